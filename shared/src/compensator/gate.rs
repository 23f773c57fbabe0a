//! The gate of the memory state ([`crate::trust`]): which samples may move it.

use super::swing::SwingFilter;
use crate::layout::{head, MAX_ENVELOPE};
use crate::real::Real;
use crate::trust::{TrustSpec, GATE_RATE_FACTOR, GATE_SPAN_MARGIN};

/// The gate's limits, folded at load: the widened envelope and the largest step per second of
/// each envelope input (Δλ_1..N, then T_amb).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Gate<F> {
    lo: [F; MAX_ENVELOPE],
    hi: [F; MAX_ENVELOPE],
    /// `GATE_RATE_FACTOR` × the calibration's largest |Δx|/Δt [unit/s]; +∞ = no rate limit
    /// (a calibration rate of 0).
    rate: [F; MAX_ENVELOPE],
    /// Inputs checked (0: the gate is off, every sample passes).
    n: u8,
}

/// What the gate remembers of a stream: the last sample it let in, and the swing of the
/// samples it let in (read with [`super::StreamState::gate_state`], put back with
/// [`super::StreamState::resume_gate`], for a checkpoint that must resume bit for bit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GateState<F> {
    x: [F; MAX_ENVELOPE],
    t_s: F,
    primed: bool,
    swing: SwingFilter<F>,
}

impl<F: Real> GateState<F> {
    /// A gate that has let nothing in.
    pub const fn new() -> Self {
        GateState { x: [F::ZERO; MAX_ENVELOPE], t_s: F::ZERO, primed: false, swing: SwingFilter::new() }
    }

    /// The swing of the samples let in.
    #[inline(always)]
    pub(super) fn swing(&self) -> &SwingFilter<F> {
        &self.swing
    }
}

impl<F: Real> Gate<F> {
    /// A gate that lets every sample in.
    pub(super) const fn off() -> Self {
        Gate { lo: [F::ZERO; MAX_ENVELOPE], hi: [F::ZERO; MAX_ENVELOPE], rate: [F::ZERO; MAX_ENVELOPE], n: 0 }
    }

    /// The gate of a model whose calibration envelope is `env_lo..env_hi` (`n` inputs) and
    /// whose trust spec is `trust`.
    pub(super) fn new<G: Real>(
        env_lo: &[F; MAX_ENVELOPE],
        env_hi: &[F; MAX_ENVELOPE],
        n: usize,
        trust: &TrustSpec<G>,
    ) -> Self {
        let mut g = Gate::off();
        let margin = F::from_f64(GATE_SPAN_MARGIN);
        let factor = F::from_f64(GATE_RATE_FACTOR);
        for (k, (((lo, hi), rate), &r)) in
            g.lo.iter_mut().zip(g.hi.iter_mut()).zip(g.rate.iter_mut()).zip(trust.rate_max.iter()).enumerate().take(n)
        {
            let (l, h) = (env_lo.get(k).copied().unwrap_or(F::ZERO), env_hi.get(k).copied().unwrap_or(F::ZERO));
            let span = (h - l).max(F::ZERO);
            *lo = l - margin * span;
            *hi = h + margin * span;
            let r = factor * F::from_real(r);
            *rate = if r <= F::ZERO { F::INFINITY } else { r };
        }
        g.n = n as u8;
        g
    }

    /// Whether every sample passes without a look.
    #[inline(always)]
    pub(super) fn is_off(&self) -> bool {
        self.n == 0
    }

    /// Whether the sample with envelope inputs `x` at `t_s` may move the memory state, given
    /// the last sample let in. A non-finite `t_s` (a model that reads no time) or one not after
    /// the last sample let in skips the rate test.
    #[inline(always)]
    pub(super) fn admits(&self, last: &GateState<F>, x: &[F; MAX_ENVELOPE], t_s: F) -> bool {
        let n = usize::from(self.n);
        // A clock that stands still or steps back gives no rate to judge: the range alone
        // decides (a rate test against a negative Δt would lock the stream out).
        let dt = t_s - last.t_s;
        let timed = last.primed && dt.is_finite() && dt > F::ZERO;
        // Untimed: every step is within an infinite limit (Δx is finite: both samples are).
        let dt = if timed { dt } else { F::INFINITY };
        // |Δx| ≤ rate·Δt; a step that overflows to ±∞ fails it against a finite limit.
        head(x, n)
            .iter()
            .zip(self.lo.iter().zip(self.hi.iter()))
            .zip(self.rate.iter().zip(last.x.iter()))
            .all(|((&v, (&lo, &hi)), (&rate, &prev))| v >= lo && v <= hi && (v - prev).abs() <= rate * dt)
    }

    /// Remember the sample let in, and move the swing by it.
    #[inline(always)]
    pub(super) fn let_in(&self, last: &mut GateState<F>, x: &[F; MAX_ENVELOPE], t_s: F) {
        if self.n > 0 {
            last.swing.update(x, usize::from(self.n), t_s - last.t_s);
            last.x = *x;
            last.t_s = t_s;
            last.primed = true;
        }
    }
}
