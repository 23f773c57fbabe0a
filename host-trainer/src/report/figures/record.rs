//! The record as a whole: the inputs (Fig. 1) and the measured against the true wavelength
//! shift of one grating (Fig. 2, from the re-simulation).

use fbg_shared::layout::Dims;

use super::{
    count, decimation_note, height, holdout_spans, letter, mark_split, num, pts, Ctx, FigSpec, COLUMNS,
    MAX_PATH_POINTS, WIDTH,
};
use crate::report::chart::{Grid, Legend, Line, Panel, C_GREY, C_H, C_MEAS, C_P, C_TRUTH};
use crate::report::decimate::{minmax_columns, stride_indices};
use crate::report::window::{best_window, turning_points, window_len_for};

/// Fig. 1: the reference measurands over the whole record.
pub fn fig1_inputs(c: &Ctx) -> FigSpec {
    let d = c.data;
    let u = c.time.seconds;
    let t: Vec<f64> = d.t_s.iter().map(|v| v / u).collect();
    let (x0, x1) = (t[0], t[t.len() - 1]);
    let spans = holdout_spans(d, u);
    let mut panels = Vec::new();
    // The ambient reading goes with the first temperature channel.
    let amb_ch = if d.t_amb_c.is_some() {
        (0..c.n_channels()).find(|&ch| c.dims.outputs()[ch].quantity == fbg_shared::layout::Quantity::Temperature)
    } else {
        None
    };
    let mut syms = Vec::new();
    let mut longs = Vec::new();
    for ch in 0..c.n_channels() {
        let nm = c.names(ch);
        syms.push(format!("{}(t)", nm.sym));
        longs.push(nm.long.to_lowercase());
        let cap = if amb_ch == Some(ch) {
            format!("({}) {} {}(t) and the ambient reading T_amb(t)", letter(ch), nm.long.to_lowercase(), nm.sym)
        } else {
            format!("({}) {} {}(t)", letter(ch), nm.long.to_lowercase(), nm.sym)
        };
        let mut p = Panel::new(cap, c.time.label(), format!("{} [{}]", nm.sym, nm.unit));
        p.xr = Some((x0, x1));
        mark_split(&mut p, &spans, x0, x1);
        if amb_ch == Some(ch) {
            let amb = minmax_columns(&t, d.ambient(), COLUMNS);
            p.lines.push(Line::new(C_MEAS, 1, pts(&amb)).label("T_amb reading (model input)"));
        }
        let truth = c.truth(ch);
        if truth.is_present() {
            let y = minmax_columns(&t, truth.as_slice(), COLUMNS);
            p.lines.push(Line::new(C_TRUTH, 1, pts(&y)).label(format!("reference {} (truth)", nm.sym)));
        } else {
            p.note("no reference for this channel in data.csv", (0.3, 0.5));
        }
        p.legend = Legend::UpperRight;
        p.legend_room = 0.3;
        panels.push(p);
    }
    let hold_from =
        spans.first().map(|s| format!("from t = {} {}", num(s.0, 2), c.time.name)).unwrap_or_else(|| "none".into());
    let dt = if d.len() > 1 { d.t_s[1] - d.t_s[0] } else { 0.0 };
    let and_list = |v: &[String]| match v {
        [] => String::new(),
        [a] => a.clone(),
        [init @ .., last] => format!("{} and {last}", init.join(", ")),
    };
    let n_rows = panels.len();
    FigSpec {
        stem: "fig1_inputs".into(),
        title: format!("Fig. 1 — Inputs: the reference measurands {}", syms.join(", ")),
        caption: format!(
            "The trajectories the compensators must reconstruct, over the whole record ({} samples, Δt = {} s, {} {}). The shaded part is the hold-out ({hold_from}); models are fitted on the calibration part only.{}{}",
            count(d.len()),
            num(dt, 1),
            num(x1 - x0, 2),
            c.time.name,
            if amb_ch.is_some() { " The ambient thermometer reading (a model input) lags the temperature." } else { "" },
            decimation_note(d.len(), 2 * COLUMNS)
        ),
        grid: Grid {
            size: (WIDTH, height(1150, n_rows)),
            title: format!("Fig. 1 — Inputs: reference {} over the whole record", and_list(&longs)),
            subtitle: "What to look for: the ranges the calibration part covers, and whether the hold-out (shaded) leaves them.".into(),
            rows: n_rows,
            cols: 1,
            panels,
        },
    }
}

/// Fig. 2: measured vs true wavelength shift of FBG1 (the paper's strain grating), its artefacts and
/// the minor loops. Needs the simulation.
pub(crate) fn fig2_wavelength(c: &Ctx, g: usize) -> Option<FigSpec> {
    let s = c.sim?;
    let d = c.data;
    let u = c.time.seconds;
    let t: Vec<f64> = d.t_s.iter().map(|v| v / u).collect();
    let (x0, x1) = (t[0], t[t.len() - 1]);
    let spans = holdout_spans(d, u);
    let truth = &s.effects.physics[g];
    let meas = &d.dl_pm[g];
    let dev: Vec<f64> = meas.iter().zip(truth).map(|(m, t)| m - t).collect();

    // Zoom: about 12 turning points of the true shift, where they are densest. Over the whole
    // record the measured and true traces lie on top of each other (the artefacts are a few pm
    // on a range of hundreds), so (a) shows this window and (b) the difference everywhere.
    let db = crate::eval::score::HYSTERESIS_INDEX_DEAD_BAND_PM;
    let tp = turning_points(truth, db);
    let len = window_len_for(&tp, d.len(), 12, 50.min(d.len()));
    let mut w = vec![0.0; d.len()];
    for &i in &tp {
        w[i] = 1.0;
    }
    let (wa, wb) = best_window(&w, len);

    let mut a = Panel::new(
        format!(
            "(a) FBG{} wavelength shift, measured and true, zoomed on t = {}–{} {}",
            g + 1,
            num(t[wa], 2),
            num(t[wb - 1], 2),
            c.time.name
        ),
        c.time.label(),
        "Δλ [pm]",
    );
    a.xr = Some((t[wa], t[wb - 1]));
    a.lines.push(
        Line::new(C_MEAS, 2, pts(&minmax_columns(&t[wa..wb], &meas[wa..wb], COLUMNS)))
            .label("measured Δλ (interrogator)"),
    );
    a.lines.push(
        Line::new(C_TRUTH, 1, pts(&minmax_columns(&t[wa..wb], &truth[wa..wb], COLUMNS)))
            .label("true Δλ (physics only)"),
    );
    a.legend = Legend::UpperRight;
    a.legend_room = 0.3;

    let mut b = Panel::new(
        "(b) measured − true: all interrogator artefacts, with the drift part",
        c.time.label(),
        "measured − true [pm]",
    );
    b.xr = Some((x0, x1));
    mark_split(&mut b, &spans, x0, x1);
    b.lines.push(Line::new(C_GREY, 1, pts(&minmax_columns(&t, &dev, COLUMNS))).label("measured − true"));
    let slow: Vec<f64> = (0..d.len()).map(|i| s.effects.drift[g][i] + s.effects.electronics[g][i]).collect();
    b.lines.push(Line::new(C_P, 3, pts(&minmax_columns(&t, &slow, COLUMNS))).label("drift + electronics part (slow)"));
    b.legend = Legend::UpperRight;
    b.legend_room = 0.3;

    let idx: Vec<usize> = stride_indices(wb - wa, MAX_PATH_POINTS).into_iter().map(|k| wa + k).collect();
    let strided = idx.len() < wb - wa;
    let mut cpan = Panel::new(
        format!(
            "(c) minor loops: measured − true against true, t = {}–{} {}",
            num(t[wa], 2),
            num(t[wb - 1], 2),
            c.time.name
        ),
        format!("true Δλ of FBG{} [pm]", g + 1),
        "measured − true [pm]",
    );
    cpan.x_pad = 0.03;
    cpan.lines.push(
        Line::new(RGBA_GREY, 1, idx.iter().map(|&i| (truth[i], dev[i])).collect())
            .label("measured − true (with noise)"),
    );
    let hyst: Vec<(f64, f64)> =
        idx.iter().map(|&i| (truth[i], s.effects.hysteresis[g][i] + s.effects.scan[g][i] + slow[i])).collect();
    cpan.lines.push(Line::new(C_H, 2, hyst).label("hysteresis + scan + slow parts (no noise)"));
    cpan.legend = Legend::UpperRight;
    cpan.legend_room = 0.3;
    let tp_in = tp.iter().filter(|&&i| i >= wa && i < wb).count();
    // Tint the zoom window in (b).
    b.zoom.push((t[wa], t[wb - 1]));
    b.note("(a), (c)", (((t[wa] - x0) / (x1 - x0).max(1e-12)).clamp(0.0, 0.95), 0.12));

    let rms = |v: &[f64]| crate::stats::rms(v.iter().copied());
    let e = &s.effects;
    Some(FigSpec {
        stem: "fig2_wavelength_fbg1".into(),
        title: format!("Fig. 2 — FBG{}: measured vs true wavelength shift", g + 1),
        caption: format!(
            "Grating FBG{}{}. (a) The interrogator's reading against the true physical shift, re-simulated from data.meta.json (the CSV holds only the measured shift), in the window tinted yellow in (b): over the whole record the two traces would lie on top of each other. (b) Their difference: drift (random walk, Eq. 8) and electronics drift wander slowly; hysteresis, scan nonlinearity and noise ride on top. RMS over the record [pm]: hysteresis {}, scan {}, drift {}, electronics {}, noise {}. (c) The same difference against the true shift in the tinted window of (b) (chosen as the window of about 12 turning points where they are densest: {} turning points with a {} pm dead band, {} samples): the loops that open at each reversal are the hysteresis the models must undo.{}{}",
            g + 1,
            if c.dims == Dims::PAPER && g == 0 { " (the strain grating)" } else { "" },
            num(rms(&e.hysteresis[g]), 2),
            num(rms(&e.scan[g]), 2),
            num(rms(&e.drift[g]), 2),
            num(rms(&e.electronics[g]), 2),
            num(rms(&e.noise[g]), 2),
            tp_in,
            num(db, 0),
            count(wb - wa),
            if strided { format!(" The loop path is drawn through every {}th sample.", (wb - wa) / idx.len().max(1)) } else { String::new() },
            decimation_note(d.len(), 2 * COLUMNS)
        ),
        grid: Grid {
            size: (WIDTH, 1350),
            title: format!("Fig. 2 — FBG{}: measured vs true wavelength shift (drift and minor hysteresis loops)", g + 1),
            subtitle: "What to look for: the slow baseline wander in (b), and the narrow loops at the turning points in (c).".into(),
            rows: 3,
            cols: 1,
            panels: vec![a, b, cpan],
        },
    })
}

const RGBA_GREY: plotters::style::RGBColor = plotters::style::RGBColor(150, 150, 150);
