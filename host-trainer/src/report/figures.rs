//! The report's eight figures (DESIGN §5; the paper's Figs. 6–12), built from the data, the
//! hold-out estimates of both models, the simulation (for the true wavelength) and the
//! metrics. Long series are reduced by [`super::decimate`], and every caption says when.

use fbg_shared::Estimate;

use super::chart::{Band, Dots, Grid, Legend, Line, Panel, C_GREY, C_H, C_MEAS, C_P, C_TRUTH};
use super::decimate::{envelope_columns, histogram, minmax_columns, stride_indices, thin_grid, Decimated};
use super::window::{best_window, turning_points, window_len_for};
use crate::data::{Column, Dataset, Measurand, Split};
use crate::eval::metrics::Metrics;
use crate::sim::Simulation;
use fbg_shared::layout::{Dims, MAX_OUTPUTS};

/// Width of every figure \[px\].
pub const WIDTH: u32 = 1400;
/// Pixel columns of a full-width panel's plotting area (figure width less the label area).
pub const COLUMNS: usize = (WIDTH - 130) as usize;
/// Most points of a phase-plot path (loops) before it is strided.
pub const MAX_PATH_POINTS: usize = 4000;

/// Cells of the parity plots' thinning grid (about 3 px each).
pub const PARITY_GRID: (usize, usize) = (200, 110);

/// How a model output is named and printed in the figures.
#[derive(Clone, Debug)]
pub struct ChannelNames {
    /// For titles: `Temperature`, `Strain 2`.
    pub long: String,
    /// For axis labels: `T`, `ε2`.
    pub sym: String,
    pub unit: &'static str,
    /// Decimals that suit its magnitude (as in the tables).
    pub digits: usize,
    /// For file names: `temperature`, `strain2`.
    pub slug: String,
}

impl ChannelNames {
    pub fn of(m: Measurand) -> Self {
        let long = m.long_name();
        let mut cap = long.clone();
        if let Some(f) = cap.get_mut(0..1) {
            f.make_ascii_uppercase();
        }
        ChannelNames {
            long: cap,
            sym: m.short_name(),
            unit: m.unit(),
            digits: if m.kind == crate::data::Kind::Temperature { 3 } else { 2 },
            slug: long.replace(' ', ""),
        }
    }
}

/// "a", "b", … for panel `k`.
fn letter(k: usize) -> char {
    (b'a' + k as u8) as char
}

/// The unit of the time axes.
#[derive(Clone, Copy, Debug)]
pub struct TimeUnit {
    pub seconds: f64,
    pub name: &'static str,
}

impl TimeUnit {
    /// Days for records of two days or more, hours down to two hours, else seconds.
    pub fn for_span(span_s: f64) -> Self {
        if span_s >= 2.0 * 86_400.0 {
            TimeUnit { seconds: 86_400.0, name: "d" }
        } else if span_s >= 7_200.0 {
            TimeUnit { seconds: 3_600.0, name: "h" }
        } else {
            TimeUnit { seconds: 1.0, name: "s" }
        }
    }
    pub fn label(&self) -> String {
        format!("time since start [{}]", self.name)
    }
}

/// What the figures are drawn from.
pub struct Ctx<'a> {
    pub data: &'a Dataset,
    /// The re-simulated installation (true wavelengths); `None` without `data.meta.json`.
    pub sim: Option<&'a Simulation>,
    pub hold: &'a [usize],
    pub est_p: &'a [Estimate<f64>],
    pub est_h: &'a [Estimate<f64>],
    pub metrics: &'a Metrics,
    pub time: TimeUnit,
    /// Model-H's answer split into its parts at each hold-out row: [core Bφ, memory Γm, RBF Wψ]
    /// per output (from `fbg_shared` with the other parts removed).
    pub parts_h: &'a [[[f64; MAX_OUTPUTS]; 3]],
    /// The models' dimensions: one channel per output.
    pub dims: Dims,
}

impl Ctx<'_> {
    /// Number of channels (the models' outputs).
    pub fn n_channels(&self) -> usize {
        self.dims.n_outputs()
    }
    /// Names of channel `ch`.
    pub fn names(&self, ch: usize) -> ChannelNames {
        ChannelNames::of(Measurand::of_output(self.dims.outputs()[ch]))
    }
    /// The data's reference of channel `ch` (NaN throughout when absent).
    pub fn truth(&self, ch: usize) -> Column<'_> {
        self.data.reference_of(&self.dims, ch)
    }
    /// The figure number of channel `ch`'s hold-out figure ([`channel_fig_no`]).
    pub fn channel_fig_no(&self, ch: usize) -> String {
        channel_fig_no(&self.dims, ch)
    }
    /// The stem of channel `ch`'s hold-out figure ([`channel_stem`]).
    pub fn channel_stem(&self, ch: usize) -> String {
        channel_stem(&self.dims, ch)
    }
}

/// The figure number of output `ch`'s hold-out figure: 3, 4, 5 for up to three outputs,
/// 3a–3d for four.
pub fn channel_fig_no(dims: &Dims, ch: usize) -> String {
    if dims.n_outputs() <= 3 {
        (3 + ch).to_string()
    } else {
        format!("3{}", letter(ch))
    }
}

/// The stem of output `ch`'s hold-out figure (`fig3_temperature`, `fig4_strain`, …).
pub fn channel_stem(dims: &Dims, ch: usize) -> String {
    format!("fig{}_{}", channel_fig_no(dims, ch), ChannelNames::of(Measurand::of_output(dims.outputs()[ch])).slug)
}

/// A figure height for `rows` stacked panels, scaled from the three-panel layout's `three`.
fn height(three: u32, rows: usize) -> u32 {
    (three * rows.max(1) as u32).div_ceil(3).max(three / 2)
}

/// A figure ready to be written, with what the page says about it.
pub struct FigSpec {
    pub stem: String,
    pub title: String,
    pub caption: String,
    pub grid: Grid,
}

/// Thousands separated by thin spaces (10 080 → "10 080").
pub fn count(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push('\u{2009}');
        }
        out.push(c);
    }
    out
}

/// A number with `d` decimals and a true minus sign.
pub fn num(v: f64, d: usize) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    let s = format!("{v:.d$}");
    if let Some(rest) = s.strip_prefix('-') {
        if rest.chars().all(|c| c == '0' || c == '.') {
            rest.to_string()
        } else {
            format!("−{rest}")
        }
    } else {
        s
    }
}

fn pts(d: &Decimated) -> Vec<(f64, f64)> {
    d.points().collect()
}

/// What the caption says about min/max decimation of `n` samples per trace.
fn decimation_note(n: usize, out_max: usize) -> String {
    if n > 2 * COLUMNS {
        format!(
            " Traces with more samples than pixel columns are drawn as each column's minimum and maximum ({} samples → at most {} points per trace): no extreme is lost, nothing is dropped.",
            count(n),
            count(out_max)
        )
    } else {
        String::new()
    }
}

/// Contiguous runs of hold-out samples as (start, end) times.
fn holdout_spans(d: &Dataset, unit: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    let mut start: Option<usize> = None;
    for i in 0..d.len() {
        match (d.split[i], start) {
            (Split::Holdout, None) => start = Some(i),
            (Split::Cal, Some(s)) => {
                out.push((d.t_s[s] / unit, d.t_s[i - 1] / unit));
                start = None;
            }
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((d.t_s[s] / unit, d.t_s[d.len() - 1] / unit));
    }
    out
}

fn mark_split(p: &mut Panel, spans: &[(f64, f64)], x0: f64, x1: f64) {
    for &(a, b) in spans {
        p.shade.push((a, b, 0.06));
        if a > x0 {
            p.vlines.push(a);
        }
    }
    if let Some(&(a, _)) = spans.first() {
        let span = (x1 - x0).max(1e-12);
        if a > x0 {
            p.note("calibration", (0.01, 0.99));
            p.note("hold-out", (((a - x0) / span + 0.01).min(0.9), 0.99));
        } else {
            p.note("hold-out", (0.01, 0.99));
        }
    }
}

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
pub fn fig2_wavelength(c: &Ctx, g: usize) -> Option<FigSpec> {
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

    // Bands are hatched, not filled: Model-P's strokes and Model-H's interleave (half a period
    // apart) where the bands overlap, so no blended colour appears that the legend lacks.
    let band = |xs: &[f64], v: &[f64], b: &[f64], color, label: &str| {
        let lo: Vec<f64> = v.iter().zip(b).map(|(a, b)| a - b).collect();
        let hi: Vec<f64> = v.iter().zip(b).map(|(a, b)| a + b).collect();
        let (ex, el, eu) = envelope_columns(xs, &lo, &hi, COLUMNS);
        let period = (ex.len() * 8 / COLUMNS).max(2);
        let offset = if color == C_H { period / 2 } else { 0 };
        Band::between(color, 0.45, &ex, &el, &eu).hatched(period, offset).label(format!("{label} (hatched)"))
    };
    let series = |xs: &[f64], v: &[f64]| pts(&minmax_columns(xs, v, COLUMNS));

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

    let mut e = Panel::new(
        format!(
            "(c) errors (estimate − truth) with ±95 % bands: coverage Model-P {} %, Model-H {} %",
            num(100.0 * mp.coverage, 1),
            num(100.0 * mh.coverage, 1)
        ),
        c.time.label(),
        format!("error [{unit}]"),
    );
    let zeros = vec![0.0; n];
    e.bands.push(band(&x, &zeros, &bp, C_P, "Model-P ±band"));
    e.bands.push(band(&x, &zeros, &bh, C_H, "Model-H ±band"));
    e.lines.push(Line::new(C_P, 1, series(&x, &ep)).label("Model-P error"));
    e.lines.push(Line::new(C_H, 1, series(&x, &eh)).label("Model-H error"));
    e.legend = Legend::UpperLeft;
    e.legend_room = 0.35;

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

/// Fig. 8: drift sensitivity (needs the drift sweep in the metrics).
pub fn fig8_drift(c: &Ctx) -> Option<FigSpec> {
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
pub fn fig9_contributions(c: &Ctx) -> Option<FigSpec> {
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
pub fn fig10_pace(c: &Ctx) -> Option<FigSpec> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_print_with_a_true_minus_and_thin_spaces() {
        assert_eq!(num(-0.1234, 2), "−0.12");
        assert_eq!(num(-0.0001, 2), "0.00");
        assert_eq!(num(f64::NAN, 2), "–");
        assert_eq!(count(10080), "10\u{2009}080");
        assert_eq!(count(999), "999");
        assert_eq!(count(1_000_000), "1\u{2009}000\u{2009}000");
    }

    #[test]
    fn time_unit_suits_the_span() {
        assert_eq!(TimeUnit::for_span(14.0 * 86_400.0).name, "d");
        assert_eq!(TimeUnit::for_span(10.0 * 3600.0).name, "h");
        assert_eq!(TimeUnit::for_span(100.0).name, "s");
    }
}
