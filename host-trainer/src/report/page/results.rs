//! The page's findings: the summary (checks, notes and the generated prose), Table 2, the
//! figures with what they need, and the studies metrics.json carries.

use super::{Page, Section};
use crate::report::figures;
use crate::report::html::{self, esc};
use crate::report::summary;

/// The summary: failed checks, notes, then the prose generated from the metrics.
pub(super) fn summary(p: &Page, sections: &mut Vec<Section>) {
    let (inp, m, out) = (p.inp, &p.inp.metrics, p.out);
    // Summary.
    let mut body = String::new();
    for w in &out.warnings {
        body.push_str(&format!("<p class=\"warn\"><strong>Check failed:</strong> {}</p>\n", esc(w)));
    }
    for n in &out.notes {
        body.push_str(&format!("<p class=\"note\"><strong>Note:</strong> {}</p>\n", esc(n)));
    }
    body.push_str("<div class=\"summary\">\n");
    for p in summary::paragraphs(m, inp.meta.is_some()) {
        body.push_str(&format!("<p>{}</p>\n", esc(&p)));
    }
    body.push_str("</div>\n");
    sections.push(Section { id: "summary".into(), title: "Summary".into(), body });
}

/// Table 2: the hold-out performance.
pub(super) fn table2(p: &Page, sections: &mut Vec<Section>) {
    let table_of = |name: &str| p.table_of(name);
    // Table 2.
    sections.push(Section {
        id: "table2".into(),
        title: "Hold-out performance (Table 2)".into(),
        body: format!(
            "<p>Per channel and model on the hold-out: RMSE, MAE, R², bias (mean of estimate − truth), largest |error|, coverage of the 95 % band, hysteresis index (mean error rising − falling), Model-H's RMSE gain over Model-P and the per-sample oracle. Units are those of the channel.</p>\n{}",
            table_of("table2")
        ),
    });
}

/// The figures' sections, each saying why a figure is omitted when it is.
pub(super) fn figures(p: &Page, sections: &mut Vec<Section>) {
    let (inp, m, specs) = (p.inp, &p.inp.metrics, p.specs);
    let fig = |stem: &str| p.fig(stem);
    let table_of = |name: &str| p.table_of(name);
    let omitted2 = if specs.iter().any(|f| f.stem.starts_with("fig2")) {
        String::new()
    } else {
        format!(
            "<p class=\"note\">Figure 2 (measured vs true wavelength) is omitted: {}</p>\n",
            if inp.meta.is_none() {
                "data.meta.json is absent, and the true wavelength exists only in the simulator."
            } else {
                "the data do not match their re-simulation (see the check above)."
            }
        )
    };
    sections.push(Section {
        id: "inputs".into(),
        title: "Inputs and raw measurements (Figs. 1–2)".into(),
        body: format!("{}{}{}", fig("fig1_inputs"), omitted2, fig("fig2_wavelength_fbg1")),
    });
    sections.push(Section {
        id: "reconstructions".into(),
        title: match (0..inp.model_h.dims.n_outputs())
            .map(|ch| figures::channel_fig_no(&inp.model_h.dims, ch))
            .collect::<Vec<_>>()
            .as_slice()
        {
            [one] => format!("Reconstruction on the hold-out (Fig. {one})"),
            [first, .., last] => format!("Reconstructions on the hold-out (Figs. {first}–{last})"),
            [] => "Reconstructions on the hold-out".into(),
        },
        body: (0..inp.model_h.dims.n_outputs())
            .map(|ch| fig(&figures::channel_stem(&inp.model_h.dims, ch)))
            .collect::<String>(),
    });
    sections.push(Section {
        id: "parity".into(),
        title: "Parity and error distributions (Figs. 6–7)".into(),
        body: format!("{}{}", fig("fig6_parity"), fig("fig7_error_histograms")),
    });
    sections.push(Section {
        id: "contributions".into(),
        title: "What the memory terms and the RBF residual contribute (Fig. 9)".into(),
        body: if inp.model_h.has_memory() || !inp.model_h.centres.is_empty() {
            fig("fig9_contributions")
        } else {
            "<p class=\"note\">Model-H has neither memory terms nor RBF centres: Figure 9 is omitted.</p>\n".into()
        },
    });
    sections.push(Section {
        id: "static-fidelity".into(),
        title: "Static fidelity and the pace study (Fig. 10)".into(),
        body: format!(
            "{}{}",
            if m.static_fidelity.is_some() {
                table_of("static_fidelity")
            } else {
                "<p class=\"note\">No static gains in metrics.json (written before static fidelity).</p>\n".into()
            },
            if m.pace.is_some() {
                // The glitch study's table is there when the pace study ran it.
                format!("{}{}{}", fig("fig10_pace"), table_of("pace"), table_of("glitch"))
            } else {
                "<p class=\"note\">No pace study in metrics.json (recorded data, or written before it): Figure 10 is omitted.</p>\n".into()
            }
        ),
    });
    sections.push(Section {
        id: "drift".into(),
        title: "Drift sensitivity (Fig. 8)".into(),
        body: if m.drift_sweep.is_some() {
            format!("{}{}", fig("fig8_drift_sensitivity"), table_of("drift_sweep"))
        } else {
            "<p class=\"note\">No drift sweep in metrics.json: Figure 8 is omitted.</p>\n".into()
        },
    });
    sections.push(Section {
        id: "ablation".into(),
        title: "Ablation (Table 3) and error budget".into(),
        body: format!(
            "{}{}",
            if m.ablation.is_some() { table_of("table3") } else { "<p class=\"note\">No ablation in metrics.json.</p>\n".into() },
            if m.error_budget.is_some() {
                format!("<p>The error budget refits both models on the scenario with one artefact switched off at a time (“all”: physics and nothing else); the oracle columns are that scenario's per-sample oracle.</p>\n{}", table_of("error_budget"))
            } else {
                "<p class=\"note\">No error budget in metrics.json (it needs data.meta.json).</p>\n".into()
            }
        ),
    });
}

/// Any other study metrics.json carries, so that nothing it holds goes unshown.
pub(super) fn other_studies(p: &Page, sections: &mut Vec<Section>) {
    let results = p.results;
    let placed = ["table2", "table3", "error_budget", "drift_sweep"];
    let others: Vec<&(&'static str, crate::eval::tables::Table)> =
        results.iter().filter(|(n, _)| !placed.contains(n)).collect();
    if !others.is_empty() {
        let mut body = String::new();
        for (n, t) in others {
            body.push_str(&html::table(t, Some(n)));
        }
        sections.push(Section { id: "other-studies".into(), title: "Other studies in metrics.json".into(), body });
    }
}
