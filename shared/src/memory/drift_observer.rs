//! A causal observer of the interrogator's common drift, seen as a temperature.

use crate::memory::low_pass::LowPass;
use crate::real::Real;

/// The temperature the gratings imply, lagged like the reference thermometer, minus that
/// thermometer, smoothed: `o = EMA_τs(EMA_τl(T_g) − T_amb)` [°C].
///
/// The thermometer follows the true temperature through a first-order lag; the gratings see it
/// at once but carry the interrogator's slow drift. Lagging the grating temperature T_g by the
/// thermometer's time constant τl and subtracting T_amb cancels the true temperature and
/// leaves the drift (plus the thermometer's offset and noise), which the second low-pass τs
/// smooths. A drift common to every grating looks like a temperature change to each of them,
/// so the observer is offered to temperature outputs only.
///
/// Coefficients only: the state is two scalars kept by the caller (`[lagged T_g, output]`).
///
/// ```
/// use fbg_shared::memory::DriftObserver;
/// let obs = DriftObserver::new(600.0f64, 3600.0);
/// let (lag, smooth) = obs.low_passes();
/// let alpha = [lag.alpha(60.0), smooth.alpha(60.0)];
/// let mut state = [0.0; 2];
/// DriftObserver::prime(&mut state, 20.0, 20.0); // no offset at the start
/// // The gratings read 0.5 °C warmer than the thermometer from now on (a drift).
/// let mut o = 0.0;
/// for _ in 0..1000 {
///     o = obs.update(&mut state, 20.5, 20.0, alpha);
/// }
/// assert!((o - 0.5).abs() < 1e-3, "the observer settles on the drift: {o}");
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DriftObserver<F> {
    lag: LowPass<F>,
    smooth: LowPass<F>,
}

impl<F: Real> DriftObserver<F> {
    /// An observer that is not used.
    pub const fn off() -> Self {
        DriftObserver { lag: LowPass::off(), smooth: LowPass::off() }
    }

    /// An observer with the thermometer's lag `lag_s` \[s\] and smoothing `smooth_s` \[s\].
    pub fn new(lag_s: F, smooth_s: F) -> Self {
        DriftObserver { lag: LowPass::new(lag_s), smooth: LowPass::new(smooth_s) }
    }

    /// The two low-passes (lag, smoothing).
    pub fn low_passes(&self) -> (LowPass<F>, LowPass<F>) {
        (self.lag, self.smooth)
    }

    /// Start a stream at grating temperature `t_g` and thermometer `t_amb` [°C].
    pub fn prime(state: &mut [F; 2], t_g: F, t_amb: F) {
        *state = [t_g, t_g - t_amb];
    }

    /// One step with smoothing factors `alpha = [lag, smooth]`; returns the observer output.
    #[inline(always)]
    pub fn update(&self, state: &mut [F; 2], t_g: F, t_amb: F, alpha: [F; 2]) -> F {
        let [lagged, out] = state;
        let l = self.lag.update(lagged, t_g, alpha[0]);
        self.smooth.update(out, l - t_amb, alpha[1])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DAY: f64 = 86_400.0;

    /// True temperature: a daily cycle of ±5 °C and a 3-hour one of ±1 °C around 20 °C.
    fn temperature(t: f64) -> f64 {
        20.0 + 5.0 * libm::sin(core::f64::consts::TAU * t / DAY)
            + libm::sin(core::f64::consts::TAU * t / (3.0 * 3600.0))
    }

    /// Slow interrogator drift the gratings carry: a ramp of 0.1 °C per day.
    const DRIFT_PER_S: f64 = 0.1 / DAY;

    fn drift(t: f64) -> f64 {
        DRIFT_PER_S * t
    }

    /// Run the observer over 14 days sampled every `dt` s. The thermometer is a first-order lag
    /// of T with time constant `lag`, integrated on its own 1-s grid (a continuous lag, not the
    /// observer's discretisation); the gratings imply T + drift. Returns the worst
    /// |output − expected| after `settle` s, where the expected output is the drift delayed
    /// by the two time constants (a ramp through two first-order lags lags by τl + τs).
    fn run(lag: f64, smooth: f64, dt: f64, settle: f64, bound: f64) -> f64 {
        let obs = DriftObserver::new(lag, smooth);
        let (lp_lag, lp_smooth) = obs.low_passes();
        assert_eq!(lp_lag.inv_tau(), 1.0 / lag);
        assert_eq!(lp_smooth.inv_tau(), 1.0 / smooth);
        let fine = LowPass::new(lag);
        let a_fine = fine.alpha(1.0);
        let mut thermometer = temperature(0.0);
        let mut state = [0.0; 2];
        DriftObserver::prime(&mut state, temperature(0.0) + drift(0.0), thermometer);
        assert_eq!(state, [temperature(0.0), 0.0]);
        let alpha = [lp_lag.alpha(dt), lp_smooth.alpha(dt)];
        let mut t = 0.0;
        let mut worst = 0.0f64;
        while t < 14.0 * DAY {
            for k in 1..=(dt as u32) {
                fine.update(&mut thermometer, temperature(t + f64::from(k)), a_fine);
            }
            t += dt;
            let o = obs.update(&mut state, temperature(t) + drift(t), thermometer, alpha);
            if t > settle {
                worst = worst.max((o - drift(t - lag - smooth)).abs());
            }
        }
        // At the end the drift (1.4 °C) is tracked, while T swings by ±6 °C.
        let ramp_lag = DRIFT_PER_S * (lag + smooth);
        assert!((state[1] - drift(t)).abs() < ramp_lag + bound, "{} vs {}", state[1], drift(t));
        worst
    }

    #[test]
    fn the_observer_follows_a_slow_drift_and_cancels_the_temperature() {
        // Compared after five times τl + τs, when the transients of the start have died out.
        // The residual is the temperature the thermometer's lag does not cancel exactly: the
        // observer holds each sample's value over the step before it, a lead of dt/2 on a
        // temperature changing by up to |dT/dt| = 2π·(5/1 day + 1/3 h) = 9.5e-4 °C/s, so at
        // most ≈ 9.5e-4·dt/2 °C before smoothing (0.028 °C at dt = 60 s), against a drift
        // that reaches 1.4 °C and a temperature that swings by ±6 °C.
        let max_rate = core::f64::consts::TAU * (5.0 / DAY + 1.0 / (3.0 * 3600.0));
        for (lag, smooth, dt) in [(600.0, 3600.0, 60.0), (600.0, 3600.0, 10.0), (300.0, 1800.0, 60.0)] {
            let bound = max_rate * dt / 2.0;
            let worst = run(lag, smooth, dt, 5.0 * (lag + smooth), bound);
            std::eprintln!(
                "drift observer τl {lag} s, τs {smooth} s, dt {dt} s: worst error {worst:.1e} °C (bound {bound:.1e})"
            );
            assert!(worst < bound, "{worst} >= {bound}");
        }
    }

    #[test]
    fn without_drift_the_observer_reads_the_thermometer_offset() {
        // A thermometer offset by +0.5 °C with no drift: the observer settles at −0.5 °C and
        // stays, and a constant temperature gives exactly that from the first sample.
        let obs = DriftObserver::new(600.0f64, 3600.0);
        let (a, b) = obs.low_passes();
        let mut state = [0.0; 2];
        DriftObserver::prime(&mut state, 20.0, 20.5);
        for k in 0..2000 {
            let dt = [1.0, 7.0, 60.0, 300.0][k % 4];
            let o = obs.update(&mut state, 20.0, 20.5, [a.alpha(dt), b.alpha(dt)]);
            assert_eq!(o, -0.5);
        }
    }
}
