//! The studies' figures: drift sensitivity (Fig. 8), Model-H's parts (Fig. 9) and the pace
//! study (Fig. 10); each only when metrics.json (or Model-H) has what it needs.

use super::{decimation_note, height, letter, num, pts, Ctx, FigSpec, COLUMNS, WIDTH};
use crate::report::chart::{Dots, Grid, Legend, Line, Panel, C_GREY, C_H, C_P};
use crate::report::decimate::minmax_columns;

/// Fig. 8: drift sensitivity (needs the drift sweep in the metrics).
pub(crate) fn fig8_drift(c: &Ctx) -> Option<FigSpec> {
    let s = c.metrics.drift_sweep.as_ref()?;
    let mut panels = Vec::new();
    let nominal = s.factors.iter().position(|&f| f == 1.0).map(|i| s.sigma_d_pm[i]);
    let xs = &s.sigma_d_pm;
    let xmin = xs.iter().cloned().fold(f64::INFINITY, f64::min);
    let xmax = xs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let pad = 0.05 * (xmax - xmin).max(1e-12);
    let (lo, hi) = (xmin - pad, xmax + pad);
    for ch in 0..c.n_channels().min(s.slope_p.len()) {
        let nm = c.names(ch);
        let (unit, dg) = (nm.unit, nm.digits);
        let mut p = Panel::new(
            format!("({}) {}", letter(ch), nm.long),
            "drift amplitude σ_d [pm per step]",
            format!("hold-out RMSE [{unit}]"),
        );
        p.xr = Some((lo, hi));
        p.y_pad = 0.15;
        for (name, ys, slope, icpt, color, filled) in [
            ("Model-P", &s.rmse_p, s.slope_p[ch], s.intercept_p[ch], C_P, true),
            ("Model-H", &s.rmse_h, s.slope_h[ch], s.intercept_h[ch], C_H, false),
        ] {
            let pts: Vec<(f64, f64)> = xs.iter().zip(ys.iter()).map(|(&x, y)| (x, y[ch])).collect();
            p.dots.push(Dots {
                label: Some(format!("{name} (refitted at each σ_d)")),
                color,
                alpha: 1.0,
                radius: 6,
                filled,
                pts,
            });
            p.lines.push(
                Line::new(color, 2, vec![(xmin, icpt + slope * xmin), (xmax, icpt + slope * xmax)])
                    .dashed()
                    .label(format!("{name} fit: slope {} {unit} per pm/step", num(slope, dg))),
            );
        }
        if let Some(x) = nominal {
            p.vlines.push(x);
            p.note("scenario σ_d", (((x - lo) / (hi - lo) + 0.01).min(0.85), 0.07));
        }
        p.legend = Legend::UpperLeft;
        p.legend_room = 0.8;
        panels.push(p);
    }
    let n_rows = panels.len();
    Some(FigSpec {
        stem: "fig8_drift_sensitivity".into(),
        title: "Fig. 8 — Drift sensitivity".into(),
        caption: format!(
            "Hold-out RMSE as the drift amplitude σ_d is scaled by {} (all else fixed; both models refitted each time with the hyper-parameters chosen on the nominal scenario), with least-squares lines; their slopes are the drift-sensitivity index (metrics.json, drift sweep). The dashed vertical line marks the scenario's own σ_d.",
            s.factors.iter().map(|f| num(*f, 1)).collect::<Vec<_>>().join(", ")
        ),
        grid: Grid {
            size: (WIDTH, height(1500, n_rows)),
            title: "Fig. 8 — Drift sensitivity: hold-out RMSE against drift amplitude σ_d".into(),
            subtitle: "What to look for: a shallower slope means a model that is more robust to baseline wander.".into(),
            rows: n_rows,
            cols: 1,
            panels,
        },
    })
}

/// Fig. 9: what each part of Model-H contributes on the hold-out.
pub(crate) fn fig9_contributions(c: &Ctx) -> Option<FigSpec> {
    if c.parts_h.len() != c.hold.len() || c.parts_h.is_empty() {
        return None;
    }
    let d = c.data;
    let u = c.time.seconds;
    let x: Vec<f64> = c.hold.iter().map(|&i| d.t_s[i] / u).collect();
    let rms = |v: &[f64]| (v.iter().map(|a| a * a).sum::<f64>() / v.len().max(1) as f64).sqrt();
    let mut panels = Vec::new();
    let mut notes = Vec::new();
    for ch in 0..c.n_channels() {
        let nm = c.names(ch);
        let (unit, dg) = (nm.unit, nm.digits);
        let reference = c.truth(ch);
        let part = |k: usize| -> Vec<f64> { c.parts_h.iter().map(|p| p[k][ch]).collect() };
        let (core, mem, rbf) = (part(0), part(1), part(2));
        let left: Vec<f64> = c.hold.iter().zip(&core).map(|(&i, v)| reference[i] - v).collect();
        let after_mem: Vec<f64> = left.iter().zip(&mem).map(|(a, b)| a - b).collect();
        let after_all: Vec<f64> = after_mem.iter().zip(&rbf).map(|(a, b)| a - b).collect();
        let mut p = Panel::new(
            format!(
                "({}) {}: RMS of Γm {} {unit}, of Wψ {} {unit}",
                letter(ch),
                nm.long,
                num(rms(&mem), dg),
                num(rms(&rbf), dg)
            ),
            c.time.label(),
            format!("{} contribution [{unit}]", nm.sym),
        );
        let series = |v: &[f64]| pts(&minmax_columns(&x, v, COLUMNS));
        if reference.is_present() {
            p.lines
                .push(Line::new(C_GREY, 1, series(&left)).label("truth − core Bφ (what memory and RBF must explain)"));
        }
        p.lines.push(Line::new(C_H, 1, series(&mem)).label("memory terms Γm"));
        p.lines.push(Line::new(C_P, 1, series(&rbf)).label("RBF residual Wψ"));
        p.legend = Legend::UpperLeft;
        p.legend_room = 0.35;
        panels.push(p);
        if reference.is_present() {
            notes.push(format!(
                "{}: hold-out RMS of truth − Bφ {} {unit}, after Γm {} {unit}, after Wψ {} {unit}",
                nm.long.to_lowercase(),
                num(rms(&left), dg),
                num(rms(&after_mem), dg),
                num(rms(&after_all), dg)
            ));
        }
    }
    let n_rows = panels.len();
    Some(FigSpec {
        stem: "fig9_contributions".into(),
        title: "Fig. 9 — What each part of Model-H contributes".into(),
        caption: format!(
            "Model-H = Bφ + Γm + Wψ, split by running `fbg-shared` with parts removed on the hold-out: the core Bφ is Model-P's, the memory terms Γm are fitted on what it leaves, and the RBF residual Wψ learns what both leave. Grey: the truth minus the core alone. {}.{}",
            notes.join("; "),
            decimation_note(c.hold.len(), 2 * COLUMNS)
        ),
        grid: Grid {
            size: (WIDTH, height(1500, n_rows)),
            title: "Fig. 9 — Contributions of the memory terms and the RBF residual on the hold-out".into(),
            subtitle: "What to look for: how much of truth − core the memory terms follow, and what the RBF adds.".into(),
            rows: n_rows,
            cols: 1,
            panels,
        },
    })
}

/// Fig. 10: the pace study — Model-H's gain over Model-P on the same installation at other
/// paces and on a steps record.
pub(crate) fn fig10_pace(c: &Ctx) -> Option<FigSpec> {
    let s = c.metrics.pace.as_ref()?;
    let n = s.rows.len();
    let mut panels = Vec::new();
    for ch in 0..c.n_channels() {
        let nm = c.names(ch);
        let mut p = Panel::new(
            format!("({}) {}", letter(ch), nm.long),
            "record (numbered as in the caption)",
            "Model-H gain over Model-P [%]",
        );
        p.xr = Some((0.5, n as f64 + 0.5));
        p.y_pad = 0.15;
        let pts: Vec<(f64, f64)> = s
            .rows
            .iter()
            .enumerate()
            .map(|(k, r)| ((k + 1) as f64, r.gain_pct(ch)))
            .filter(|q| q.1.is_finite())
            .collect();
        let better: Vec<(f64, f64)> = pts.iter().copied().filter(|q| q.1 >= 0.0).collect();
        let worse: Vec<(f64, f64)> = pts.into_iter().filter(|q| q.1 < 0.0).collect();
        p.dots.push(Dots {
            label: Some("Model-H better".into()),
            color: C_H,
            alpha: 1.0,
            radius: 6,
            filled: true,
            pts: better,
        });
        p.dots.push(Dots {
            label: Some("Model-H worse".into()),
            color: C_P,
            alpha: 1.0,
            radius: 6,
            filled: false,
            pts: worse,
        });
        p.lines.push(Line::new(C_GREY, 1, vec![(0.5, 0.0), (n as f64 + 0.5, 0.0)]).dashed());
        p.legend = Legend::UpperLeft;
        p.legend_room = 0.4;
        panels.push(p);
    }
    let n_rows = panels.len();
    let labels: Vec<String> = s.rows.iter().enumerate().map(|(k, r)| format!("{} {}", k + 1, r.label)).collect();
    Some(FigSpec {
        stem: "fig10_pace".into(),
        title: "Fig. 10 — The same installation at other paces".into(),
        caption: format!(
            "Hold-out RMSE gain of Model-H over Model-P, both calibrated at the native pace, on the same installation and seed simulated with the measurand trajectories at another pace (×¼ is four times slower) or as a steps record ({}, seed {}). Records: {}. Cross-validation inside the calibration week cannot see this: every fold has its pace. Table: pace study.",
            s.scenario,
            s.seed,
            labels.join("; ")
        ),
        grid: Grid {
            size: (WIDTH, height(1500, n_rows)),
            title: "Fig. 10 — Static fidelity: Model-H against Model-P at other paces".into(),
            subtitle: "What to look for: every dot at or above zero — a model right at every pace, not only the calibration week's.".into(),
            rows: n_rows,
            cols: 1,
            panels,
        },
    })
}
