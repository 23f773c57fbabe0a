//! Where Model-H's memory may be trusted (DESIGN §4, "honest outside the calibration"): the
//! conditions its calibration showed, carried in the blob.
//!
//! Two rules read these numbers on every step ([`crate::PreparedModel::step`]):
//!
//! - **The gate.** A sample enters the memory state (operators, latches) only if every input
//!   lies within the calibration envelope widened by [`GATE_SPAN_MARGIN`] of its span on each
//!   side, and has moved since the last accepted sample by at most [`GATE_RATE_FACTOR`] × the
//!   largest |Δx|/Δt of the calibration batch × the time since then. A refused sample is
//!   answered by Model-P's core with Model-P's band widened as a fault, flagged
//!   [`crate::Flags::OUT_OF_ENVELOPE`] and [`crate::Flags::FALLBACK`]; the state does not move, so
//!   a single glitch (a thermometer's 85 °C power-on value, a 1e300) leaves every later reading
//!   as it would have been, and the state stays within the widened envelope whatever arrives.
//!   The limit grows with the time since the last accepted sample, so a real step is accepted
//!   once enough time has passed (the rule cannot lock a stream out); a time stamp that does
//!   not advance leaves the range test alone to decide.
//! - **The fade.** The memory terms and the RBF residual (what Model-H adds to Model-P's core)
//!   were seen working only while the installation moved as in the calibration week. Each
//!   grating's quiet time q_g — the time since its narrowest play operator last reversed (the
//!   trainer puts that half-width above the grating's noise, so noise alone does not reverse
//!   it) — had a largest value `quiet_max_s[g]` there. Beyond it the added part fades
//!   linearly to nothing at twice that value (the smallest fade of any grating), and the band
//!   to Model-P's (`fallback_var`): at rest, or on a hold or a pace slower than any the
//!   calibration contained, Model-H answers as Model-P and says so with
//!   [`crate::Flags::FALLBACK`] (not a fault: Model-P's value and band are as good as ever).
//! - **The pace.** Every error that a first-order lag causes (a thermometer behind the air,
//!   a structure behind the thermometer) grows with the rate at which the inputs move, and
//!   what the calibration fitted of it holds for the rates it saw. Each envelope input's pace,
//!   the power of its swing over the last hours ([`crate::compensator::SwingFilter`]: a
//!   band-pass whose value for a ramp is proportional to its rate), had a largest value there,
//!   `swing_rms_max`²; so had the power Q of its speed (the rate of its fast low-pass, which
//!   keeps growing with the pace of an oscillation faster than the band-pass's corner, where
//!   the swing reads only the amplitude), `speed_rms_max`². Beyond either, with ρ = max over
//!   the inputs of √(P / P_max) and √(Q / Q_max): what Model-H
//!   adds to the core fades linearly to nothing at ρ = 2 (flagged
//!   [`crate::Flags::FALLBACK`], not a fault), and the band's variance is multiplied by ρ² —
//!   a lag error grows at most in proportion to the pace and noise does not grow, so the
//!   band's width in proportion to ρ bounds what the faster pace can add without a model of
//!   how much of the error was lag.
//! - **The slowest pace.** A pace slower than any the calibration showed is outside it too
//!   (the lag and memory terms were fitted on the rates it saw): each envelope input's swing
//!   power had a smallest value there once the filters had settled, `swing_rms_min`². With the
//!   slowness σ = max over the inputs of √(P_min / P), what Model-H adds fades linearly from
//!   σ = 1 to nothing at σ = 2 (flagged [`crate::Flags::FALLBACK`], not a fault); the band
//!   fades to Model-P's and is not widened (a slower pace adds no lag error). A stream that
//!   has just started has no pace yet (P grows from 0 over the window): it reads Model-P
//!   until its pace is known.
//! - **The band beyond the validated lead** is Model-H's own, growing with the lead as the
//!   drift's walk makes it grow; it does not decay towards Model-P's. The cross-validation saw
//!   leads up to the field context's largest validated lead only, but on the
//!   bench's simulated installations Model-H's error stays the same fraction of Model-P's on
//!   every day of the week after calibration (BENCHMARKS.md, band coverage by day): its
//!   advantage does not wear off with the lead, and a band that assumed it did was far wider
//!   than 95 % by the week's end.

use serde::{Deserialize, Serialize};

use crate::bounds::{self, within};
use crate::error::Error;
use crate::layout::{head, Dims, MAX_ENVELOPE, MAX_GRATINGS, MAX_OUTPUTS};
use crate::real::{cast_array, Real};

/// The gate's range: the calibration envelope widened by this fraction of its span on each
/// side.
pub const GATE_SPAN_MARGIN: f64 = 0.5;

/// The gate's rate limit: this many times the largest |Δx|/Δt of the calibration batch.
pub const GATE_RATE_FACTOR: f64 = 10.0;

/// The conditions in which Model-H's memory was seen to work, per model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrustSpec<F> {
    /// Largest |Δx|/Δt of each envelope input (Δλ_1..N \[pm/s\], then T_amb \[°C/s\]) between
    /// consecutive calibration samples; 0 = no rate limit on that input.
    pub rate_max: [F; MAX_ENVELOPE],
    /// Largest quiet time \[s\] of each grating over the calibration batch (see the module
    /// doc); 0 = no fade on that grating.
    pub quiet_max_s: [F; MAX_GRATINGS],
    /// Model-P's band variance per output at the end of calibration, k²·σ² \[unit²\]: the band
    /// Model-H fades to.
    pub fallback_var: [F; MAX_OUTPUTS],
    /// Its growth with the lead time, k²·dσ²/dt \[unit²/s\].
    pub fallback_var_growth: [F; MAX_OUTPUTS],
    /// Largest RMS swing of each envelope input over the calibration batch, √P_max (its unit;
    /// see [`crate::compensator::SwingFilter`]); 0 = that input does not set the pace.
    pub swing_rms_max: [F; MAX_ENVELOPE],
    /// Largest RMS speed of each envelope input over the calibration batch, √Q_max (its unit
    /// per second; see [`crate::compensator::SwingFilter`]); 0 = that input's speed does not
    /// set the pace.
    pub speed_rms_max: [F; MAX_ENVELOPE],
    /// Smallest RMS swing of each envelope input over the calibration batch once the pace
    /// filters had settled, √P_min (its unit; see [`crate::compensator::SwingFilter`]); 0 = no
    /// slow-pace test on that input.
    pub swing_rms_min: [F; MAX_ENVELOPE],
}

impl<F: Real> TrustSpec<F> {
    /// No gate rate limit, no fade, no fallback band: a model without memory (Model-P).
    pub const fn off() -> Self {
        TrustSpec {
            rate_max: [F::ZERO; MAX_ENVELOPE],
            quiet_max_s: [F::ZERO; MAX_GRATINGS],
            fallback_var: [F::ZERO; MAX_OUTPUTS],
            fallback_var_growth: [F::ZERO; MAX_OUTPUTS],
            swing_rms_max: [F::ZERO; MAX_ENVELOPE],
            speed_rms_max: [F::ZERO; MAX_ENVELOPE],
            swing_rms_min: [F::ZERO; MAX_ENVELOPE],
        }
    }

    /// Every number finite, ≥ 0 and within its field's bound; entries beyond the dims 0.
    pub fn validate(&self, dims: &Dims) -> Result<(), Error> {
        let bad = |field| Err(Error::BadParameter { field });
        let ok = |v: F, bound: f64| within(v, bound) && v >= F::ZERO;
        let (ne, m) = (dims.envelope_len(), dims.n_outputs());
        if !head(&self.rate_max, ne).iter().all(|&v| ok(v, bounds::INPUT_MAX)) {
            return bad("trust.rate_max");
        }
        if !head(&self.quiet_max_s, dims.gratings()).iter().all(|&v| ok(v, bounds::TIME_MAX)) {
            return bad("trust.quiet_max_s");
        }
        if !head(&self.fallback_var, m).iter().all(|&v| ok(v, bounds::VARIANCE_MAX)) {
            return bad("trust.fallback_var");
        }
        if !head(&self.fallback_var_growth, m).iter().all(|&v| ok(v, bounds::VARIANCE_MAX)) {
            return bad("trust.fallback_var_growth");
        }
        if !head(&self.swing_rms_max, ne).iter().all(|&v| ok(v, bounds::INPUT_MAX)) {
            return bad("trust.swing_rms_max");
        }
        if !head(&self.speed_rms_max, ne).iter().all(|&v| ok(v, bounds::INPUT_MAX)) {
            return bad("trust.speed_rms_max");
        }
        if !head(&self.swing_rms_min, ne).iter().all(|&v| ok(v, bounds::INPUT_MAX)) {
            return bad("trust.swing_rms_min");
        }
        Ok(())
    }

    /// The same numbers in another precision.
    pub fn convert<G: Real>(&self) -> TrustSpec<G> {
        TrustSpec {
            rate_max: cast_array(&self.rate_max),
            quiet_max_s: cast_array(&self.quiet_max_s),
            fallback_var: cast_array(&self.fallback_var),
            fallback_var_growth: cast_array(&self.fallback_var_growth),
            swing_rms_max: cast_array(&self.swing_rms_max),
            speed_rms_max: cast_array(&self.speed_rms_max),
            swing_rms_min: cast_array(&self.swing_rms_min),
        }
    }
}
