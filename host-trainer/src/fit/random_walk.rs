//! The random walk of the interrogator's drift: how fast the error variance grows with the time
//! since calibration, read from the errors' structure function rather than from their lead.
//!
//! The lead-time regression of [`super::band`] sees one path of the drift over leads of a day
//! or two; its slope is mostly noise, shrunk it is often zero, and a week later the drift is
//! most of the error. A random walk of rate q \[unit²/s\] adds q·L to the structure function
//! D(L) = E[(e(t + L) − e(t))²] at every lag L; an error with a correlation time shorter than
//! L adds a constant, and one that repeats every day adds the same at L and L + 24 h. So
//!
//!   q̂ = (D(L₁ + 24 h) − D(L₁)) / 24 h,  L₁ = 12 h,
//!
//! uses every pair of samples of the validation stretches (the increments of a random walk are
//! independent) and leaves out the stationary and daily parts. It needs validation stretches
//! longer than L₁ + 24 h; a shorter calibration gives no estimate (`None`).
//!
//! **One drift for every output.** The interrogator's drift moves every grating (DESIGN Eq. 8),
//! each by its gain gᵢ when they are stated (`train --drift-gains`; else alike), so output c
//! sees it through its common-mode sensitivity s_c = Σᵢ gᵢ·∂ŷ_c/∂Δλᵢ, and q_d is the rate of
//! a channel of gain 1. Each
//! output's errors, divided by s_c, estimate the same rate q_d \[pm²/s\]; the estimates are
//! pooled with weights 1/D(L₁)² (the spread of an output's estimate grows with its own error
//! in pm), and each output's band grows by s_c²·q_d. A load cycle of several days in the
//! strain errors then weighs next to nothing, where read alone it would pass for a walk.
//! A single calibration week holds one path of the drift, so the estimate is rough (many
//! times the truth where weather or load cycles of several days pass for a walk): it is a floor
//! under the growth the validation errors calibrate. An interrogator's stated stability
//! ([`super::TrainOptions::drift_spec_pm_per_sqrt_day`]) is a walk the band adds as it is
//! ([`WalkGrowth`]).

/// The shorter lag L₁ \[s\]: longer than the hysteresis and thermometer-lag errors' memory.
pub const LAG_SHORT_S: f64 = 12.0 * 3_600.0;
/// The longer lag \[s\]: a day beyond [`LAG_SHORT_S`], so a daily cycle cancels.
pub const LAG_LONG_S: f64 = LAG_SHORT_S + 86_400.0;
/// A pair is taken when its spacing is within this fraction of the lag.
const LAG_TOLERANCE: f64 = 0.01;
/// Pairs at the longer lag below which there is no estimate.
const MIN_PAIRS: usize = 100;

/// Sums of squared differences at the two lags, over any number of error series.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StructureSums {
    short: (f64, usize),
    long: (f64, usize),
}

impl StructureSums {
    /// Add the pairs of one series: times `t_s` \[s\], increasing, and its signed errors `e`
    /// (non-finite errors are skipped).
    pub fn add(&mut self, t_s: &[f64], e: &[f64]) {
        self.short = sum_at_lag(t_s, e, LAG_SHORT_S, self.short);
        self.long = sum_at_lag(t_s, e, LAG_LONG_S, self.long);
    }

    /// Pool with the sums of other series.
    pub fn merge(&mut self, other: &StructureSums) {
        self.short = (self.short.0 + other.short.0, self.short.1 + other.short.1);
        self.long = (self.long.0 + other.long.0, self.long.1 + other.long.1);
    }

    /// The sums in another unit: every squared difference times `k` (1/s² turns an output's
    /// unit² into pm²).
    pub fn scaled(&self, k: f64) -> StructureSums {
        StructureSums { short: (self.short.0 * k, self.short.1), long: (self.long.0 * k, self.long.1) }
    }

    /// D(L₁) and D(L₁ + 24 h) \[unit²\]; `None` with too few pairs or a non-finite sum.
    fn structure(&self) -> Option<(f64, f64)> {
        if self.long.1 < MIN_PAIRS || self.short.1 < MIN_PAIRS {
            return None;
        }
        let d = (self.short.0 / self.short.1 as f64, self.long.0 / self.long.1 as f64);
        (d.0.is_finite() && d.1.is_finite()).then_some(d)
    }

    /// The random-walk rate q̂ \[unit²/s\] of this series alone, at least zero; `None` with too
    /// few pairs.
    #[cfg(test)]
    pub fn rate(&self) -> Option<f64> {
        self.structure().map(|(short, long)| ((long - short) / (LAG_LONG_S - LAG_SHORT_S)).max(0.0))
    }
}

/// The common rate q_d \[pm²/s\] from one set of sums per output, each of that output's
/// errors in pm (divided by its common-mode sensitivity): the outputs' (D(L₁ + 24 h) − D(L₁)) /
/// 24 h weighted by 1/D(L₁)², at least zero; `None` when no output has an estimate.
pub fn common_rate(per_output: &[StructureSums]) -> Option<f64> {
    let (mut sum, mut weights) = (0.0, 0.0);
    for (short, long) in per_output.iter().filter_map(StructureSums::structure) {
        if short > 0.0 {
            let w = 1.0 / (short * short);
            sum += w * (long - short) / (LAG_LONG_S - LAG_SHORT_S);
            weights += w;
        }
    }
    (weights > 0.0 && (sum / weights).is_finite()).then(|| (sum / weights).max(0.0))
}

/// Per output, the band growth the drift's walk adds \[unit²/s\]: s_c²·q for the rate read and
/// for the stated one. They enter the band differently (`VarModel::fit` in the band module): a
/// rate read from one week is rough (often many times the truth, where slow weather or load
/// cycles pass for a walk), so it is only a floor under the growth whose 95 % multiplier the
/// validation errors set; a stated rate is the interrogator's walk, Gaussian, and is added with
/// the normal multiplier, from the end of calibration and as the offset the walk has there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WalkGrowth {
    /// s_c²·q_d with q_d read from the validation errors (`None`: no estimate).
    pub read: Option<f64>,
    /// s_c²·q_s with q_s the interrogator's stated stability (`None`: none stated).
    pub stated: Option<f64>,
}

/// The walk's rate q_d read from `per_output` (each output's sums in its own unit) through the
/// common-mode sensitivities `common` (s_c, unit per pm; one per output, for every series
/// alike: a series divided by its own s_c near zero would blow up), and per output the growth
/// s_c²·q \[unit²/s\] of the rate read and of the `stated` one \[pm²/s\].
pub fn growth(per_output: &[StructureSums], common: &[f64], stated: Option<f64>) -> (Option<f64>, Vec<WalkGrowth>) {
    let in_pm: Vec<StructureSums> = per_output
        .iter()
        .zip(common)
        .filter(|(_, s)| s.is_finite() && **s != 0.0)
        .map(|(w, s)| w.scaled(1.0 / (s * s)))
        .collect();
    let read = common_rate(&in_pm);
    let growth = (0..per_output.len())
        .map(|c| {
            let s2 = common.get(c).map_or(0.0, |s| s * s);
            WalkGrowth { read: read.map(|q| s2 * q), stated: stated.map(|q| s2 * q) }
        })
        .collect();
    (read, growth)
}

/// `acc` plus the squared differences of the pairs of (`t_s`, `e`) spaced `lag_s` apart
/// (within [`LAG_TOLERANCE`]), and their count.
fn sum_at_lag(t_s: &[f64], e: &[f64], lag_s: f64, acc: (f64, usize)) -> (f64, usize) {
    let tol = LAG_TOLERANCE * lag_s;
    let (mut sum, mut n) = acc;
    let mut j = 0;
    for (i, (&ti, &ei)) in t_s.iter().zip(e).enumerate() {
        let target = ti + lag_s;
        j = j.max(i);
        // The first sample at or after the target (times increase).
        while j < t_s.len() && t_s[j] < target - tol {
            j += 1;
        }
        let (Some(&tj), Some(&ej)) = (t_s.get(j), e.get(j)) else { break };
        if (tj - target).abs() <= tol && ei.is_finite() && ej.is_finite() {
            sum += (ej - ei) * (ej - ei);
            n += 1;
        }
    }
    (sum, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Rng, Stream};

    /// Minute samples over `days`: a random walk of rate `q` \[unit²/s\], white noise of
    /// variance `white`, and a daily cycle of amplitude `daily`.
    fn series(q: f64, white: f64, daily: f64, days: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
        let mut rng = Rng::new(seed, Stream::Drift);
        let n = (days * 1_440.0) as usize;
        let mut w = 0.0;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 60.0).collect();
        let e = t
            .iter()
            .map(|&ti| {
                w += (q * 60.0).sqrt() * rng.normal();
                w + white.sqrt() * rng.normal() + daily * (std::f64::consts::TAU * ti / 86_400.0).sin()
            })
            .collect();
        (t, e)
    }

    #[test]
    fn a_random_walk_reads_its_rate_through_noise_and_a_daily_cycle() {
        // Forty independent four-day stretches (one holds about two independent 36-h
        // increments, so one stretch alone reads the rate within a factor of two at best).
        let q = 1e-6;
        let mut s = StructureSums::default();
        for seed in 0..40 {
            let (t, e) = series(q, 0.05, 0.3, 4.0, seed);
            s.add(&t, &e);
        }
        let r = s.rate().unwrap();
        assert!((r / q - 1.0).abs() < 0.35, "rate {r:e} against {q:e}");
    }

    #[test]
    fn stationary_errors_and_a_daily_cycle_read_next_to_no_growth() {
        // No walk: the estimate is noise around zero, small beside what a walk of the same
        // variance over a week would add.
        let mut s = StructureSums::default();
        for seed in 0..40 {
            let (t, e) = series(0.0, 0.05, 0.3, 4.0, seed);
            s.add(&t, &e);
        }
        let r = s.rate().unwrap();
        assert!(r * 7.0 * 86_400.0 < 0.01, "rate {r:e}");
    }

    #[test]
    fn the_common_rate_leans_on_the_output_where_the_walk_is_most_of_the_error() {
        // One output: the walk under small noise; the other: the same walk under a large
        // error with a four-day cycle, which alone reads as a walk many times faster.
        let q = 1e-6;
        let (mut clean, mut cycled) = (StructureSums::default(), StructureSums::default());
        for seed in 0..40 {
            let (t, e) = series(q, 0.05, 0.0, 4.0, seed);
            clean.add(&t, &e);
            let big: Vec<f64> =
                t.iter().zip(&e).map(|(&ti, &ei)| ei + 3.0 * (std::f64::consts::TAU * ti / 345_600.0).sin()).collect();
            cycled.add(&t, &big);
        }
        assert!(cycled.rate().unwrap() > 5.0 * q, "the cycle alone: {:e}", cycled.rate().unwrap());
        let r = common_rate(&[clean, cycled]).unwrap();
        assert!((r / q - 1.0).abs() < 0.5, "common rate {r:e} against {q:e}");
        assert_eq!(common_rate(&[StructureSums::default()]), None);
    }

    #[test]
    fn each_output_grows_by_its_sensitivity_squared_times_each_rate() {
        // One output walking at 1e-6 unit²/s with s = 0.1 unit/pm (1e-4 pm²/s), one whose
        // common-mode sensitivity is 0 (left out of the read, no growth).
        let mut t_out = StructureSums::default();
        for seed in 0..40 {
            let (t, e) = series(1e-6, 0.0, 0.0, 4.0, seed);
            t_out.add(&t, &e);
        }
        let sums = [t_out, StructureSums::default()];
        let (read, g) = growth(&sums, &[0.1, 0.0], None);
        let q = read.unwrap();
        assert!((q / 1e-4 - 1.0).abs() < 0.35, "{q:e}");
        assert_eq!(g[0], WalkGrowth { read: Some(0.1 * 0.1 * q), stated: None });
        assert_eq!(g[1], WalkGrowth { read: Some(0.0), stated: None });
        // A stated rate is carried beside the one read, which is unchanged.
        let (read2, g2) = growth(&sums, &[0.1, 0.0], Some(1e-2));
        assert_eq!(read2, read);
        assert_eq!(g2[0], WalkGrowth { read: Some(0.1 * 0.1 * q), stated: Some(0.1 * 0.1 * 1e-2) });
        // Nothing read and nothing stated: no growth known.
        assert_eq!(growth(&[StructureSums::default()], &[0.1], None), (None, vec![WalkGrowth::default()]));
        assert_eq!(
            growth(&[StructureSums::default()], &[0.1], Some(1e-2)).1,
            vec![WalkGrowth { read: None, stated: Some(0.1 * 0.1 * 1e-2) }]
        );
    }

    #[test]
    fn stretches_shorter_than_the_long_lag_give_no_estimate() {
        let (t, e) = series(1e-6, 0.05, 0.0, 1.4, 3);
        let mut s = StructureSums::default();
        s.add(&t, &e);
        assert_eq!(s.rate(), None);
    }

    #[test]
    fn gaps_and_non_finite_errors_are_skipped() {
        let (mut t, mut e) = series(1e-6, 0.0, 0.0, 4.0, 5);
        // A six-hour gap and a NaN: no pair uses either.
        t.drain(1_000..1_360);
        e.drain(1_000..1_360);
        e[2_000] = f64::NAN;
        let mut s = StructureSums::default();
        s.add(&t, &e);
        assert!(s.rate().is_some_and(f64::is_finite));
    }
}
