//! First-order low-pass (exponential moving average) on an irregular clock.

use crate::real::Real;

/// Below this Δt/τ the smoothing factor is taken from its Taylor series (exact to rounding),
/// above it from `1 − e^(−Δt/τ)` (where the subtraction loses nothing that matters).
const SERIES_BELOW: f64 = 0.125;

/// The smoothing factor α = 1 − e^(−Δt/τ) of a first-order low-pass for a step of `dt_s` [s]
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
#[inline]
pub fn smoothing_factor<F: Real>(dt_s: F, inv_tau: F) -> F {
    let x = dt_s * inv_tau;
    if !(x > F::ZERO) {
        return F::ZERO;
    }
    if x < F::from_f64(SERIES_BELOW) {
        // x − x²/2 + x³/6 − x⁴/24 + x⁵/120: truncation below x⁶/720 < 5e-9·x.
        let c5 = F::from_f64(1.0 / 120.0);
        let c4 = F::from_f64(-1.0 / 24.0);
        let c3 = F::from_f64(1.0 / 6.0);
        let c2 = F::from_f64(-0.5);
        let p = c5.mul_add(x, c4).mul_add(x, c3).mul_add(x, c2).mul_add(x, F::ONE);
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
    /// A low-pass with time constant `tau_s` [s] (> 0; 0 or less gives a pass-through whose
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
