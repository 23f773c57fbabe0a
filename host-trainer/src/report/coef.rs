//! Coefficient tables of both models, in the trainer's [`Table`] form (so they come out as
//! Markdown, CSV and HTML from one set of rows): stage 1, the polynomial core B in physical
//! units (and as stored), the scalers, the RBF centres (standardised and physical), σ, W, the
//! hyper-parameters and the band parameters.

use fbg_shared::layout::paper::{N_OUTPUTS, POLY_NAMES, Z_DIMS, Z_NAMES};

use crate::eval::metrics::Metrics;
use crate::eval::score::UNITS;
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
pub fn core_of(p: &HostParams) -> PolyCore {
    PolyCore::of(p)
}

/// Units of the polynomial terms φ_k on physical first guesses.
const TERM_UNITS: [&str; 10] = ["1", "°C", "µε", "kPa", "°C²", "µε²", "kPa²", "°C·µε", "°C·kPa", "µε·kPa"];

/// The tables and their file stems.
pub fn tables(p: &HostParams, h: &HostParams, m: &Metrics) -> Vec<(String, Table)> {
    let shared = p.stage1 == h.stage1 && p.poly == h.poly && p.guess_mean == h.guess_mean && p.guess_std == h.guess_std;
    let mut out = Vec::new();
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

fn stage1(p: &HostParams, who: &str) -> Table {
    let header =
        ["output", "× Δλ1 [pm]", "× Δλ2 [pm]", "× Δλ3 [pm]", "× T_amb [°C]", "constant"].map(String::from).to_vec();
    let rows = (0..N_OUTPUTS)
        .map(|o| {
            let mut r = vec![format!("{} guess [{}]", crate::eval::score::CHANNELS[o], UNITS[o])];
            r.extend(p.stage1[o].iter().map(|v| e(*v)));
            r
        })
        .collect();
    Table {
        title: format!("Stage 1 (linear inverse) of {who}: first guess = A · [Δλ1, Δλ2, Δλ3, T_amb, 1]"),
        header,
        rows,
    }
}

fn poly_physical(p: &HostParams, who: &str) -> Table {
    let b = core_of(p).physical_coefficients();
    let header = ["term φ_k", "unit of φ_k", "T [°C]", "strain [µε]", "p [kPa]"].map(String::from).to_vec();
    let rows = (0..POLY_NAMES.len())
        .map(|k| vec![POLY_NAMES[k].to_string(), TERM_UNITS[k].to_string(), e(b[0][k]), e(b[1][k]), e(b[2][k])])
        .collect();
    Table {
        title: format!(
            "Polynomial core B of {who} in physical units: output = Σ_k c_k φ_k(T̂, ε̂, p̂) on the first guesses in °C, µε, kPa; a coefficient's unit is the output's unit divided by the unit of φ_k"
        ),
        header,
        rows,
    }
}

fn poly_standardised(p: &HostParams, who: &str) -> Table {
    let header = ["term φ_k", "T [°C]", "strain [µε]", "p [kPa]"].map(String::from).to_vec();
    let rows = (0..POLY_NAMES.len())
        .map(|k| vec![POLY_NAMES[k].to_string(), e(p.poly[0][k]), e(p.poly[1][k]), e(p.poly[2][k])])
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
    let header = ["term", "meaning", "unit", "Γ → T [°C per unit]", "Γ → strain [µε per unit]", "Γ → p [kPa per unit]"]
        .map(String::from)
        .to_vec();
    let rows = (0..fbg_shared::layout::paper::N_MEMORY)
        .filter_map(|k| h.memory.term(&h.dims, k).filter(|t| t.parameter > 0.0).map(|t| (k, t)))
        .map(|(k, t)| {
            vec![
                format!("m{k} ({})", t.group.name()),
                crate::export::memory_term_meaning(&t),
                t.group.unit().to_string(),
                e(h.gamma[0][k]),
                e(h.gamma[1][k]),
                e(h.gamma[2][k]),
            ]
        })
        .collect();
    Table {
        title: "Memory terms of Model-H: ŷ = Bφ + Γm + Wψ; each term m_k is level-free (a signal minus its own low-pass or play operator), Γ was fitted jointly with B (ridge on the standardised terms); 0 where cross-validation left a group out for that output".into(),
        header,
        rows,
    }
}

fn scalers(h: &HostParams) -> Table {
    let mut rows = Vec::new();
    for (o, (name, unit)) in crate::eval::score::CHANNELS.iter().zip(UNITS).enumerate() {
        rows.push(vec![format!("first guess {name} [{unit}]"), g(h.guess_mean[o]), g(h.guess_std[o]), "yes".into()]);
    }
    let active = h.hyper.feature_set.active();
    for d in 0..Z_DIMS {
        rows.push(vec![
            format!("RBF input {}", Z_NAMES[d]),
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
    let active = h.hyper.feature_set.active();
    let dims: Vec<usize> = (0..Z_DIMS).filter(|&d| active[d]).collect();
    let mut header = vec!["centre j".to_string()];
    header.extend(dims.iter().map(|&d| format!("μ {}", Z_NAMES[d])));
    if physical {
        header.extend(["w T [°C]", "w strain [µε]", "w p [kPa]"].map(String::from));
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
                r.extend(c.w.iter().map(|v| e(*v)));
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
    let cv = |v: [f64; 3]| v.iter().map(|x| g(*x)).collect::<Vec<_>>().join(" / ");
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
            "envelope low (Δλ1..3 [pm], T_amb [°C])",
            h.envelope_lo.iter().map(|v| g(*v)).collect::<Vec<_>>().join(" / "),
            "",
        ),
        row(
            "envelope high (Δλ1..3 [pm], T_amb [°C])",
            h.envelope_hi.iter().map(|v| g(*v)).collect::<Vec<_>>().join(" / "),
            "",
        ),
        row(
            "CV grid points",
            m.selection.grid_points.to_string(),
            if m.selection.grid_points == 0 { "not recorded (metrics from `evaluate`)" } else { "" },
        ),
        row("CV RMSE Model-P (T / ε / p)", cv(m.selection.cv_rmse_p), ""),
        row("CV RMSE Model-H (T / ε / p)", cv(m.selection.cv_rmse_h), ""),
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
        for (o, (ch, unit)) in crate::eval::score::CHANNELS.iter().zip(UNITS).enumerate() {
            let fitted = vm.get(o).map_or(String::from("–"), |v| format!("{} ± {}", g(v.b_fitted), g(v.b_se)));
            rows.push(vec![
                name.to_string(),
                format!("{ch} [{unit}]"),
                g(q.resid_var[o]),
                g(q.resid_var_growth[o]),
                fitted,
                g(q.band_k[o]),
                g(q.resid_var[o].sqrt() * q.band_k[o]),
                g(me.channels[o].mean_band),
                format!("{:.1}", 100.0 * me.channels[o].coverage),
            ]);
        }
    }
    Table {
        title: format!(
            "95 % band parameters: half-width = k95 · sqrt(s²(τ) · (1 + leverage)) (× the flagged-band factor for flagged samples), s²(τ) = a + b·τ with τ the time since the end of calibration (t = {} s); b is the fitted growth shrunk by t²/(1 + t²), t = fitted / se",
            g(h.t_cal_end_s)
        ),
        header: ["model", "output", "a = s² at cal end [unit²]", "b = growth [unit²/s]", "growth as fitted ± se [unit²/s]", "k95", "half-width at τ = 0", "mean half-width on hold-out", "coverage %"]
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
    }
}
