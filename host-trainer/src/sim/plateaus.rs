//! The plateau record (DESIGN §3, `[plateaus]`): after the native calibration part, every
//! measurand rests at a level drawn at random across its calibration range, holds it for a
//! random time between `hold_min_s` and `hold_max_s`, ramps linearly in `ramp_s` to the next
//! level, and so on to the end of the native record — each measurand on its own schedule, so
//! that one may move while the others rest.
//!
//! It is the state a monitored structure spends most of its life in: long rests at no
//! particular level, reached at no particular time. A model whose memory terms were learnt only
//! where the gratings always move is tested here where they sit still for hours; DESIGN §4's
//! second rule (trusted only where the calibration showed it) must hold on it. The levels span
//! the 5th to the 95th percentile of each measurand's calibration part (as the steps record's),
//! and the plateaus carry no AR wiggle: the truth is exactly constant while it rests.

use crate::rng::{Rng, Stream};
use crate::sim::scenario::Plateaus;
use crate::sim::steps::{percentile, LEVEL_PERCENTILES};

/// Replace every series' samples from `n_cal` on by its plateau schedule; the grid has
/// spacing `dt_s`. Draws from its own random stream, series after series, so the calibration
/// part and every other effect keep their bytes.
pub fn replace_holdout(series: &mut [Vec<f64>], n_cal: usize, plateaus: &Plateaus, dt_s: f64, seed: u64) {
    let mut rng = Rng::new(seed, Stream::Plateaus);
    let ramp = (plateaus.ramp_s / dt_s).round().max(1.0) as usize;
    for s in series.iter_mut() {
        let n = s.len();
        if n_cal == 0 || n_cal >= n {
            continue;
        }
        let cal = &s[..n_cal];
        let (lo, hi) = (percentile(cal, LEVEL_PERCENTILES.0), percentile(cal, LEVEL_PERCENTILES.1));
        let mut from = cal[n_cal - 1];
        let mut i = n_cal;
        while i < n {
            let level = rng.uniform_in(lo, hi);
            let hold_s = rng.uniform_in(plateaus.hold_min_s, plateaus.hold_max_s);
            let visit = ramp + (hold_s / dt_s).round().max(1.0) as usize;
            for j in 0..visit.min(n - i) {
                s[i + j] = if j < ramp { from + (level - from) * (j + 1) as f64 / ramp as f64 } else { level };
            }
            i += visit;
            from = level;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn holds_random_levels_inside_the_calibration_range_for_their_drawn_times() {
        let cal: Vec<f64> = (0..1000).map(|k| (k as f64 * 0.01).sin()).collect();
        let mut s = vec![[cal.clone(), vec![0.0; 5000]].concat(), [cal.clone(), vec![0.0; 5000]].concat()];
        let p = Plateaus { enabled: true, hold_min_s: 4.0 * 3600.0, hold_max_s: 16.0 * 3600.0, ramp_s: 600.0 };
        replace_holdout(&mut s, 1000, &p, 60.0, 7);
        let (lo, hi) = (percentile(&cal, 5.0), percentile(&cal, 95.0));
        for x in &s {
            assert_eq!(x[..1000], cal[..]);
            // Runs of exactly constant truth: every one inside the range and 4–16 h long (the
            // last one cut by the record's end).
            let mut runs = Vec::new();
            let mut k = 1000 + 10;
            while k < x.len() {
                let mut j = k;
                while j < x.len() && x[j] == x[k] {
                    j += 1;
                }
                runs.push((x[k], j - k, j == x.len()));
                k = j + 10;
            }
            assert!(runs.len() >= 5, "{runs:?}");
            for &(level, len, last) in &runs {
                assert!((lo..=hi).contains(&level), "{level}");
                assert!(last || (240..=960).contains(&len), "{len}");
            }
        }
        // Each series on its own schedule.
        assert_ne!(s[0][2000..], s[1][2000..]);
    }
}
