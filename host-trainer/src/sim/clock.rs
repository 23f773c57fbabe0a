//! The logger's clock (DESIGN §3): timestamp jitter and recording gaps. The physics always runs
//! on the uniform grid k·dt_s; these only change which rows are recorded and the times
//! written beside them, from their own random streams.

use crate::rng::{Rng, Stream};
use crate::sim::scenario::Clock;

/// Largest timestamp error, as a fraction of dt_s: below ½, so the timestamps stay strictly
/// increasing.
pub(crate) const MAX_JITTER_FRACTION: f64 = 0.45;

/// The recorded time \[s\] of each of the `n` grid samples: k·dt_s, plus a Gaussian error of σ
/// `jitter_s` clamped to ±[`MAX_JITTER_FRACTION`]·dt_s when jitter is on (and to t ≥ 0).
pub fn timestamps(clock: &Clock, n: usize, seed: u64) -> Vec<f64> {
    let dt = clock.dt_s;
    let grid = (0..n).map(|k| k as f64 * dt);
    if clock.jitter_s <= 0.0 {
        return grid.collect();
    }
    let mut rng = Rng::new(seed, Stream::ClockJitter);
    let bound = MAX_JITTER_FRACTION * dt;
    // Never before the record's start.
    grid.map(|t| (t + (clock.jitter_s * rng.normal()).clamp(-bound, bound)).max(0.0)).collect()
}

/// The recording gaps \[s\] over `duration_s`: starts a Poisson process of `gaps_per_day`,
/// lengths exponential with mean `gap_mean_s`, each gap's start drawn after the previous one
/// ended. Empty when gaps are off.
pub fn gaps(clock: &Clock, duration_s: f64, seed: u64) -> Vec<(f64, f64)> {
    if clock.gaps_per_day <= 0.0 || clock.gap_mean_s <= 0.0 {
        return Vec::new();
    }
    let mut rng = Rng::new(seed, Stream::ClockGaps);
    let mut exp = |mean: f64| -mean * libm::log(1.0 - rng.uniform());
    let between = 86_400.0 / clock.gaps_per_day;
    let mut out = Vec::new();
    let mut t = exp(between);
    while t < duration_s {
        let len = exp(clock.gap_mean_s);
        out.push((t, t + len));
        t += len + exp(between);
    }
    out
}

/// The grid samples (of `n`) that are recorded: those outside every gap, or `None` when the
/// clock has no gaps.
pub(crate) fn kept_rows(clock: &Clock, n: usize, seed: u64) -> Option<Vec<usize>> {
    if clock.gaps_per_day <= 0.0 {
        return None;
    }
    let gaps = gaps(clock, n as f64 * clock.dt_s, seed);
    let mut g = gaps.iter().peekable();
    let mut keep = Vec::with_capacity(n);
    for k in 0..n {
        let t = k as f64 * clock.dt_s;
        while g.peek().is_some_and(|&&(_, end)| end <= t) {
            g.next();
        }
        if !g.peek().is_some_and(|&&(start, _)| start <= t) {
            keep.push(k);
        }
    }
    Some(keep)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jitter_keeps_time_increasing_and_has_its_sigma() {
        let c = Clock { jitter_s: 2.0, ..Clock::default() };
        let t = timestamps(&c, 20_000, 3);
        assert!(t.windows(2).all(|w| w[1] > w[0]));
        let dev: Vec<f64> = t.iter().enumerate().map(|(k, v)| v - k as f64 * 60.0).collect();
        let s = crate::stats::rms(dev.iter().copied());
        assert!((s - 2.0).abs() < 0.1, "{s}");
        // A jitter larger than the interval is clamped, never reordering samples.
        let wild = Clock { jitter_s: 500.0, ..Clock::default() };
        let t = timestamps(&wild, 5_000, 3);
        assert!(t.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(timestamps(&Clock::default(), 5, 3), vec![0.0, 60.0, 120.0, 180.0, 240.0]);
    }

    #[test]
    fn gaps_drop_about_the_expected_fraction() {
        let c = Clock { gaps_per_day: 2.0, gap_mean_s: 600.0, ..Clock::default() };
        let n = 200 * 1440;
        let keep = kept_rows(&c, n, 5).unwrap();
        let g = gaps(&c, n as f64 * 60.0, 5);
        assert!((300..500).contains(&g.len()), "{} gaps in 200 days", g.len());
        let dropped = (n - keep.len()) as f64 / n as f64;
        let want = 2.0 * 600.0 / 86_400.0;
        assert!((dropped / want - 1.0).abs() < 0.2, "dropped {dropped}, expected about {want}");
        assert!(keep.windows(2).all(|w| w[1] > w[0]));
        assert!(kept_rows(&Clock::default(), 10, 5).is_none());
    }
}
