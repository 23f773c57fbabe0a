//! The errors on the hold-out, every channel and both models: parity (Fig. 6) and histograms
//! (Fig. 7).

use super::{count, height, letter, num, pts, Ctx, FigSpec, PARITY_GRID, WIDTH};
use crate::report::chart::{Band, Dots, Grid, Legend, Line, Panel, C_H, C_P, C_TRUTH};
use crate::report::decimate::{histogram, thin_grid};

/// Fig. 6: parity plots, every channel, both models.
pub fn fig6_parity(c: &Ctx) -> FigSpec {
    let m = &c.metrics.table2;
    let mut panels = Vec::new();
    let mut drawn = 0usize;
    let mut total = 0usize;
    for ch in 0..c.n_channels() {
        let reference = c.truth(ch);
        let truth: Vec<f64> = c.hold.iter().map(|&i| reference[i]).collect();
        let vp: Vec<f64> = c.est_p.iter().map(|e| e.values[ch]).collect();
        let vh: Vec<f64> = c.est_h.iter().map(|e| e.values[ch]).collect();
        let all = truth.iter().chain(&vp).chain(&vh).filter(|v| v.is_finite());
        let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let pad = 0.03 * (hi - lo).max(1e-9);
        let (lo, hi) = (lo - pad, hi + pad);
        let nm = c.names(ch);
        let (unit, dg, sym) = (nm.unit, nm.digits, nm.sym.as_str());
        for (k, (name, v, color, me)) in
            [("Model-P", &vp, C_P, &m.model_p), ("Model-H", &vh, C_H, &m.model_h)].into_iter().enumerate()
        {
            let thin = thin_grid(&truth, v, (lo, hi), (lo, hi), PARITY_GRID.0, PARITY_GRID.1);
            drawn += thin.x.len();
            total += thin.n_in;
            let mut p = Panel::new(
                format!("({}) {} — {name}", letter(2 * ch + k), nm.long),
                format!("true {sym} [{unit}]"),
                format!("estimated {sym} [{unit}]"),
            );
            p.xr = Some((lo, hi));
            p.yr = Some((lo, hi));
            p.dots.push(Dots { label: None, color, alpha: 0.35, radius: 2, filled: true, pts: pts(&thin) });
            p.lines.push(Line::new(C_TRUTH, 1, vec![(lo, lo), (hi, hi)]).dashed().label("ideal (estimate = truth)"));
            let cm = &me.channels[ch];
            p.note(format!("RMSE {} {unit}   MAE {} {unit}", num(cm.rmse, dg), num(cm.mae, dg)), (0.03, 0.96));
            p.note(format!("R² {}   bias {} {unit}", num(cm.r2, 4), num(cm.bias, dg)), (0.03, 0.89));
            p.legend = Legend::LowerRight;
            panels.push(p);
        }
    }
    let n_rows = c.n_channels();
    FigSpec {
        stem: "fig6_parity".into(),
        title: "Fig. 6 — Parity: estimate against truth on the hold-out".into(),
        caption: format!(
            "Every hold-out sample of every channel, Model-P (left) and Model-H (right), against the 45° line of a perfect estimate; RMSE, MAE, R² and bias are those of Table 2 (metrics.json). Points are drawn once per occupied cell of a {} × {} grid over each panel ({} estimates → {} points): every place the full cloud puts ink still gets ink, but the density of dense regions is not shown (Fig. 7 shows it).",
            PARITY_GRID.0,
            PARITY_GRID.1,
            count(total),
            count(drawn)
        ),
        grid: Grid {
            size: (WIDTH, height(1700, n_rows)),
            title: "Fig. 6 — Parity plots: estimate vs truth on the hold-out, per channel and model".into(),
            subtitle: "What to look for: tighter, more symmetric clouds around the diagonal for Model-H; a tilt means a proportional bias.".into(),
            rows: n_rows,
            cols: 2,
            panels,
        },
    }
}

/// Fig. 7: error histograms per channel, both models.
pub fn fig7_errors(c: &Ctx) -> FigSpec {
    let m = &c.metrics.table2;
    let bins = 80;
    let mut panels = Vec::new();
    for ch in 0..c.n_channels() {
        let reference = c.truth(ch);
        let truth: Vec<f64> = c.hold.iter().map(|&i| reference[i]).collect();
        let ep: Vec<f64> = c.est_p.iter().zip(&truth).map(|(e, t)| e.values[ch] - t).collect();
        let eh: Vec<f64> = c.est_h.iter().zip(&truth).map(|(e, t)| e.values[ch] - t).collect();
        let (lo, hi) = ep
            .iter()
            .chain(&eh)
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let (lo, hi) = if lo < hi { (lo, hi) } else { (lo - 1.0, hi + 1.0) };
        let wbin = (hi - lo) / bins as f64;
        let nm = c.names(ch);
        let (unit, dg, sym) = (nm.unit, nm.digits, nm.sym.as_str());
        let mut p =
            Panel::new(format!("({}) {}", letter(ch), nm.long), format!("error of {sym} [{unit}]"), "samples per bin");
        p.xr = Some((lo, hi));
        p.y_pad = 0.0;
        let mut ymax: f64 = 0.0;
        for (name, e, color, me) in [("Model-P", &ep, C_P, &m.model_p), ("Model-H", &eh, C_H, &m.model_h)] {
            let (counts, _) = histogram(e, lo, hi, bins);
            let mut step = Vec::with_capacity(2 * bins + 2);
            step.push((lo, 0.0));
            for (k, &n) in counts.iter().enumerate() {
                let a = lo + k as f64 * wbin;
                step.push((a, n as f64));
                step.push((a + wbin, n as f64));
                ymax = ymax.max(n as f64);
            }
            step.push((hi, 0.0));
            let mut poly = step.clone();
            poly.push((lo, 0.0));
            p.bands.push(Band { label: None, color, alpha: 0.18, poly, hatch: None });
            let cm = &me.channels[ch];
            p.lines.push(Line::new(color, 2, step).label(format!(
                "{name}: bias {} {unit}, RMSE {} {unit}",
                num(cm.bias, dg),
                num(cm.rmse, dg)
            )));
        }
        p.yr = Some((0.0, 1.22 * ymax.max(1.0)));
        p.lines.push(Line::new(C_TRUTH, 1, vec![(0.0, 0.0), (0.0, 1.22 * ymax.max(1.0))]).dashed());
        p.legend = Legend::UpperRight;
        panels.push(p);
    }
    let n_rows = panels.len();
    FigSpec {
        stem: "fig7_error_histograms".into(),
        title: "Fig. 7 — Error distributions on the hold-out".into(),
        caption: format!(
            "Histograms of estimate − truth over the {} hold-out samples, {bins} equal bins spanning the smallest to the largest error of either model (no sample is left out; the dashed line marks zero error). Bias and RMSE from metrics.json.",
            count(c.hold.len())
        ),
        grid: Grid {
            size: (WIDTH, height(1500, n_rows)),
            title: "Fig. 7 — Error distributions (estimate − truth) on the hold-out, both models".into(),
            subtitle: "What to look for: a narrower, more centred distribution with lighter tails for Model-H.".into(),
            rows: n_rows,
            cols: 1,
            panels,
        },
    }
}
