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
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DriftObserver<F> {
    lag: LowPass<F>,
    smooth: LowPass<F>,
}

impl<F: Real> DriftObserver<F> {
    /// An observer with the thermometer's lag `lag_s` [s] and smoothing `smooth_s` [s].
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
