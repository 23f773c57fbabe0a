//! Coefficient tables of both models, in the trainer's [`Table`] form (so they come out as
//! Markdown, CSV and HTML from one set of rows): stage 1, the polynomial core B in physical
//! units (and as stored), the scalers, the RBF centres (standardised and physical), σ, W, the
//! hyper-parameters and the band parameters.

use fbg_shared::layout::head;

use crate::data::measurand::{input_columns, poly_term_names};
use crate::eval::metrics::Metrics;
use crate::eval::tables::Table;
use crate::fit::{HostParams, PolyCore};

/// Scientific notation with a signed two-digit exponent: 6.844992e+00.
fn e(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let s = format!("{v:.6e}");
    match s.split_once('e') {
        Some((m, x)) => {
            let x: i32 = x.parse().unwrap_or(0);
            format!("{m}e{}{:02}", if x < 0 { '-' } else { '+' }, x.abs())
        }
        None => s,
    }
}

fn g(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        e(v)
    } else {
        format!("{v:.6}")
    }
}

/// The polynomial core of a model (as read from its blob).
pub(crate) fn core_of(p: &HostParams) -> PolyCore {
    PolyCore::of(p)
}

/// Units of the polynomial terms φ_k on physical first guesses (`1`, `°C`, …, `°C²`, `°C·µε`).
fn term_units(p: &HostParams) -> Vec<String> {
    let u: Vec<&str> = p.dims.outputs().iter().map(|o| o.unit()).collect();
    (0..p.dims.poly_len())
        .map(|k| match p.dims.poly_term(k) {
            None => "1".to_string(),
            Some((i, None)) => u[i].to_string(),
            Some((i, Some(j))) if i == j => format!("{}²", u[i]),
            Some((i, Some(j))) => format!("{}·{}", u[i], u[j]),
        })
        .collect()
}

/// "{channel} [{unit}]" of each output (`T [°C]`, `strain [µε]`, …).
fn output_labels(p: &HostParams) -> Vec<String> {
    p.dims.outputs().iter().map(|o| format!("{} [{}]", o.channel(), o.unit())).collect()
}

/// The RBF input names of a model (`dl1 [pm]`, …, `T_amb [°C]`, `t [s]`, `latch1`, …).
fn z_names(p: &HostParams) -> Vec<String> {
    (0..p.dims.z_len()).map(|i| p.dims.z_name(i).as_str().to_string()).collect()
}

/// The tables and their file stems.
pub fn tables(p: &HostParams, h: &HostParams, m: &Metrics) -> Vec<(String, Table)> {
    let shared = p.stage1 == h.stage1 && p.poly == h.poly && p.guess_mean == h.guess_mean && p.guess_std == h.guess_std;
    let mut out = sensitivity_tables(p).into_iter().map(|(n, t)| (n.to_string(), t)).collect::<Vec<_>>();
    let cores: Vec<(&str, &str, &HostParams)> = if shared {
        vec![("", "Model-P and Model-H (shared core)", h)]
    } else {
        vec![("_p", "Model-P", p), ("_h", "Model-H", h)]
    };
    for (suffix, who, params) in &cores {
        out.push((format!("coef_stage1{suffix}"), stage1(params, who)));
        out.push((format!("coef_poly_physical{suffix}"), poly_physical(params, who)));
        out.push((format!("coef_poly_standardised{suffix}"), poly_standardised(params, who)));
    }
    if h.has_memory() {
        out.push(("coef_memory".into(), memory(h)));
    }
    out.push(("coef_scalers".into(), scalers(h)));
    if !h.centres.is_empty() {
        out.push(("coef_rbf_physical".into(), centres(h, true)));
        out.push(("coef_rbf_standardised".into(), centres(h, false)));
    }
    out.push(("coef_hyper".into(), hyper(p, h, m)));
    out.push(("coef_band".into(), band(p, h, m)));
    out
}

/// A number with `digits` significant digits, in plain notation where that stays readable.
fn sig(v: f64, digits: usize) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    if v == 0.0 {
        return "0".into();
    }
    let mag = v.abs().log10().floor() as i32;
    if !(-4..6).contains(&mag) {
        return format!("{v:.*e}", digits.saturating_sub(1));
    }
    format!("{v:.*}", (digits as i32 - 1 - mag).max(0) as usize)
}

/// The calibration sheet of Model-P `p` ([`crate::fit::sensitivity`]): each grating's
/// sensitivity to each measurand (pm per unit) and the model's inverse (unit per pm), with
/// T_amb's slope when the model reads a thermometer; one table saying why when the model has
/// no sensitivities. Also `inspect`'s print, so the two cannot differ.
pub fn sensitivity_tables(p: &HostParams) -> Vec<(&'static str, Table)> {
    let s = match crate::fit::sensitivity::of(p) {
        Ok(s) => s,
        Err(e) => {
            return vec![(
                "sensitivity",
                Table {
                    title: "Sensitivities at the calibration point".into(),
                    header: vec!["not available".into()],
                    rows: vec![vec![e.to_string()]],
                },
            )]
        }
    };
    let short: Vec<String> = crate::data::Measurand::of_dims(&p.dims).iter().map(|m| m.short_name()).collect();
    let gratings: Vec<String> = (1..=s.gratings).map(|g| format!("FBG{g} (dl{g}_pm)")).collect();
    let mut header = vec!["grating".to_string()];
    header.extend(short.iter().zip(s.forward_units()).map(|(n, u)| format!("∂Δλ/∂{n} [{u}]")));
    let forward = Table {
        title: format!("Sensitivity of each grating to each measurand, ∂Δλ_i/∂y_j, {}", s.how()),
        header,
        rows: s
            .forward
            .iter()
            .zip(&gratings)
            .map(|(row, g)| std::iter::once(g.clone()).chain(row.iter().map(|&v| sig(v, 5))).collect())
            .collect(),
    };
    let mut header = vec!["output".to_string()];
    header.extend((1..=s.gratings).map(|g| format!("∂ŷ/∂Δλ{g}")));
    if s.ambient.is_some() {
        header.push("∂ŷ/∂T_amb (gratings held)".into());
    }
    let rows = (0..s.outputs.len())
        .map(|j| {
            let mut r = vec![format!("{} [{}]", short[j], s.inverse_units()[j])];
            r.extend(s.inverse[j].iter().map(|&v| sig(v, 5)));
            if let Some(a) = &s.ambient {
                r.push(format!("{} {}/°C", sig(a[j], 5), s.units[j]));
            }
            r
        })
        .collect();
    let inverse = Table {
        title: "The model's inverse, ∂ŷ_j/∂Δλ_i: each output's change per pm of each grating (same point and map)"
            .into(),
        header,
        rows,
    };
    vec![("sensitivity", forward), ("sensitivity_inverse", inverse)]
}

fn stage1(p: &HostParams, who: &str) -> Table {
    let dims = &p.dims;
    let mut inputs: Vec<String> = (1..=dims.gratings()).map(|g| format!("Δλ{g}")).collect();
    if dims.ambient() {
        inputs.push("T_amb".into());
    }
    let mut header = vec!["output".to_string()];
    header.extend((1..=dims.gratings()).map(|g| format!("× Δλ{g} [pm]")));
    if dims.ambient() {
        header.push("× T_amb [°C]".into());
    }
    header.push("constant".into());
    let rows = dims
        .outputs()
        .iter()
        .enumerate()
        .map(|(o, out)| {
            let mut r = vec![format!("{} guess [{}]", out.channel(), out.unit())];
            r.extend(head(&p.stage1[o], dims.stage1_len()).iter().map(|v| e(*v)));
            r
        })
        .collect();
    Table {
        title: format!("Stage 1 (linear inverse) of {who}: first guess = A · [{}, 1]", inputs.join(", ")),
        header,
        rows,
    }
}

fn poly_physical(p: &HostParams, who: &str) -> Table {
    let b = core_of(p).physical_coefficients();
    let m = p.dims.n_outputs();
    let mut header = vec!["term φ_k".to_string(), "unit of φ_k".to_string()];
    header.extend(output_labels(p));
    let (names, units) = (poly_term_names(&p.dims), term_units(p));
    let rows = (0..names.len())
        .map(|k| {
            let mut r = vec![names[k].clone(), units[k].clone()];
            r.extend((0..m).map(|o| e(b[o][k])));
            r
        })
        .collect();
    let hats: Vec<String> =
        crate::data::Measurand::of_dims(&p.dims).iter().map(|x| format!("{}̂", x.short_name())).collect();
    let us: Vec<&str> = p.dims.outputs().iter().map(|o| o.unit()).collect();
    Table {
        title: format!(
            "Polynomial core B of {who} in physical units: output = Σ_k c_k φ_k({}) on the first guesses in {}; a coefficient's unit is the output's unit divided by the unit of φ_k",
            hats.join(", "),
            us.join(", ")
        ),
        header,
        rows,
    }
}

fn poly_standardised(p: &HostParams, who: &str) -> Table {
    let mut header = vec!["term φ_k".to_string()];
    header.extend(output_labels(p));
    let names = poly_term_names(&p.dims);
    let rows = (0..names.len())
        .map(|k| {
            let mut r = vec![names[k].clone()];
            r.extend((0..p.dims.n_outputs()).map(|o| e(p.poly[o][k])));
            r
        })
        .collect();
    Table {
        title: format!(
            "Polynomial core B of {who} as stored in the blob (on standardised first guesses (ĝ − mean)/std)"
        ),
        header,
        rows,
    }
}

/// Γ of Model-H: every used memory term with its meaning, unit and coefficient per output.
fn memory(h: &HostParams) -> Table {
    let mut header = ["term", "meaning", "unit"].map(String::from).to_vec();
    header.extend(h.dims.outputs().iter().map(|o| format!("Γ → {} [{} per unit]", o.channel(), o.unit())));
    let rows = (0..h.dims.memory_len())
        .filter_map(|k| h.memory.term(&h.dims, k).filter(|t| t.parameter > 0.0).map(|t| (k, t)))
        .map(|(k, t)| {
            let mut r = vec![
                format!("m{k} ({})", t.group.name()),
                crate::export::memory_term_meaning(&t),
                t.group.unit().to_string(),
            ];
            r.extend((0..h.dims.n_outputs()).map(|o| e(h.gamma[o][k])));
            r
        })
        .collect();
    Table {
        title: "Memory terms of Model-H: ŷ = Bφ + Γm + Wψ; each term m_k is level-free (a signal minus its own low-pass or play operator), Γ was fitted on what the core Bφ leaves (ridge on the standardised terms); 0 where cross-validation left a group out for that output".into(),
        header,
        rows,
    }
}

fn scalers(h: &HostParams) -> Table {
    let mut rows = Vec::new();
    for (o, label) in output_labels(h).iter().enumerate() {
        rows.push(vec![format!("first guess {label}"), g(h.guess_mean[o]), g(h.guess_std[o]), "yes".into()]);
    }
    let active = h.dims.z_active(h.hyper.feature_set);
    let names = z_names(h);
    for d in 0..names.len() {
        rows.push(vec![
            format!("RBF input {}", names[d]),
            g(h.z_mean[d]),
            g(h.z_std[d]),
            if active[d] { "yes" } else { "no" }.into(),
        ]);
    }
    Table {
        title: "Scalers: standardisation of the first guesses (polynomial core) and of the RBF inputs z (Model-H)"
            .into(),
        header: ["quantity", "mean", "std", "used"].map(String::from).to_vec(),
        rows,
    }
}

fn centres(h: &HostParams, physical: bool) -> Table {
    let active = h.dims.z_active(h.hyper.feature_set);
    let names = z_names(h);
    let dims: Vec<usize> = (0..names.len()).filter(|&d| active[d]).collect();
    let mut header = vec!["centre j".to_string()];
    header.extend(dims.iter().map(|&d| format!("μ {}", names[d])));
    if physical {
        header.extend(output_labels(h).iter().map(|l| format!("w {l}")));
    }
    let rows = h
        .centres
        .iter()
        .enumerate()
        .map(|(j, c)| {
            let mut r = vec![j.to_string()];
            for &d in &dims {
                let v = if physical { h.z_mean[d] + c.mu[d] * h.z_std[d] } else { c.mu[d] };
                r.push(g(v));
            }
            if physical {
                r.extend(head(&c.w, h.dims.n_outputs()).iter().map(|v| e(*v)));
            }
            r
        })
        .collect();
    let sigma = h.hyper.sigma;
    Table {
        title: if physical {
            format!(
                "RBF centres of Model-H in physical units (μ = mean + μ_std · std) with their residual weights W; width σ = {} in standardised units (= {} × the median nearest-neighbour distance); ψ_j = exp(−|z_std − μ_j|² / (2σ²))",
                g(sigma),
                g(h.hyper.sigma_mult)
            )
        } else {
            format!("RBF centres of Model-H in standardised units (as stored); σ = {}", g(sigma))
        },
        header,
        rows,
    }
}

fn hyper(p: &HostParams, h: &HostParams, m: &Metrics) -> Table {
    let c = &m.selection.chosen;
    let hh = &h.hyper;
    let n_cal = h.provenance.n_cal;
    let row = |a: &str, b: String, note: &str| vec![a.to_string(), b, note.to_string()];
    let cv = |v: &[f64]| v.iter().map(|x| g(*x)).collect::<Vec<_>>().join(" / ");
    let outs = m.channels.iter().map(|c| c.replacen("strain", "ε", 1)).collect::<Vec<_>>().join(" / ");
    let env = format!(
        "({})",
        input_columns(&h.dims)
            .iter()
            .map(|c| c.replace("_pm", " [pm]").replace("T_amb_C", "T_amb [°C]"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    let n_env = h.dims.envelope_len();
    let rows = vec![
        row("feature set (RBF inputs)", hh.feature_set.name().to_string(), "chosen by blocked forward-chaining CV"),
        row("RBF centres K", h.centres.len().to_string(), "k-means++ on the calibration inputs"),
        row("σ (standardised)", g(hh.sigma), ""),
        row("σ multiplier", g(hh.sigma_mult), "× median nearest-neighbour distance between centres"),
        row("ridge α (Eq. 7)", g(hh.alpha), &format!("= α_rel · n_cal, α_rel = {}, n_cal = {n_cal}", g(c.alpha_rel))),
        row(
            "direction-latch dead band",
            format!("{} pm", g(hh.dead_band_pm)),
            if hh.feature_set.uses_latch() { "" } else { "unused by this feature set" },
        ),
        row("cross-terms in stage 2", c.cross_terms.to_string(), ""),
        row("weak-support threshold on max ψ", g(hh.weak_support), "flag WEAK_SUPPORT below it"),
        row("envelope margin", g(hh.envelope_margin), "fraction of the calibration range on each side"),
        row("band factor for flagged samples", g(hh.flagged_band_factor), ""),
        row(
            &format!("envelope low {env}"),
            head(&h.envelope_lo, n_env).iter().map(|v| g(*v)).collect::<Vec<_>>().join(" / "),
            "",
        ),
        row(
            &format!("envelope high {env}"),
            head(&h.envelope_hi, n_env).iter().map(|v| g(*v)).collect::<Vec<_>>().join(" / "),
            "",
        ),
        row(
            "CV grid points",
            m.selection.grid_points.to_string(),
            if m.selection.grid_points == 0 { "not recorded (metrics from `evaluate`)" } else { "" },
        ),
        row(&format!("CV RMSE Model-P ({outs})"), cv(&m.selection.cv_rmse_p), ""),
        row(&format!("CV RMSE Model-H ({outs})"), cv(&m.selection.cv_rmse_h), ""),
        row("Model-P centres", p.centres.len().to_string(), "0 for a polynomial-only model"),
    ];
    Table {
        title: "Hyper-parameters of Model-H (from its blob) and the cross-validation behind them (metrics.json)".into(),
        header: ["parameter", "value", "note"].map(String::from).to_vec(),
        rows,
    }
}

fn band(p: &HostParams, h: &HostParams, m: &Metrics) -> Table {
    let mut rows = Vec::new();
    let models = [
        ("Model-P", p, &m.table2.model_p, &m.selection.var_model_p),
        ("Model-H", h, &m.table2.model_h, &m.selection.var_model_h),
    ];
    for (name, q, me, vm) in models {
        for (o, label) in output_labels(h).iter().enumerate() {
            let fitted = vm.get(o).map_or(String::from("–"), |v| format!("{} ± {}", g(v.b_fitted), g(v.b_se)));
            rows.push(vec![
                name.to_string(),
                label.clone(),
                g(q.resid_var[o]),
                g(q.resid_var_growth[o]),
                fitted,
                g(q.band_k[o]),
                g(q.resid_var[o].sqrt() * q.band_k[o]),
                g(me.channels[o].mean_band),
                format!("{:.1}", 100.0 * me.channels[o].coverage),
                vm.get(o)
                    .filter(|v| v.cv_coverage.is_finite())
                    .map_or(String::from("–"), |v| format!("{:.1}", 100.0 * v.cv_coverage)),
                vm.get(o)
                    .filter(|v| v.lead_max_s.is_finite())
                    .map_or(String::from("–"), |v| format!("{:.1}", v.lead_max_s / 3600.0)),
            ]);
        }
    }
    Table {
        title: format!(
            "95 % band parameters: half-width = k95 · sqrt(s²(τ) · (1 + leverage)) (× the flagged-band factor for flagged samples), s²(τ) = a + b·τ with τ the time since the end of calibration (t = {} s); b is the fitted growth shrunk by t²/(1 + t²), t = fitted / se; a is at least the cross-validated error at the shortest leads; a record without absolute time gets the band at the largest validated lead (flag lead-unknown)",
            g(h.t_cal_end_s)
        ),
        header: ["model", "output", "a = s² at cal end [unit²]", "b = growth [unit²/s]", "growth as fitted ± se [unit²/s]", "k95", "half-width at τ = 0", "mean half-width on hold-out", "coverage % (hold-out)", "coverage % (cross-validated)", "largest validated lead [h]"]
            .map(String::from)
            .to_vec(),
        rows,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scientific_cells_have_signed_exponents() {
        assert_eq!(e(6.844992), "6.844992e+00");
        assert_eq!(e(-1.392361e-3), "-1.392361e-03");
        assert_eq!(e(f64::NAN), "–");
        assert_eq!(g(0.5), "0.500000");
        assert_eq!(g(3.9e-9), "3.900000e-09");
        assert_eq!(sig(10.856753, 5), "10.857");
        assert_eq!(sig(0.0190727, 5), "0.019073");
        assert_eq!(sig(-0.000495114, 3), "-0.000495");
        assert_eq!(sig(1.2e-7, 3), "1.20e-7");
    }
}
