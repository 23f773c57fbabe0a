//! The steps record (DESIGN §3, `[steps]`): after the native calibration part, each measurand
//! in turn (in the dataset's canonical order) moves by linear ramps through `levels` levels and
//! holds each for `hold_s`, while every other measurand stays at its calibration-part median.
//! The levels span the 5th to the 95th percentile of the measurand's calibration part, evenly
//! spaced, and are visited low, high, second-lowest, second-highest, …, middle, so that the
//! level is not a trend in time. Each level is held twice, approached once from below and once
//! from above (a ramp out to one level spacing beyond the level and back, far enough to turn
//! any hysteresis loop narrower than that), as a calibration laboratory takes an ascending and a descending series: a
//! hysteresis loop then shows as the difference of the two holds, not as a gain error (visited
//! once, the low levels would all be reached falling and the high ones rising, and the loop's
//! width would read as a slope). The holds carry no AR wiggle: the truth is exactly constant.
//!
//! [`holds`] finds the holds of such a record again from its truth columns alone (a CSV read
//! back has no scenario), for scoring a model on settled, known levels.

use std::ops::Range;

use crate::data::{Dataset, Split};
use crate::sim::scenario::Steps;

/// The calibration-part percentiles the levels span.
pub(crate) const LEVEL_PERCENTILES: (f64, f64) = (5.0, 95.0);

/// Fewest rows of constant truth [`holds`] counts as a hold.
pub(crate) const MIN_HOLD_ROWS: usize = 4;

/// The order the levels 0 (lowest) … `levels` − 1 are visited: low, high, second-lowest,
/// second-highest, …, middle.
pub(crate) fn visit_order(levels: usize) -> Vec<usize> {
    let (mut lo, mut hi) = (0, levels);
    let mut out = Vec::with_capacity(levels);
    while lo < hi {
        out.push(lo);
        lo += 1;
        if lo < hi {
            hi -= 1;
            out.push(hi);
        }
    }
    out
}

/// The `p`-th percentile (0–100) of `x`, linear between order statistics; NaN when empty.
pub fn percentile(x: &[f64], p: f64) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let r = (p / 100.0).clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (i, f) = (r.floor() as usize, r - r.floor());
    match v.get(i + 1) {
        Some(&next) => v[i] + f * (next - v[i]),
        None => v[i],
    }
}

/// `levels` levels evenly spaced from the 5th to the 95th percentile of `cal`, lowest first.
pub(crate) fn levels_of(cal: &[f64], levels: usize) -> Vec<f64> {
    let (lo, hi) = (percentile(cal, LEVEL_PERCENTILES.0), percentile(cal, LEVEL_PERCENTILES.1));
    let last = levels.saturating_sub(1).max(1) as f64;
    (0..levels).map(|i| lo + (hi - lo) * i as f64 / last).collect()
}

/// Append the steps part to `series` (each holding its calibration part): the series listed in
/// `stepped` step in that order through their levels, every series not being stepped holds its
/// calibration-part median. Each level is visited `Steps::APPROACHES` times, each visit
/// `hold_samples` long: a linear ramp of `ramp_samples` out to the excursion point (one level
/// spacing below, then above, the level: far enough to turn any hysteresis loop narrower than
/// a level spacing, even beyond the calibration range at the end levels), a ramp of
/// `ramp_samples` back to the level, and the level held to the end of the visit.
pub fn extend(series: &mut [Vec<f64>], stepped: &[usize], steps: &Steps, hold_samples: usize, ramp_samples: usize) {
    let medians: Vec<f64> = series.iter().map(|s| crate::stats::median(s)).collect();
    let levels: Vec<Vec<f64>> = stepped.iter().map(|&k| levels_of(&series[k], steps.levels as usize)).collect();
    let order = visit_order(steps.levels as usize);
    let ramp = ramp_samples.max(1);
    let mut prev: Vec<f64> = series.iter().map(|s| s.last().copied().unwrap_or(f64::NAN)).collect();
    for (q, &k) in stepped.iter().enumerate() {
        let lv = &levels[q];
        let spacing = if lv.len() > 1 { (lv[lv.len() - 1] - lv[0]) / (lv.len() - 1) as f64 } else { 0.0 };
        for &l in &order {
            for side in [-1.0, 1.0] {
                let level = lv[l];
                let excursion = level + side * spacing;
                let at =
                    |v: f64| -> Vec<f64> { (0..series.len()).map(|s| if s == k { v } else { medians[s] }).collect() };
                let (out_to, target) = (at(excursion), at(level));
                for j in 0..hold_samples {
                    for (s, out) in series.iter_mut().enumerate() {
                        // Out to the excursion point, back, then the setpoint itself: holds are
                        // exactly constant.
                        out.push(if j < ramp {
                            prev[s] + (out_to[s] - prev[s]) * (j + 1) as f64 / ramp as f64
                        } else if j + 1 < 2 * ramp {
                            out_to[s] + (target[s] - out_to[s]) * (j + 1 - ramp) as f64 / ramp as f64
                        } else {
                            target[s]
                        });
                    }
                }
                prev = target;
            }
        }
    }
}

/// One settled hold of a steps record.
#[derive(Clone, Debug, PartialEq)]
pub struct Hold {
    /// The measurand that was stepped, as an index into the dataset's references (canonical
    /// order).
    pub measurand: usize,
    /// Its true (held) value, in its unit.
    pub level: f64,
    /// The rows of the last half of the hold, when the instrument's memory has settled.
    pub rows: Range<usize>,
}

/// The holds of a steps record, found from its truth columns: hold-out runs of at least
/// `MIN_HOLD_ROWS` rows over which every reference is exactly constant. The stepped
/// measurand of a run is the one away from its resting value (the value its holds take most
/// often; with a single measurand every run is its own). Runs where that is not exactly one
/// measurand are left out. Empty for a record that is no steps record.
pub fn holds(data: &Dataset) -> Vec<Hold> {
    let n = data.len();
    let same = |a: usize, b: usize| data.refs.iter().all(|r| r.values[a] == r.values[b] && r.values[a].is_finite());
    let mut runs: Vec<Range<usize>> = Vec::new();
    let mut i = 0;
    while i < n {
        if data.split[i] != Split::Holdout || !same(i, i) {
            i += 1;
            continue;
        }
        let mut j = i + 1;
        while j < n && data.split[j] == Split::Holdout && same(i, j) {
            j += 1;
        }
        if j - i >= MIN_HOLD_ROWS {
            runs.push(i..j);
        }
        i = j;
    }
    let rest: Vec<Option<f64>> = data
        .refs
        .iter()
        .map(|r| {
            let mut counts: Vec<(u64, usize)> = Vec::new();
            for run in &runs {
                let bits = r.values[run.start].to_bits();
                match counts.iter_mut().find(|(b, _)| *b == bits) {
                    Some((_, c)) => *c += 1,
                    None => counts.push((bits, 1)),
                }
            }
            counts.iter().max_by_key(|(_, c)| *c).filter(|(_, c)| *c >= 2).map(|(b, _)| f64::from_bits(*b))
        })
        .collect();
    let single = data.refs.len() == 1;
    runs.into_iter()
        .filter_map(|run| {
            let moved: Vec<usize> =
                (0..data.refs.len()).filter(|&c| single || rest[c] != Some(data.refs[c].values[run.start])).collect();
            let &[c] = moved.as_slice() else { return None };
            let mid = run.start + (run.end - run.start) / 2;
            Some(Hold { measurand: c, level: data.refs[c].values[run.start], rows: mid..run.end })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_are_visited_away_from_their_neighbours() {
        assert_eq!(visit_order(5), [0, 4, 1, 3, 2]);
        assert_eq!(visit_order(6), [0, 5, 1, 4, 2, 3]);
        let x: Vec<f64> = (0..=100).map(f64::from).collect();
        assert_eq!(percentile(&x, 5.0), 5.0);
        assert_eq!(levels_of(&x, 5), [5.0, 27.5, 50.0, 72.5, 95.0]);
    }

    #[test]
    fn extend_ramps_then_holds_exactly() {
        let mut s = vec![(0..100).map(f64::from).collect::<Vec<f64>>(), vec![7.0; 100]];
        let steps = Steps { enabled: true, levels: 5, hold_s: 0.0, ramp_s: 0.0 };
        extend(&mut s, &[0, 1], &steps, 20, 4);
        assert_eq!(s[0].len(), 100 + 2 * 5 * Steps::APPROACHES * 20);
        // First visit: measurand 0 ramps from 99 down to one level spacing below its lowest
        // level, back up to it and holds; measurand 1 goes to its median.
        let lo = percentile(&s[0][..100], 5.0);
        let lv = levels_of(&s[0][..100], 5);
        let spacing = (lv[4] - lv[0]) / 4.0;
        assert!((s[0][101] - (99.0 + (lo - spacing - 99.0) * 0.5)).abs() < 1e-9);
        assert!((s[0][103] - (lo - spacing)).abs() < 1e-9);
        assert!(s[0][107..120].iter().all(|&v| v == lo));
        // Second visit of the same level: from above.
        assert!((s[0][123] - (lo + spacing)).abs() < 1e-9);
        assert!(s[0][127..140].iter().all(|&v| v == lo));
        assert!(s[1][100..300].iter().all(|&v| v == 7.0));
    }
}
