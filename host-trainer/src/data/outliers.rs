//! Reference outliers: a cell of a reference column (`T_C`, `strain_ue`, …) that no neighbour
//! agrees with, such as one `T_C = 1e6` among readings of 20 °C. One such cell is enough to
//! ruin a calibration (least squares follow it: on a 2-day `paper` record the hold-out T RMSE
//! went from 0.64 °C to 12 700 °C), and it ruins the cross-validation that would have warned
//! too (its squared error dominates every pooled RMSE it enters, so which model looks worse is
//! chance). `train` refuses a calibration batch with one, naming the file,
//! line and column, or leaves its rows out with `--on-error skip`.
//!
//! The test, per reference column over the rows checked (time order, missing cells left out):
//!
//! * the **running windows**: every run of [`WINDOW`] = 7 consecutive values that contains the
//!   cell, and the interval [lo, hi] their medians span;
//! * the **distance** of the value x from [lo, hi]: 0 for a value some window's median agrees
//!   with. A run of r equal values among others sets the median of a window when r ≥ 4 of its
//!   7 values are the run's, so a genuine level change that persists 4 samples or more (a step,
//!   a hold: what the steps record's reader counts as one, `sim::steps::MIN_HOLD_ROWS`) is inside
//!   the interval wherever the cell sits in it, and so is every sample of a ramp or a turning
//!   point (its windows' medians lie on both sides of it). Only a cell, or a run of at most 3
//!   cells, that no window's majority shares is away from it. Within 3 cells of either end,
//!   where no window is centred on the cell, the interval also takes the value the end
//!   window's trend gives the cell (a record that ends on a ramp ends beyond every median);
//! * the **scale** s: the MAD of the 2 × [`SCALE_NEIGHBOURS`] neighbours about their median (the
//!   running median the messages quote), times [`MAD_TO_SIGMA`]; never below the column's
//!   typical scale (the median over the column of the non-zero |x − running median|, times
//!   [`MAD_TO_SIGMA`]) nor below its resolution (the smallest non-zero step between
//!   consecutive values): a window that happens to be flat (a hold, a quantised reading) does
//!   not make a one-count flicker look like an outlier;
//! * the robust z-score z = ±distance / s; the cell is an outlier when |z| > [`Z_LIMIT`].
//!
//! The first data row of a dataset CSV is the line after its header (line 1, or after the
//! record's comment lines): [`csv_line`].

use rayon::prelude::*;
use serde::Serialize;

use crate::data::Dataset;
use crate::stats::median_in_place;

/// Robust z-score above which a reference cell is an outlier. Gaussian noise exceeds 8 σ once
/// in 10¹⁵ samples, and the scale of a window of 10 neighbours is itself noisy (its MAD can come
/// out at half the true σ): at 5 σ a year of 1 Hz references would raise false alarms, at 8 the
/// simulated presets (whose references carry AR noise, holds, ramps and steps) show none over
/// many seeds, with their largest |z| under 4 (`tests/fit.rs`). A gross error (a unit slip,
/// a missing decimal point, a logger's 1e6 or −9999 sentinel) is thousands of σ away.
pub const Z_LIMIT: f64 = 8.0;

/// Length of the running windows whose medians a cell is compared with: 7, so a run of up to
/// 3 bad cells is outvoted in every window and a level held 4 samples or more is not an
/// outlier.
pub const WINDOW: usize = 7;

/// Neighbours on each side of a cell that its running median and its local scale use.
pub const SCALE_NEIGHBOURS: usize = 5;

/// MAD to standard deviation for Gaussian noise (1 / Φ⁻¹(3/4)).
pub const MAD_TO_SIGMA: f64 = 1.4826;

/// The column's typical scale is taken on at most this many evenly spaced cells (a 10⁶-row
/// batch costs no more than a 50 000-row one).
pub const SCALE_SAMPLES: usize = 50_000;

/// How many line numbers messages and summaries list.
pub const FIRST_LINES: usize = 5;

/// The dataset CSV line of data row `row` (0-based): the header is line 1.
pub fn csv_line(d: &Dataset, row: usize) -> u64 {
    row as u64 + 2 + d.meta.comment_lines
}

/// One outlying reference cell.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Outlier {
    /// Data row (0-based).
    pub row: usize,
    /// Its line in the dataset CSV ([`csv_line`]).
    pub line: u64,
    /// The reference column (`T_C`, `strain_ue`, …).
    pub column: String,
    /// The column's unit.
    pub unit: &'static str,
    /// The cell's value.
    pub value: f64,
    /// The running median: the median of its 2 × [`SCALE_NEIGHBOURS`] neighbours.
    pub median: f64,
    /// The robust scale the z-score divides by (the column's unit).
    pub scale: f64,
    /// The robust z-score (signed: positive above its neighbours).
    pub z: f64,
}

impl Outlier {
    /// "1000000 °C where the running median is 24.1689 °C (robust z = 8.81e6, limit 8)".
    pub fn describe(&self) -> String {
        format!(
            "{} {} where the running median is {} {} (robust z = {}, limit {})",
            crate::error::ShortNumber(self.value),
            self.unit,
            median_text(self.median),
            self.unit,
            z_text(self.z),
            Z_LIMIT
        )
    }
}

/// The running median to four decimals, short when huge (a column of 1e308 cells).
fn median_text(m: f64) -> String {
    if m.abs() < 1e9 {
        format!("{m:.4}")
    } else {
        crate::error::quote_number(m)
    }
}

/// A z-score as people read it: `9.5`, `-12.3`, `8.81e6`.
fn z_text(z: f64) -> String {
    if z.abs() < 1e4 {
        format!("{z:.1}")
    } else {
        format!("{z:.2e}")
    }
}

impl std::fmt::Display for Outlier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {}, column {}: {}", self.line, self.column, self.describe())
    }
}

/// An outlier of a series: its index, running median, scale and z-score.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeriesOutlier {
    pub index: usize,
    pub median: f64,
    pub scale: f64,
    pub z: f64,
}

/// The running median at `i` (of its neighbours, `i` itself left out) and the neighbours in
/// `buf`.
fn neighbours(x: &[f64], i: usize, buf: &mut Vec<f64>) -> f64 {
    buf.clear();
    let lo = i.saturating_sub(SCALE_NEIGHBOURS);
    let hi = (i + SCALE_NEIGHBOURS + 1).min(x.len());
    buf.extend(x.get(lo..i).unwrap_or(&[]));
    buf.extend(x.get(i + 1..hi).unwrap_or(&[]));
    let mut sorted = buf.clone();
    median_in_place(&mut sorted)
}

/// The median of every window of [`WINDOW`] consecutive values (one window, the whole series,
/// when it is shorter): window `j` starts at `j`.
fn window_medians(x: &[f64]) -> Vec<f64> {
    let w = WINDOW.min(x.len());
    x.par_windows(w)
        .with_min_len(4096)
        .map(|v| {
            let mut b = [0.0; WINDOW];
            let b = &mut b[..w];
            b.copy_from_slice(v);
            median_in_place(b)
        })
        .collect()
}

/// Distance of `x[i]` from the interval the medians of its windows span (signed: positive
/// above); `med` from [`window_medians`].
fn distance(x: &[f64], med: &[f64], i: usize) -> f64 {
    let w = WINDOW.min(x.len());
    // Windows j..j + w containing i: j from i + 1 − w to i, within the series.
    let first = (i + 1).saturating_sub(w);
    let last = i.min(med.len().saturating_sub(1));
    let (lo, hi) = med
        .get(first..=last)
        .unwrap_or(&[])
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &m| (a.min(m), b.max(m)));
    // Within half a window of either end no window is centred on the cell, and on a trend the
    // end cells lie beyond every window's median: the nearest window's trend, carried to the
    // cell, is also an answer.
    let (lo, hi) = match end_trend(x, med, i) {
        Some(p) => (lo.min(p), hi.max(p)),
        None => (lo, hi),
    };
    let v = x[i];
    if v > hi {
        v - hi
    } else if v < lo {
        v - lo
    } else {
        0.0
    }
}

/// For a cell within half a window of either end, the value the first (last) window's trend
/// gives it: that window's median plus its slope (the median of its last 3 values minus that of
/// its first 3, over the 4 samples between them) times the cell's offset from its centre.
fn end_trend(x: &[f64], med: &[f64], i: usize) -> Option<f64> {
    let n = x.len();
    let half = WINDOW / 2;
    if n <= WINDOW || (i >= half && i + half < n) {
        return None;
    }
    let j = if i < half { 0 } else { n - WINDOW };
    let w = x.get(j..j + WINDOW)?;
    let third = |s: &[f64]| {
        let mut b = [0.0; 3];
        b.copy_from_slice(s.get(..3)?);
        Some(median_in_place(&mut b))
    };
    let slope = (third(w.get(WINDOW - 3..)?)? - third(w)?) / (WINDOW - 3) as f64;
    Some(med.get(j)? + slope * (i as f64 - (j + half) as f64))
}

/// The column's floor of the scale: its typical robust scale and its resolution, the larger.
fn scale_floor(x: &[f64]) -> f64 {
    let n = x.len();
    let stride = n.div_ceil(SCALE_SAMPLES).max(1);
    let mut buf = Vec::with_capacity(2 * SCALE_NEIGHBOURS);
    // Cells equal to their running median (an exact hold, a quantised reading at rest) say
    // nothing about the noise: left out, so that a record of long holds keeps the scale of its
    // moving parts (the resolution floor covers a quantised column).
    let mut dev: Vec<f64> =
        (0..n).step_by(stride).map(|i| (x[i] - neighbours(x, i, &mut buf)).abs()).filter(|&d| d > 0.0).collect();
    let typical = if dev.is_empty() { 0.0 } else { MAD_TO_SIGMA * median_in_place(&mut dev) };
    let resolution = x.windows(2).map(|w| (w[1] - w[0]).abs()).filter(|&d| d > 0.0).fold(f64::INFINITY, f64::min);
    let resolution = if resolution.is_finite() { resolution } else { 0.0 };
    typical.max(resolution)
}

/// The outliers of a series of finite values in time order ([module docs](self)).
pub fn of_series(x: &[f64]) -> Vec<SeriesOutlier> {
    beyond(x, Z_LIMIT)
}

/// The largest |z| of a series (0 when every cell agrees with a window's median): how far
/// a clean record stays from [`Z_LIMIT`].
pub fn largest_z(x: &[f64]) -> f64 {
    beyond(x, 0.0).iter().map(|o| o.z.abs()).fold(0.0, f64::max)
}

/// The cells of `x` whose |z| exceeds `limit`.
pub fn beyond(x: &[f64], limit: f64) -> Vec<SeriesOutlier> {
    if x.len() < 3 {
        return Vec::new();
    }
    let floor = scale_floor(x);
    let med = window_medians(x);
    (0..x.len())
        .into_par_iter()
        .with_min_len(4096)
        .filter_map(|i| {
            let d = distance(x, &med, i);
            // The scale is never below `floor`: most cells are settled without their window.
            if d == 0.0 || d.abs() <= limit * floor {
                return None;
            }
            let mut buf = Vec::with_capacity(2 * SCALE_NEIGHBOURS);
            let median = neighbours(x, i, &mut buf);
            let mut dev: Vec<f64> = buf.iter().map(|v| (v - median).abs()).collect();
            let scale = (MAD_TO_SIGMA * median_in_place(&mut dev)).max(floor);
            let z = d / scale;
            (z.abs() > limit).then_some(SeriesOutlier { index: i, median, scale, z })
        })
        .collect()
}

/// The outlying reference cells of `d` over the rows `rows` (sorted; e.g. the calibration
/// rows), every reference column, missing cells left out; by row, then column.
pub fn find(d: &Dataset, rows: &[usize]) -> Vec<Outlier> {
    let mut out = Vec::new();
    for r in &d.refs {
        let at: Vec<usize> = rows.iter().copied().filter(|&i| r.values.get(i).is_some_and(|v| v.is_finite())).collect();
        let x: Vec<f64> = at.iter().map(|&i| r.values[i]).collect();
        for o in of_series(&x) {
            let row = at[o.index];
            out.push(Outlier {
                row,
                line: csv_line(d, row),
                column: r.measurand.column(),
                unit: r.measurand.unit(),
                value: x[o.index],
                median: o.median,
                scale: o.scale,
                z: o.z,
            });
        }
    }
    out.sort_by(|a, b| a.row.cmp(&b.row).then_with(|| a.column.cmp(&b.column)));
    out
}

/// The distinct rows of `found`, sorted.
pub fn rows_of(found: &[Outlier]) -> Vec<usize> {
    let mut rows: Vec<usize> = found.iter().map(|o| o.row).collect();
    rows.dedup();
    rows
}

/// "102, 340, 341 and 2 more": the first [`FIRST_LINES`] lines of `found`'s rows.
pub fn first_lines(found: &[Outlier]) -> String {
    let rows = rows_of(found);
    let line = |r: usize| found.iter().find(|o| o.row == r).map_or(0, |o| o.line);
    let mut s: Vec<String> = rows.iter().take(FIRST_LINES).map(|&r| line(r).to_string()).collect();
    if rows.len() > FIRST_LINES {
        s.push(format!("and {} more", rows.len() - FIRST_LINES));
    }
    s.join(", ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn noisy(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = crate::rng::Rng::new(seed, crate::rng::Stream::WhiteNoise);
        (0..n).map(|i| 20.0 + 0.01 * i as f64 + 0.1 * rng.normal()).collect()
    }

    #[test]
    fn a_spike_is_found_with_its_running_median() {
        let mut x = noisy(400, 1);
        x[100] = 1e6;
        let o = of_series(&x);
        assert_eq!(o.len(), 1, "{o:?}");
        assert_eq!(o[0].index, 100);
        assert!((o[0].median - 21.0).abs() < 0.3, "{o:?}");
        assert!(o[0].z > 1e5);
    }

    #[test]
    fn runs_of_up_to_three_bad_cells_are_found_and_a_four_sample_level_is_not() {
        for run in 1..=3 {
            let mut x = noisy(300, 2);
            for v in &mut x[150..150 + run] {
                *v = -9999.0;
            }
            let idx: Vec<usize> = of_series(&x).iter().map(|o| o.index).collect();
            assert_eq!(idx, (150..150 + run).collect::<Vec<_>>(), "run of {run}");
        }
        // A 4-sample level in noise, exact holds with single-sample steps between them.
        let mut x = noisy(100, 4);
        for v in &mut x[50..54] {
            *v += 30.0;
        }
        assert!(of_series(&x).is_empty(), "{:?}", of_series(&x));
        let mut x = vec![10.0; 50];
        x.extend([30.0; 4]);
        x.extend([10.0; 50]);
        x.extend([50.0; 50]);
        x.extend([-20.0; 50]);
        assert!(of_series(&x).is_empty(), "{:?}", of_series(&x));
    }

    #[test]
    fn ramps_turning_points_steps_and_quantised_readings_are_not_outliers() {
        // A tent (ramp out and back) between holds, then a quantised slow signal.
        let mut x = vec![0.0; 20];
        x.extend((1..=10).map(|k| 10.0 * k as f64));
        x.extend((0..10).rev().map(|k| 10.0 * k as f64));
        x.extend([0.0; 20]);
        x.extend((0..200).map(|i| (20.0 + 0.3 * (i as f64 / 15.0).sin() / 0.0625).round() * 0.0625));
        assert!(of_series(&x).is_empty(), "{:?}", of_series(&x));
    }

    #[test]
    fn ends_and_tiny_series() {
        let mut x = noisy(100, 3);
        x[0] = 500.0;
        x[99] = -500.0;
        let idx: Vec<usize> = of_series(&x).iter().map(|o| o.index).collect();
        assert_eq!(idx, [0, 99]);
        assert!(of_series(&[1.0, 1e9]).is_empty());
        assert!(of_series(&[5.0; 30]).is_empty());
    }
}
