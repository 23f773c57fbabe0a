//! First-order low-pass (exponential moving average) on an irregular clock.

use crate::real::Real;

/// Below this Δt/τ the smoothing factor is taken from its Taylor series (exact to rounding),
/// above it from `1 − e^(−Δt/τ)` (where the subtraction loses nothing that matters).
const SERIES_BELOW: f64 = 0.125;

/// The smoothing factor α = 1 − e^(−Δt/τ) of a first-order low-pass for a step of `dt_s` \[s\]
/// with `inv_tau` = 1/τ [1/s], in 0..=1.
///
/// This is the exact discretisation of `τ·ds/dt = x − s` when the input holds the new sample's
/// value over the step (zero-order hold), so the time constant is τ seconds at any sample rate
/// and across gaps. `dt_s <= 0` (a repeated or backward time stamp) gives 0: the state stays.
///
/// ```
/// use fbg_shared::memory::smoothing_factor;
/// let a: f64 = smoothing_factor(60.0, 1.0 / 600.0);
/// assert!((a - (1.0 - (-0.1f64).exp())).abs() < 1e-15);
/// assert_eq!(smoothing_factor(-1.0f32, 0.01), 0.0);
/// ```
// Out of line: it runs only when Δt changes, and twelve inlined copies cost device flash.
#[inline(never)]
pub fn smoothing_factor<F: Real>(dt_s: F, inv_tau: F) -> F {
    let x = dt_s * inv_tau;
    // Negated on purpose: NaN (e.g. ∞ · 0) holds the state too.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(x > F::ZERO) {
        return F::ZERO;
    }
    if x < F::from_f64(SERIES_BELOW) {
        // x·(1 − x/2! + x²/3! − … − x⁹/10!): the first omitted term, x¹¹/11!, is below
        // 2.5e-17·x for x < 0.125, so the series is exact to f64 rounding. (Stopping at x⁵/5!
        // left an error of up to x⁶/6! ≈ 4.4e-8·x at the switch, visible in f64.)
        let c10 = F::from_f64(-1.0 / 3_628_800.0);
        let c9 = F::from_f64(1.0 / 362_880.0);
        let c8 = F::from_f64(-1.0 / 40_320.0);
        let c7 = F::from_f64(1.0 / 5_040.0);
        let c6 = F::from_f64(-1.0 / 720.0);
        let c5 = F::from_f64(1.0 / 120.0);
        let c4 = F::from_f64(-1.0 / 24.0);
        let c3 = F::from_f64(1.0 / 6.0);
        let c2 = F::from_f64(-0.5);
        let p = c10
            .mul_add(x, c9)
            .mul_add(x, c8)
            .mul_add(x, c7)
            .mul_add(x, c6)
            .mul_add(x, c5)
            .mul_add(x, c4)
            .mul_add(x, c3)
            .mul_add(x, c2)
            .mul_add(x, F::ONE);
        p * x
    } else {
        F::ONE - x.exp_neg()
    }
}

/// A first-order low-pass: its coefficient, the time constant, as 1/τ [1/s]. The state is one
/// scalar kept by the caller (in the input's unit).
///
/// `s ← s + α(Δt)·(x − s)` with α from [`smoothing_factor`]. Step response: after a step of
/// height h at t₀, `s(t) = h·(1 − e^(−(t − t₀)/τ))` at every sample time, whatever the spacing.
///
/// ```
/// use fbg_shared::memory::LowPass;
/// let lp = LowPass::new(600.0f64);
/// let mut s = 0.0;
/// // One step of one time constant reaches 1 − 1/e of a unit step.
/// lp.update(&mut s, 1.0, lp.alpha(600.0));
/// assert!((s - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LowPass<F> {
    inv_tau: F,
}

impl<F: Real> LowPass<F> {
    /// An unused slot (α is always 0).
    pub const fn off() -> Self {
        LowPass { inv_tau: F::ZERO }
    }

    /// A low-pass with time constant `tau_s` \[s\] (> 0; 0 or less gives a pass-through whose
    /// α is 0, i.e. an unused slot).
    pub fn new(tau_s: F) -> Self {
        LowPass { inv_tau: if tau_s > F::ZERO { F::ONE / tau_s } else { F::ZERO } }
    }

    /// 1/τ [1/s].
    pub fn inv_tau(&self) -> F {
        self.inv_tau
    }

    /// The smoothing factor for a step of `dt_s` seconds.
    #[inline]
    pub fn alpha(&self, dt_s: F) -> F {
        smoothing_factor(dt_s, self.inv_tau)
    }

    /// Move `state` towards `x` by `alpha` (from [`LowPass::alpha`]) and return the new state.
    #[inline(always)]
    pub fn update(&self, state: &mut F, x: F, alpha: F) -> F {
        *state = alpha.mul_add(x - *state, *state);
        *state
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fbg_testkit::Rng;
    use std::vec::Vec;

    /// The exact α = 1 − e^(−x), without cancellation.
    fn exact(x: f64) -> f64 {
        -libm::expm1(-x)
    }

    /// x on a log grid from 1e-9 to 50, plus a dense band around the series/exp switch.
    fn xs() -> Vec<f64> {
        let mut v: Vec<f64> = (0..=2000).map(|i| 1e-9 * libm::pow(5e10, f64::from(i) / 2000.0)).collect();
        let mut x = SERIES_BELOW;
        for _ in 0..200 {
            x = f64::from_bits(x.to_bits() - 1);
            v.push(x);
        }
        v.extend((0..2000).map(|i| SERIES_BELOW * (0.9 + 0.2 * f64::from(i) / 2000.0)));
        v
    }

    #[test]
    fn smoothing_factor_is_one_minus_exp_in_f64() {
        let (mut worst_series, mut worst_exp) = (0.0f64, 0.0f64);
        for x in xs() {
            // inv_tau = 1: dt is x itself, so the product dt·(1/τ) is exact.
            let a: f64 = smoothing_factor(x, 1.0);
            let rel = ((a - exact(x)) / exact(x)).abs();
            if x < SERIES_BELOW {
                worst_series = worst_series.max(rel);
            } else {
                worst_exp = worst_exp.max(rel);
                // The exp branch is literally 1 − e^(−x): the same as libm's up to the 2 ulp
                // of exp_neg_f64, i.e. 2.2e-16 absolute (α >= 0.1175 there).
                assert!((a - (1.0 - libm::exp(-x))).abs() <= 2.3e-16, "x = {x}");
            }
            assert!((0.0..=1.0).contains(&a), "x = {x}: α = {a}");
        }
        // Series: exact to rounding (truncation < 2.5e-17 relative, a few roundings).
        assert!(worst_series < 1e-15, "series branch: worst relative error {worst_series:e}");
        // exp branch: e^(−x) to 2 ulp, amplified by the cancellation e^(−x)/(1 − e^(−x)) <= 7.5
        // at x = 0.125, so below 2e-15 relative (measured: see the message).
        assert!(worst_exp < 2e-15, "exp branch: worst relative error {worst_exp:e}");
    }

    #[test]
    fn smoothing_factor_is_one_minus_exp_in_f32() {
        let mut worst = 0.0f64;
        for x in xs() {
            let x32 = x as f32;
            let a: f32 = smoothing_factor(x32, 1.0);
            let want = exact(f64::from(x32));
            worst = worst.max(((f64::from(a) - want) / want).abs());
            assert!((0.0..=1.0).contains(&a));
        }
        // exp_neg_f32's 5e-7 relative error times the cancellation factor 7.5 at the switch.
        assert!(worst < 4e-6, "worst relative error {worst:e}");
    }

    #[test]
    fn smoothing_factor_is_continuous_at_the_switch() {
        // f64: the last value from the series and the first from the exponential agree to
        // rounding (the exact α changes by 1 ulp of x across the pair).
        let hi = SERIES_BELOW;
        let lo = f64::from_bits(hi.to_bits() - 1);
        let (a_lo, a_hi): (f64, f64) = (smoothing_factor(lo, 1.0), smoothing_factor(hi, 1.0));
        assert!(a_lo <= a_hi || (a_lo - a_hi) / a_hi < 2e-15, "{a_lo} > {a_hi}");
        assert!(((a_hi - a_lo) / a_hi).abs() < 2e-15, "jump {:e}", (a_hi - a_lo) / a_hi);
        // The same across a wider neighbourhood: α/x is smooth, the branches meet.
        for k in 1..=1000u32 {
            let d = f64::from(k) * 1e-7;
            let (x0, x1) = (hi - d, hi + d);
            let (a0, a1): (f64, f64) = (smoothing_factor(x0, 1.0), smoothing_factor(x1, 1.0));
            assert!(a0 < a1, "monotone across the switch: α({x0}) = {a0} >= α({x1}) = {a1}");
        }
        // f32: the exponential branch carries exp_neg_f32's error (5e-7 × 7.5).
        let hi = SERIES_BELOW as f32;
        let lo = f32::from_bits(hi.to_bits() - 1);
        let (a_lo, a_hi): (f32, f32) = (smoothing_factor(lo, 1.0), smoothing_factor(hi, 1.0));
        assert!(((a_hi - a_lo) / a_hi).abs() < 4e-6, "f32 jump {:e}", (a_hi - a_lo) / a_hi);
    }

    #[test]
    fn a_non_positive_or_undefined_step_holds_the_state() {
        for dt in [0.0, -0.0, -1.0, -1e9, f64::NEG_INFINITY, f64::NAN] {
            assert_eq!(smoothing_factor(dt, 1.0 / 600.0), 0.0, "dt = {dt}");
            assert_eq!(smoothing_factor(dt as f32, 1.0 / 600.0), 0.0, "dt = {dt}");
        }
        let lp = LowPass::new(600.0f64);
        let mut s = 3.0;
        for dt in [0.0, -60.0] {
            assert_eq!(lp.update(&mut s, 100.0, lp.alpha(dt)), 3.0);
        }
        assert_eq!(s, 3.0);
        // An unused slot (τ <= 0) has α = 0 at any step: its state never moves.
        for tau in [0.0, -5.0] {
            let lp = LowPass::new(tau);
            assert_eq!(lp.inv_tau(), 0.0);
            assert_eq!(lp.alpha(60.0), 0.0);
            assert_eq!(lp.alpha(f64::INFINITY), 0.0, "∞ · 0 is NaN, which holds");
        }
        // Very long steps reach the input: α = 1.
        assert_eq!(smoothing_factor(1e9f64, 1.0 / 60.0), 1.0);
        assert_eq!(smoothing_factor(f64::INFINITY, 1.0 / 60.0), 1.0);
        assert_eq!(smoothing_factor(1e9f32, 1.0 / 60.0), 1.0);
    }

    /// A unit step at t0 (state 0 primed at t0, input 1 from the next sample on) sampled with
    /// Δt drawn from {1, 7, 60, 300} s: s(t) = 1 − e^(−(t − t0)/τ) at every sample.
    fn step_response<F: Real>(tau: f64, seed: u64, tol: f64) -> f64 {
        let mut r = Rng(seed);
        let lp = LowPass::new(F::from_f64(tau));
        let t0 = 1000.0;
        let (mut t, mut s) = (t0, F::ZERO);
        let mut worst = 0.0f64;
        while t - t0 < 12.0 * tau {
            let dt = r.pick(&[1.0, 7.0, 60.0, 300.0]).unwrap();
            t += dt;
            lp.update(&mut s, F::ONE, lp.alpha(F::from_f64(dt)));
            let want = -libm::expm1(-(t - t0) / tau);
            let err = (s.to_f64() - want).abs();
            worst = worst.max(err);
            assert!(err < tol, "τ = {tau}, t − t0 = {}: {} vs {want}", t - t0, s.to_f64());
        }
        worst
    }

    #[test]
    fn step_response_under_an_irregular_clock() {
        let (mut w64, mut w32) = (0.0f64, 0.0f64);
        for tau in [30.0, 600.0, 3600.0] {
            for seed in 0..4 {
                w64 = w64.max(step_response::<f64>(tau, seed, 1e-12));
                w32 = w32.max(step_response::<f32>(tau, seed, 1e-6));
            }
        }
        // τ = 1 day with 1-s steps among the others: an f32 state near 1 moves by
        // α·(1 − s) ≈ 1.2e-5·(1 − s), a few ulp (6e-8), and the roundings of ~4 000 such
        // steps add up (measured 5.2e-6); f64 still meets 1e-12.
        let mut w32_day = 0.0f64;
        for seed in 0..4 {
            w64 = w64.max(step_response::<f64>(86_400.0, seed, 1e-12));
            w32_day = w32_day.max(step_response::<f32>(86_400.0, seed, 1e-5));
        }
        std::eprintln!(
            "step response: worst |s − (1 − e^(−Δt/τ))| f64 {w64:.1e}, f32 {w32:.1e} (τ <= 1 h), {w32_day:.1e} (τ = 1 day)"
        );
    }

    #[test]
    fn one_time_constant_by_any_partition_reaches_one_minus_one_over_e() {
        // 600 s = 300 + 4·60 + 8·7 + 4·1 in every order: the irregular clock does not matter.
        let mut steps: Vec<f64> = [300.0].into_iter().chain([60.0; 4]).chain([7.0; 8]).chain([1.0; 4]).collect();
        assert_eq!(steps.iter().sum::<f64>(), 600.0);
        let lp = LowPass::new(600.0f64);
        let want = 1.0 - libm::exp(-1.0);
        let mut r = Rng(9);
        for _ in 0..50 {
            // Fisher–Yates shuffle.
            for i in (1..steps.len()).rev() {
                let j = (r.next_u64() % (i as u64 + 1)) as usize;
                steps.swap(i, j);
            }
            let mut s = 0.0;
            for &dt in &steps {
                lp.update(&mut s, 1.0, lp.alpha(dt));
            }
            assert!((s - want).abs() < 1e-15, "{s} vs {want}");
        }
        // One step of exactly τ.
        let mut s = 0.0;
        lp.update(&mut s, 1.0, lp.alpha(600.0));
        assert!((s - want).abs() < 1e-15);
    }
}
