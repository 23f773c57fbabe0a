//! Tables 2 and 3, the error budget and the drift sweep as aligned text (terminal), Markdown
//! and CSV (report). One renderer per table, three formats from the same rows, so the formats
//! can never disagree.

use crate::eval::metrics::{AblationRow, BudgetRow, DriftSweep, Metrics, RecalStudy};

/// A rectangular table: header and rows of cells.
#[derive(Clone, Debug, Default)]
pub struct Table {
    pub title: String,
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    /// Aligned plain text.
    pub fn text(&self) -> String {
        let n = self.header.len();
        let mut w = vec![0usize; n];
        for r in std::iter::once(&self.header).chain(self.rows.iter()) {
            for (i, c) in r.iter().enumerate().take(n) {
                w[i] = w[i].max(c.chars().count());
            }
        }
        let line = |r: &Vec<String>| {
            r.iter()
                .enumerate()
                .map(|(i, c)| {
                    let pad = w[i] - c.chars().count();
                    if i == 0 {
                        format!("{c}{}", " ".repeat(pad))
                    } else {
                        format!("{}{c}", " ".repeat(pad))
                    }
                })
                .collect::<Vec<_>>()
                .join("  ")
        };
        let mut out = format!("{}\n{}\n", self.title, line(&self.header));
        out.push_str(&"-".repeat(w.iter().sum::<usize>() + 2 * (n - 1)));
        out.push('\n');
        for r in &self.rows {
            out.push_str(&line(r));
            out.push('\n');
        }
        out
    }
    /// GitHub-flavoured Markdown (a `|` inside a cell is escaped).
    pub fn markdown(&self) -> String {
        let row = |r: &Vec<String>| r.iter().map(|c| c.replace('|', "\\|")).collect::<Vec<_>>().join(" | ");
        let mut out = format!("| {} |\n|{}\n", row(&self.header), "---|".repeat(self.header.len()));
        for r in &self.rows {
            out.push_str(&format!("| {} |\n", row(r)));
        }
        out
    }
    /// CSV (RFC 4180 quoting). A comma inside a cell is written as a semicolon and a line
    /// break as a space, so that every row has the header's number of cells also for a
    /// reader that knows no quoting (`numpy.genfromtxt(path, names=True, delimiter=",")`).
    pub fn csv(&self) -> String {
        let q = |c: &String| {
            let c = c.replace(',', ";").replace(['\r', '\n'], " ");
            if c.contains('"') {
                format!("\"{}\"", c.replace('"', "\"\""))
            } else {
                c
            }
        };
        let mut out = String::new();
        for r in std::iter::once(&self.header).chain(self.rows.iter()) {
            out.push_str(&r.iter().map(q).collect::<Vec<_>>().join(","));
            out.push('\n');
        }
        out
    }
}

fn f(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        "–".into()
    }
}

/// Decimals that suit a channel's magnitude, by unit (°C: 3, µε and kPa: 2).
fn digits(unit: &str) -> usize {
    if unit == "°C" {
        3
    } else {
        2
    }
}

/// Decimals of each output of `m`.
fn all_digits(m: &Metrics) -> Vec<usize> {
    m.units.iter().map(|u| digits(u)).collect()
}

/// The symbol of a channel for compact headers: `T`, `ε`, `ε2`, `p`.
fn symbol(channel: &str) -> String {
    channel.replacen("strain", "ε", 1)
}

/// Per output, "{symbol} {suffix}" for each suffix: compact column headers.
fn per_output_headers(m: &Metrics, suffixes: &[&str]) -> Vec<String> {
    m.channels.iter().flat_map(|c| suffixes.iter().map(move |s| format!("{} {s}", symbol(c)))).collect()
}

/// Where the record came from: "paper, seed 7" for a simulated one (its `.meta.json` gave the
/// oracle and the seed), "“site3” (recorded data)" for a recorded one, which has no seed.
pub(crate) fn origin_label(m: &Metrics) -> String {
    if m.table2.oracle_floor.is_some() {
        format!("{}, seed {}", m.scenario, m.seed)
    } else {
        format!("“{}” (recorded data)", m.scenario)
    }
}

/// How many hold-out samples there were and how many were scored: rows with a gap (a missing
/// input or reference) are skipped, and the label says so.
pub(crate) fn holdout_label(m: &Metrics) -> String {
    let scored = m.table2.model_h.channels.iter().map(|c| c.n).max().unwrap_or(0);
    if scored == m.holdout_samples {
        format!("{} hold-out samples", m.holdout_samples)
    } else {
        format!(
            "{} hold-out samples, {scored} scored: {} with gaps skipped",
            m.holdout_samples,
            m.holdout_samples.saturating_sub(scored)
        )
    }
}

/// The flags raised on the hold-out, per flag: a line for a terminal. (What deserves a
/// warning is [`Metrics::warnings`], printed beside it.)
pub fn flag_line(m: &Metrics) -> String {
    let t = &m.table2;
    let n = t.model_h.channels.iter().map(|c| c.n).max().unwrap_or(0).max(1) as f64;
    let pct = |k: usize| 100.0 * k as f64 / n;
    let fc = t.model_h.flag_counts;
    format!(
        "Model-H flags on the hold-out: {:.1} % of samples flagged — {:.1} % non-finite, {:.1} % outside the calibration envelope, {:.1} % weak RBF support, {:.1} % implausible, {:.1} % fallen back to Model-P (memory not trusted: a hold longer than the calibration's, or a refused sample)",
        100.0 * t.model_h.flagged_fraction,
        pct(fc[0]),
        pct(fc[1]),
        pct(fc[2]),
        pct(fc[3]),
        pct(fc[4])
    )
}

/// Table 2: hold-out performance, both models, with the per-sample oracle.
pub fn table2(m: &Metrics) -> Table {
    let t = &m.table2;
    let mut rows = Vec::new();
    for c in 0..m.channels.len() {
        let dg = digits(&m.units[c]);
        for (name, e) in [("Model-P", &t.model_p), ("Model-H", &t.model_h)] {
            let ch = &e.channels[c];
            rows.push(vec![
                format!("{} [{}]", m.channels[c], m.units[c]),
                name.to_string(),
                f(ch.rmse, dg),
                f(ch.mae, dg),
                f(ch.r2, 4),
                f(ch.bias, dg),
                f(ch.max_abs, dg),
                f(100.0 * ch.coverage, 1),
                f(ch.hysteresis_index, dg),
                if name == "Model-H" { f(t.gain_pct[c], 1) } else { String::new() },
                t.oracle_floor.as_ref().map(|o| f(o[c], dg)).unwrap_or_default(),
            ]);
        }
    }
    Table {
        title: format!("Table 2. Hold-out performance ({}, {})", origin_label(m), holdout_label(m)),
        header: [
            "channel",
            "model",
            "RMSE",
            "MAE",
            "R²",
            "bias",
            "max|e|",
            "coverage %",
            "hyst. index",
            "gain %",
            "per-sample oracle",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    }
}

/// Table 3: ablation for every channel (RMSE).
pub fn table3(rows: &[AblationRow], m: &Metrics) -> Table {
    let base = rows.first().map(|r| &r.channels);
    let dg = all_digits(m);
    let mut out = Vec::new();
    for r in rows {
        let mut cells = vec![r.name.clone()];
        for c in 0..m.channels.len() {
            cells.push(f(r.channels[c].rmse, dg[c]));
            cells.push(base.map(|b| f(100.0 * (b[c].rmse - r.channels[c].rmse) / b[c].rmse, 1)).unwrap_or_default());
        }
        cells.push(r.note.clone());
        out.push(cells);
    }
    Table {
        title: format!("Table 3. Ablation, hold-out RMSE ({}, seed {})", m.scenario, m.seed),
        header: std::iter::once("configuration".to_string())
            .chain(m.channels.iter().zip(&m.units).flat_map(|(c, u)| [format!("{c} [{u}]"), "gain %".to_string()]))
            .chain(std::iter::once("notes".to_string()))
            .collect(),
        rows: out,
    }
}

/// Error budget: hold-out RMSE with each artefact switched off.
pub fn budget(rows: &[BudgetRow], m: &Metrics) -> Table {
    let mut out = Vec::new();
    for r in rows {
        let name = if r.not_fitted.is_some() { format!("{} (not fitted)", r.effect_off) } else { r.effect_off.clone() };
        let mut cells = vec![name];
        for (c, &digits) in all_digits(m).iter().enumerate() {
            cells.push(f(r.rmse_p[c], digits));
            cells.push(f(r.rmse_h[c], digits));
            cells.push(f(r.oracle_floor[c], digits));
        }
        out.push(cells);
    }
    Table {
        title: format!("Error budget: hold-out RMSE with one artefact switched off ({}, seed {})", m.scenario, m.seed),
        header: std::iter::once("switched off".to_string())
            .chain(per_output_headers(m, &["P", "H", "oracle"]))
            .collect(),
        rows: out,
    }
}

/// Drift sweep points and slopes.
pub fn drift(s: &DriftSweep, m: &Metrics) -> Table {
    let mut rows = Vec::new();
    for (i, x) in s.sigma_d_pm.iter().enumerate() {
        let mut cells = vec![format!("{:.3}", x), format!("×{}", s.factors[i])];
        for (c, &digits) in all_digits(m).iter().enumerate() {
            cells.push(f(s.rmse_p[i][c], digits));
            cells.push(f(s.rmse_h[i][c], digits));
        }
        rows.push(cells);
    }
    let mut slope = vec!["slope per pm/step".to_string(), String::new()];
    for (c, &digits) in all_digits(m).iter().enumerate() {
        slope.push(f(s.slope_p[c], digits));
        slope.push(f(s.slope_h[c], digits));
    }
    rows.push(slope);
    Table {
        title: format!("Drift sweep: hold-out RMSE vs σ_d, both models refitted ({}, seed {})", m.scenario, m.seed),
        header: ["σ_d [pm/step]".to_string(), "factor".to_string()]
            .into_iter()
            .chain(per_output_headers(m, &["P", "H"]))
            .collect(),
        rows,
    }
}

/// Field recalibration study: the old model, a short-batch recalibration and a full refit on a
/// changed installation.
pub fn recalibration(rs: &[RecalStudy], m: &Metrics) -> Table {
    let mut rows = Vec::new();
    let dg = all_digits(m);
    for r in rs {
        for (name, h, p) in [
            ("old model, no recalibration", &r.h_old, &r.p_old),
            ("short-batch recalibration", &r.h_short, &r.p_short),
            ("full recalibration", &r.h_full, &r.p_full),
        ] {
            let mut cells = vec![format!("{} h ({} samples)", r.batch_hours, r.batch_samples), name.to_string()];
            for c in 0..dg.len() {
                cells.push(f(p[c], dg[c]));
                cells.push(f(h[c], dg[c]));
            }
            rows.push(cells);
        }
        let mut cells = vec![String::new(), "gain recovered by the batch (Model-H) %".to_string()];
        for c in 0..dg.len() {
            cells.push(String::new());
            cells.push(f(100.0 * r.recovered_fraction_h[c], 0));
        }
        rows.push(cells);
    }
    Table {
        title: format!(
            "Field recalibration: hold-out RMSE on a changed installation (new dispersion, drift and environment; {}, seed {} → {})",
            m.scenario,
            m.seed,
            rs.first().map(|r| r.seed_new).unwrap_or(0)
        ),
        header: ["batch".to_string(), "model state".to_string()]
            .into_iter()
            .chain(per_output_headers(m, &["P", "H"]))
            .collect(),
        rows,
    }
}

/// The pace study: both models on the installation at other paces and on a steps record.
pub fn pace(s: &crate::eval::pace::PaceStudy, m: &Metrics) -> Table {
    let dg = all_digits(m);
    let mut rows = Vec::new();
    for r in &s.rows {
        let mut cells = vec![r.label.clone()];
        for (c, &digits) in dg.iter().enumerate() {
            cells.push(f(r.rmse_p[c], digits));
            cells.push(f(r.rmse_h[c], digits));
            cells.push(f(r.gain_pct(c), 1));
            cells.push(f(100.0 * r.coverage_h[c], 1));
        }
        rows.push(cells);
        if !r.slope_p.is_empty() {
            let mut cells = vec![format!("steps: settled slope ({} holds)", r.holds)];
            for c in 0..dg.len() {
                cells.push(f(r.slope_p[c], 4));
                cells.push(f(r.slope_h[c], 4));
                cells.push(String::new());
                cells.push(String::new());
            }
            rows.push(cells);
        }
    }
    Table {
        title: format!(
            "Pace study: hold-out RMSE of the models calibrated at the native pace, on the same installation at other paces (×¼ = four times slower) and on a steps record ({}, seed {})",
            s.scenario, s.seed
        ),
        header: std::iter::once("record".to_string()).chain(per_output_headers(m, &["P", "H", "gain %", "H cov %"])).collect(),
        rows,
    }
}

/// The glitch study: one bad sample in one input of the hold-out, and its trace in later rows.
pub fn glitch(s: &crate::eval::pace::PaceStudy) -> Table {
    let rows = s
        .glitch
        .iter()
        .map(|g| {
            vec![
                g.input.clone(),
                g.value.clone(),
                f(g.t_s.unwrap_or(f64::NAN), 0),
                if g.flagged { "yes".into() } else { "NO".into() },
                g.later_rows.map_or("–".into(), |n| n.to_string()),
                g.rows_beyond_band.to_string(),
                f(g.worst_ratio.unwrap_or(f64::NAN), 3),
            ]
        })
        .collect();
    Table {
        title: format!(
            "Glitch study: Model-H on the hold-out with one sample of one input replaced, against the clean record ({}, seed {}); a later row is beyond when some output moved by more than its band",
            s.scenario, s.seed
        ),
        header: ["input", "glitch", "t [s]", "row flagged", "later rows", "rows beyond band", "worst |Δ|/band"]
            .iter()
            .map(|h| h.to_string())
            .collect(),
        rows,
    }
}

/// Static fidelity: both models' static gains over the calibration batch and what Model-H's
/// dynamic parts add.
pub fn static_fidelity(sf: &crate::eval::metrics::StaticFidelity, m: &Metrics) -> Table {
    let dg = all_digits(m);
    let mut rows = vec![
        std::iter::once("static gain, Model-P".to_string())
            .chain(sf.gain_p.iter().map(|&v| f(v, 4)))
            .collect::<Vec<_>>(),
        std::iter::once("static gain, Model-H".to_string()).chain(sf.gain_h.iter().map(|&v| f(v, 4))).collect(),
    ];
    for (part, v) in &sf.contributions {
        rows.push(
            std::iter::once(format!("RMS added by {part}"))
                .chain(v.iter().zip(&dg).map(|(&x, &d)| f(x, d + 1)))
                .collect(),
        );
    }
    Table {
        title: format!(
            "Static fidelity: slope of the truth on the settled reading (high-pass memory terms at 0) over the calibration batch (1 is right), and what Model-H's dynamic parts add ({})",
            origin_label(m)
        ),
        header: std::iter::once("quantity".to_string())
            .chain(m.channels.iter().zip(&m.units).map(|(c, u)| format!("{c} [{u}]")))
            .collect(),
        rows,
    }
}

/// Every table of a metrics set with its file name.
pub fn all(m: &Metrics) -> Vec<(&'static str, Table)> {
    let mut v = vec![("table2", table2(m))];
    if let Some(a) = &m.ablation {
        v.push(("table3", table3(a, m)));
    }
    if let Some(b) = &m.error_budget {
        v.push(("error_budget", budget(b, m)));
    }
    if let Some(d) = &m.drift_sweep {
        v.push(("drift_sweep", drift(d, m)));
    }
    if let Some(r) = &m.recalibration {
        v.push(("recalibration", recalibration(r, m)));
    }
    if let Some(sf) = &m.static_fidelity {
        v.push(("static_fidelity", static_fidelity(sf, m)));
    }
    if let Some(p) = &m.pace {
        v.push(("pace", pace(p, m)));
        if !p.glitch.is_empty() {
            v.push(("glitch", glitch(p)));
        }
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn markdown_escapes_pipes_and_csv_quotes() {
        let t = Table {
            title: "t".into(),
            header: vec!["a".into(), "max|e|".into()],
            rows: vec![vec!["x, y".into(), "\"q\"".into()]],
        };
        let md = t.markdown();
        assert!(md.starts_with("| a | max\\|e\\| |\n|---|---|\n"), "{md}");
        assert_eq!(t.csv(), "a,max|e|\nx; y,\"\"\"q\"\"\"\n");
        assert!(t.text().contains("max|e|"));
    }
}
