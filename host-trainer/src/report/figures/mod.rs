//! The report's figures (DESIGN §5; the paper's Figs. 6–12), built from the data, the
//! hold-out estimates of both models, the simulation (for the true wavelength) and the
//! metrics. Long series are reduced by the report's `decimate` module, and every caption says when.

mod channel;
mod errors;
mod record;
mod studies;

use fbg_shared::Estimate;

use super::chart::{Grid, Panel};
use super::decimate::Decimated;
use crate::data::{Column, Dataset, Measurand, Split};
use crate::eval::metrics::Metrics;
use crate::sim::Simulation;
pub use channel::fig_channel;
pub use errors::{fig6_parity, fig7_errors};
use fbg_shared::layout::{Dims, MAX_OUTPUTS};
pub use record::fig1_inputs;
pub(crate) use record::fig2_wavelength;
pub(crate) use studies::{fig10_pace, fig8_drift, fig9_contributions};

/// Width of every figure \[px\].
pub const WIDTH: u32 = 1400;
/// Pixel columns of a full-width panel's plotting area (figure width less the label area).
pub const COLUMNS: usize = (WIDTH - 130) as usize;
/// Most points of a phase-plot path (loops) before it is strided.
pub(crate) const MAX_PATH_POINTS: usize = 4000;

/// Cells of the parity plots' thinning grid (about 3 px each).
pub(crate) const PARITY_GRID: (usize, usize) = (200, 110);

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
    pub(crate) fn n_channels(&self) -> usize {
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
    pub(crate) fn channel_fig_no(&self, ch: usize) -> String {
        channel_fig_no(&self.dims, ch)
    }
    /// The stem of channel `ch`'s hold-out figure ([`channel_stem`]).
    pub fn channel_stem(&self, ch: usize) -> String {
        channel_stem(&self.dims, ch)
    }
}

/// The figure number of output `ch`'s hold-out figure: 3, 4, 5 for up to three outputs,
/// 3a–3d for four.
pub(crate) fn channel_fig_no(dims: &Dims, ch: usize) -> String {
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

/// Every figure `c` can give, in the page's order: the inputs, the wavelength of FBG1 (with
/// the simulation), one per channel, parity, error histograms, then the studies'.
pub fn all(c: &Ctx) -> Vec<FigSpec> {
    let mut specs: Vec<FigSpec> = vec![fig1_inputs(c)];
    specs.extend(fig2_wavelength(c, 0));
    for ch in 0..c.n_channels() {
        specs.push(fig_channel(c, ch));
    }
    specs.push(fig6_parity(c));
    specs.push(fig7_errors(c));
    specs.extend(fig8_drift(c));
    specs.extend(fig9_contributions(c));
    specs.extend(fig10_pace(c));
    specs
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
