//! The pace of the inputs: how fast they have moved lately, against how fast the calibration
//! saw them move ([`crate::trust`], "the pace of the calibration").
//!
//! Each envelope input's swing s = LP_fast(x) − LP_slow(x) is a band-pass of the input: two
//! first-order low-passes with time constants [`SWING_FAST_TAU_S`] and [`SWING_SLOW_TAU_S`],
//! each stepped with α = Δt / (τ + Δt). A ramp of rate r settles at s = r·(τ_slow − τ_fast), so
//! |s| measures the recent rate in the input's own unit while the fast low-pass keeps the white
//! noise out. Its power P = LP_window(s²), a low-pass of s² over [`PACE_WINDOW_S`], is the
//! pace: how much the input moved over the last hours. The calibration shows each input's
//! largest RMS swing √P_max.
//!
//! The swing measures a rate only below the band-pass's lower corner: an oscillation faster
//! than the slow low-pass (a load cycle of minutes) reads as its amplitude however fast it
//! goes. So each input also has a speed v = (x − LP_fast(x)) / τ_fast, the rate of the fast
//! low-pass (a ramp of rate r settles at v = r exactly; an oscillation of amplitude A and
//! angular frequency ω reads A·ω/√(1 + (ωτ_fast)²), growing with ω up to A/τ_fast, and white
//! noise of σ adds about σ/τ_fast), and its power Q = LP_window(v²). The pace ratio of a
//! stream is ρ = max_k max(√(P_k / P_max,k), √(Q_k / Q_max,k)) ([`Pace::ratios_sq`] gives ρ²).
//!
//! A pace slower than the calibration's slowest is outside it too: its slowness is
//! σ = max_k √(P_min,k / P_k), P_min,k the smallest power of input k over the calibration once
//! the filters had settled ([`Pace::ratios_sq`] gives σ², at most 4).

use crate::layout::{head, MAX_ENVELOPE};
use crate::real::Real;
use crate::trust::TrustSpec;

/// Time constant of the swing's fast low-pass \[s\].
pub const SWING_FAST_TAU_S: f64 = 120.0;

/// Time constant of the swing's slow low-pass \[s\].
pub const SWING_SLOW_TAU_S: f64 = 1200.0;

/// Time constant of the low-pass of the squared swing (the pace window) \[s\].
pub const PACE_WINDOW_S: f64 = 3.0 * 3600.0;

/// The filters of every envelope input (Δλ_1..N \[pm\], then T_amb \[°C\]): what a stream carries
/// for its pace. Starts at the first sample it sees (swing and power 0).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SwingFilter<F> {
    fast: [F; MAX_ENVELOPE],
    slow: [F; MAX_ENVELOPE],
    power: [F; MAX_ENVELOPE],
    speed_power: [F; MAX_ENVELOPE],
    primed: bool,
}

impl<F: Real> SwingFilter<F> {
    /// A filter that has seen nothing.
    pub const fn new() -> Self {
        SwingFilter {
            fast: [F::ZERO; MAX_ENVELOPE],
            slow: [F::ZERO; MAX_ENVELOPE],
            power: [F::ZERO; MAX_ENVELOPE],
            speed_power: [F::ZERO; MAX_ENVELOPE],
            primed: false,
        }
    }

    /// Take the first `n` inputs of `x`, `dt_s` after the last sample taken. A first sample
    /// sets both low-passes to it; a `dt_s` that is not a positive number leaves the filters as
    /// they were (a clock that stands still or steps back gives no rate).
    ///
    /// ```
    /// use fbg_shared::compensator::{SwingFilter, SWING_FAST_TAU_S, SWING_SLOW_TAU_S};
    /// let mut f = SwingFilter::<f64>::new();
    /// // A ramp of 0.01 °C/s on input 0, sampled every 10 s for 20 h.
    /// for i in 0..7200 {
    ///     f.update(&[0.01 * 10.0 * i as f64; 9], 1, 10.0);
    /// }
    /// let expected = 0.01 * (SWING_SLOW_TAU_S - SWING_FAST_TAU_S);
    /// assert!((f.swing(0) - expected).abs() < 1e-3 * expected);
    /// // The power has settled at the squared swing.
    /// assert!((f.power(0).sqrt() - expected).abs() < 1e-2 * expected);
    /// // The speed reads the ramp's rate.
    /// assert!((f.speed_power(0).sqrt() - 0.01).abs() < 1e-4);
    /// ```
    #[inline(always)]
    pub fn update(&mut self, x: &[F; MAX_ENVELOPE], n: usize, dt_s: F) {
        if !self.primed {
            self.fast = *x;
            self.slow = *x;
            self.primed = true;
            return;
        }
        if dt_s <= F::ZERO || !dt_s.is_finite() {
            return;
        }
        let a_fast = dt_s / (F::from_f64(SWING_FAST_TAU_S) + dt_s);
        let a_slow = dt_s / (F::from_f64(SWING_SLOW_TAU_S) + dt_s);
        let a_power = dt_s / (F::from_f64(PACE_WINDOW_S) + dt_s);
        let inv_tau_fast = F::from_f64(1.0 / SWING_FAST_TAU_S);
        for ((((f, s), p), q), &v) in self
            .fast
            .iter_mut()
            .zip(self.slow.iter_mut())
            .zip(self.power.iter_mut())
            .zip(self.speed_power.iter_mut())
            .zip(head(x, n).iter())
        {
            *f = a_fast.mul_add(v - *f, *f);
            *s = a_slow.mul_add(v - *s, *s);
            let sw = *f - *s;
            *p = a_power.mul_add(sw.mul_add(sw, -*p), *p);
            let speed = (v - *f) * inv_tau_fast;
            *q = a_power.mul_add(speed.mul_add(speed, -*q), *q);
        }
    }

    /// The swing of input `k` (0 beyond the inputs or before the first sample).
    #[inline(always)]
    pub fn swing(&self, k: usize) -> F {
        match (self.fast.get(k), self.slow.get(k)) {
            (Some(&f), Some(&s)) => f - s,
            _ => F::ZERO,
        }
    }

    /// The power of input `k`'s swing over the pace window (its unit²; 0 beyond the inputs).
    #[inline(always)]
    pub fn power(&self, k: usize) -> F {
        self.power.get(k).copied().unwrap_or(F::ZERO)
    }

    /// The power of input `k`'s speed over the pace window (its unit²/s²; 0 beyond the
    /// inputs).
    #[inline(always)]
    pub fn speed_power(&self, k: usize) -> F {
        self.speed_power.get(k).copied().unwrap_or(F::ZERO)
    }
}

/// The calibration's pace, folded at load: 1 / P_max and 1 / Q_max of each input (0: not
/// read), and P_min (0: not read).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Pace<F> {
    inv_max: [F; MAX_ENVELOPE],
    inv_speed_max: [F; MAX_ENVELOPE],
    min: [F; MAX_ENVELOPE],
    /// Inputs read (0: no pace term).
    n: u8,
}

impl<F: Real> Pace<F> {
    /// No pace term.
    pub(super) const fn off() -> Self {
        Pace {
            inv_max: [F::ZERO; MAX_ENVELOPE],
            inv_speed_max: [F::ZERO; MAX_ENVELOPE],
            min: [F::ZERO; MAX_ENVELOPE],
            n: 0,
        }
    }

    /// The pace term of a trust spec over `n` envelope inputs; off when no input has a
    /// calibration swing or speed, largest or smallest.
    pub(super) fn new<G: Real>(trust: &TrustSpec<G>, n: usize) -> Self {
        let mut p = Pace::off();
        let pairs = p
            .inv_max
            .iter_mut()
            .zip(head(&trust.swing_rms_max, n).iter())
            .chain(p.inv_speed_max.iter_mut().zip(head(&trust.speed_rms_max, n).iter()));
        let mut on = false;
        for (o, &v) in pairs {
            let v = F::from_real(v);
            if v > F::ZERO {
                *o = F::ONE / (v * v);
                on = true;
            }
        }
        for (o, &v) in p.min.iter_mut().zip(head(&trust.swing_rms_min, n).iter()) {
            let v = F::from_real(v);
            if v > F::ZERO {
                *o = v * v;
                on = true;
            }
        }
        if on {
            p.n = n as u8;
        }
        p
    }

    /// Whether the term is off.
    #[inline(always)]
    pub(super) fn is_off(&self) -> bool {
        self.n == 0
    }

    /// (ρ², σ²) of `filter`: ρ² = max_k max(P_k / P_max,k, Q_k / Q_max,k), and the slowness
    /// ratio² max_k P_min,k / P_k, at most 4 (where the fade has reached 0; a filter that has
    /// seen nothing gives the cap, without a division); each 0 without its calibration
    /// figures. One pass over the inputs.
    #[inline(always)]
    pub(super) fn ratios_sq(&self, filter: &SwingFilter<F>) -> (F, F) {
        let four = F::from_f64(4.0);
        let (mut r, mut slow) = (F::ZERO, F::ZERO);
        let n = usize::from(self.n);
        let model = head(&self.inv_max, n).iter().zip(head(&self.inv_speed_max, n)).zip(head(&self.min, n));
        for (((&inv, &inv_speed), &min), (&p, &q)) in model.zip(filter.power.iter().zip(filter.speed_power.iter())) {
            let v = (p * inv).max(q * inv_speed);
            if v > r {
                r = v;
            }
            let v = if min <= F::ZERO {
                F::ZERO
            } else if p * four <= min {
                four
            } else {
                min / p
            };
            if v > slow {
                slow = v;
            }
        }
        (r, slow)
    }
}
