//! One channel on the hold-out (Figs. 3–5, or 3a–3d): both models with their bands, zoomed
//! on turning points, over the whole hold-out, and their errors.

use super::{count, decimation_note, num, pts, Ctx, FigSpec, COLUMNS, WIDTH};
use crate::report::chart::{Band, Grid, Legend, Line, Panel, C_H, C_P, C_TRUTH};
use crate::report::decimate::{envelope_columns, minmax_columns};
use crate::report::window::{best_window, turning_points, window_len_for};
use plotters::style::RGBColor;

fn finite_std(v: &[f64]) -> f64 {
    crate::stats::std_dev(v.iter().copied().filter(|x| x.is_finite()))
}

/// Figs. 3–5: one channel on the hold-out.
pub fn fig_channel(c: &Ctx, ch: usize) -> FigSpec {
    let d = c.data;
    let u = c.time.seconds;
    let n = c.hold.len();
    let x: Vec<f64> = c.hold.iter().map(|&i| d.t_s[i] / u).collect();
    let reference = c.truth(ch);
    let truth: Vec<f64> = c.hold.iter().map(|&i| reference[i]).collect();
    let vp: Vec<f64> = c.est_p.iter().map(|e| e.values[ch]).collect();
    let vh: Vec<f64> = c.est_h.iter().map(|e| e.values[ch]).collect();
    let bp: Vec<f64> = c.est_p.iter().map(|e| e.band95[ch]).collect();
    let bh: Vec<f64> = c.est_h.iter().map(|e| e.band95[ch]).collect();
    let ep: Vec<f64> = vp.iter().zip(&truth).map(|(a, b)| a - b).collect();
    let eh: Vec<f64> = vh.iter().zip(&truth).map(|(a, b)| a - b).collect();
    let m = &c.metrics.table2;
    let (mp, mh) = (&m.model_p.channels[ch], &m.model_h.channels[ch]);
    let nm = c.names(ch);
    let (unit, dg, sym) = (nm.unit, nm.digits, nm.sym.as_str());

    // Zoom window: about 6 turning points of the truth (dead band half its standard
    // deviation), placed where the two models' summed |error| is largest.
    let db = 0.5 * finite_std(&truth);
    let tp = turning_points(&truth, db);
    let len = window_len_for(&tp, n, 6, 60);
    let weight: Vec<f64> = ep.iter().zip(&eh).map(|(a, b)| a.abs() + b.abs()).collect();
    let (wa, wb) = best_window(&weight, len);

    let ylabel = format!("{sym} [{unit}]");
    let lab_p = format!("Model-P (hold-out RMSE {} {unit})", num(mp.rmse, dg));
    let lab_h = format!("Model-H (hold-out RMSE {} {unit})", num(mh.rmse, dg));
    let whole = wb - wa == n;
    let mut a = Panel::new(
        if whole {
            "(a) the whole hold-out (too few turning points to zoom on)".to_string()
        } else {
            format!("(a) zoom on turning points, t = {}–{} {}", num(x[wa], 2), num(x[wb - 1], 2), c.time.name)
        },
        c.time.label(),
        ylabel.clone(),
    );
    let r = wa..wb;
    a.bands.push(band(&x[r.clone()], &vp[r.clone()], &bp[r.clone()], C_P, "Model-P 95 % band"));
    a.bands.push(band(&x[r.clone()], &vh[r.clone()], &bh[r.clone()], C_H, "Model-H 95 % band"));
    a.lines.push(Line::new(C_P, 2, series(&x[r.clone()], &vp[r.clone()])).label(lab_p.clone()));
    a.lines.push(Line::new(C_H, 2, series(&x[r.clone()], &vh[r.clone()])).label(lab_h.clone()));
    a.lines.push(Line::new(C_TRUTH, 2, series(&x[r.clone()], &truth[r.clone()])).label("truth"));
    a.legend = Legend::UpperRight;
    a.legend_room = 0.45;

    let mut b = Panel::new("(b) the whole hold-out", c.time.label(), ylabel);
    b.bands.push(band(&x, &vp, &bp, C_P, "Model-P 95 % band"));
    b.bands.push(band(&x, &vh, &bh, C_H, "Model-H 95 % band"));
    b.lines.push(Line::new(C_P, 1, series(&x, &vp)).label("Model-P"));
    b.lines.push(Line::new(C_H, 1, series(&x, &vh)).label("Model-H"));
    b.lines.push(Line::new(C_TRUTH, 1, series(&x, &truth)).label("truth"));
    if !whole {
        b.zoom.push((x[wa], x[wb - 1]));
    }
    b.legend = Legend::None;

    let mut e = error_panel(c, (100.0 * mp.coverage, 100.0 * mh.coverage), unit, &x, (&ep, &eh), (&bp, &bh));

    if !reference.is_present() {
        for p in [&mut a, &mut b, &mut e] {
            p.note("no reference for this channel in data.csv: estimates only, no errors", (0.02, 0.08));
        }
    }
    let flagged = c.est_h.iter().filter(|e| !e.flags.is_ok()).count();
    let nonfinite = vp.iter().chain(&vh).filter(|v| !v.is_finite()).count();
    let fig_no = c.channel_fig_no(ch);
    FigSpec {
        stem: c.channel_stem(ch),
        title: format!("Fig. {fig_no} — {} on the hold-out", nm.long),
        caption: format!(
            "Hold-out {} ({} samples, never seen in fitting): the reference, Model-P (polynomial only) and Model-H (polynomial + RBF residual), each with its 95 % band. (a) The window of about 6 turning points of the truth (dead band {} {unit}) where the two models' summed |error| is largest ({} samples), shaded yellow in (b). Bands are hatched in the model's colour (vertical strokes), so where they overlap the strokes of both interleave. (c) The errors against ± the band half-widths; the band should hold the truth about 95 % of the time. Metrics from metrics.json: RMSE {} → {} {unit}, MAE {} → {} {unit}, hysteresis index {} → {} {unit} (Model-P → Model-H). Samples flagged by Model-H: {}{}.{}{}",
            nm.long.to_lowercase(),
            count(n),
            num(db, dg),
            count(wb - wa),
            num(mp.rmse, dg),
            num(mh.rmse, dg),
            num(mp.mae, dg),
            num(mh.mae, dg),
            num(mp.hysteresis_index, dg),
            num(mh.hysteresis_index, dg),
            count(flagged),
            if flagged > 0 { " (their bands are widened, which shows as spikes of the band in (c))" } else { "" },
            if nonfinite > 0 { format!(" {} non-finite estimates are not drawn.", count(nonfinite)) } else { String::new() },
            decimation_note(n, 2 * COLUMNS)
        ),
        grid: Grid {
            size: (WIDTH, 1350),
            title: format!("Fig. {fig_no} — {} on the hold-out: truth, Model-P and Model-H with 95 % bands", nm.long),
            subtitle: "What to look for: who tracks the truth at the turning points in (a); errors inside their bands in (c).".into(),
            rows: 3,
            cols: 1,
            panels: vec![a, b, e],
        },
    }
}

/// A model's 95 % band around `v` (half-widths `b`) over `xs`. Bands are hatched, not filled:
/// Model-P's strokes and Model-H's interleave (half a period apart) where the bands overlap,
/// so no blended colour appears that the legend lacks.
fn band(xs: &[f64], v: &[f64], b: &[f64], color: RGBColor, label: &str) -> Band {
    let lo: Vec<f64> = v.iter().zip(b).map(|(a, b)| a - b).collect();
    let hi: Vec<f64> = v.iter().zip(b).map(|(a, b)| a + b).collect();
    let (ex, el, eu) = envelope_columns(xs, &lo, &hi, COLUMNS);
    let period = (ex.len() * 8 / COLUMNS).max(2);
    let offset = if color == C_H { period / 2 } else { 0 };
    Band::between(color, 0.45, &ex, &el, &eu).hatched(period, offset).label(format!("{label} (hatched)"))
}

/// A trace reduced to each pixel column's minimum and maximum.
fn series(xs: &[f64], v: &[f64]) -> Vec<(f64, f64)> {
    pts(&minmax_columns(xs, v, COLUMNS))
}

/// Panel (c): both models' errors against ± their band half-widths, with the coverages \[%\]
/// (Model-P, Model-H) in the caption.
fn error_panel(
    c: &Ctx,
    coverage_pct: (f64, f64),
    unit: &str,
    x: &[f64],
    (ep, eh): (&[f64], &[f64]),
    (bp, bh): (&[f64], &[f64]),
) -> Panel {
    let mut e = Panel::new(
        format!(
            "(c) errors (estimate − truth) with ±95 % bands: coverage Model-P {} %, Model-H {} %",
            num(coverage_pct.0, 1),
            num(coverage_pct.1, 1)
        ),
        c.time.label(),
        format!("error [{unit}]"),
    );
    let zeros = vec![0.0; x.len()];
    e.bands.push(band(x, &zeros, bp, C_P, "Model-P ±band"));
    e.bands.push(band(x, &zeros, bh, C_H, "Model-H ±band"));
    e.lines.push(Line::new(C_P, 1, series(x, ep)).label("Model-P error"));
    e.lines.push(Line::new(C_H, 1, series(x, eh)).label("Model-H error"));
    e.legend = Legend::UpperLeft;
    e.legend_room = 0.35;
    e
}
