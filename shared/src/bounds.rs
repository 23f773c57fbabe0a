//! The largest magnitude a fit can give each kind of number a blob carries: a model with a
//! number beyond its bound is refused by [`crate::ModelParams::validate`] (so by the decoder, the
//! encoder and every load), whatever its CRC or signature. The bounds follow from the units and
//! the scaling, generously: they let through anything a calibration can produce and stop the
//! values (up to 3.4e38 in f32) whose products overflow or whose estimates mean nothing.
//!
//! | bound | value | applies to |
//! |---|---|---|
//! | [`OUTPUT_MAX`] | 1e6 output units | guess means and deviations, output envelope, largest band |
//! | [`INPUT_MAX`] | 1e6 pm or °C | input envelope, shift and T_amb scalers, dead band, play widths, λ_ref tolerance |
//! | [`TIME_MAX`] | 1e10 s | time and latch scalers, end of calibration, time constants, largest lead |
//! | [`COEF_MAX`] | 1e9 | stage 1, polynomial core, Γ, centre weights, the observer's row |
//! | [`STANDARDISED_MAX`] | 1e6 | centre positions μ, σ and its multiplier |
//! | [`VARIANCE_MAX`] | 1e12 unit² (per s for the growth) | residual variance and its growth |
//! | [`INV_G_MAX`] | 1e12 | `var_inv_g` and its tail, α |
//! | [`EIGVEC_MAX`] | 1 + 1e-3 | the centres' variance components |
//! | [`FACTOR_MAX`] | 1e3 | band multipliers, the flagged-band factor, the envelope margin |
//! | [`UNIX_MAX_S`] | 1e11 s | the absolute end of calibration |
//! | ([`crate::FieldContext::validate`]) | 100–10 000 nm | a known λ_ref |
//!
//! And an output's index within its quantity is at most [`crate::layout::MAX_OUTPUTS`] (a model has no more
//! outputs than that, so `strain5_ue` cannot be one of them).

use crate::real::Real;

/// Largest |output value| (°C, µε, kPa): a million µε is 100 % strain, a million kPa a
/// gigapascal; no grating sees a million °C.
pub const OUTPUT_MAX: f64 = 1e6;
/// Largest |input| (Δλ in pm, T_amb in °C): a micrometre of shift is beyond any grating's
/// window.
pub const INPUT_MAX: f64 = 1e6;
/// Largest time \[s\] on the calibration clock or of a time constant (about 317 years).
pub const TIME_MAX: f64 = 1e10;
/// Largest |coefficient|: stage 1 (output units per pm or °C; FBG sensitivities are above
/// 1e-3 pm per unit, so a real inverse is below 1e3 per pm), the polynomial core and the
/// centre weights (output units per standardised unit: the calibration's output range, with
/// 1000 times [`OUTPUT_MAX`] for near-collinear guesses that cancel), Γ and the observer's
/// row (per pm or °C of a memory term).
pub const COEF_MAX: f64 = 1e9;
/// Largest standardised position or width (centres are calibration samples: a sample
/// |z| standard deviations from the mean needs more than z² samples).
pub const STANDARDISED_MAX: f64 = 1e6;
/// Largest residual variance (unit²) and its growth (unit² per s): [`OUTPUT_MAX`]².
pub const VARIANCE_MAX: f64 = 1e12;
/// Largest `1/g` of the variance's eigenvalues g ≥ α, and largest α (α is the relative
/// ridge times the calibration size; 1/g ≤ 1/α).
pub const INV_G_MAX: f64 = 1e12;
/// Largest |variance component|: components of unit eigenvectors, with room for rounding.
pub const EIGVEC_MAX: f64 = 1.0 + 1e-3;
/// Largest band multiplier (a 95 % quantile of |error|/s; 1.96 for Gaussian errors), flagged-band
/// factor and envelope margin (a fraction of the calibration range).
pub const FACTOR_MAX: f64 = 1e3;
/// Largest absolute end of calibration, Unix seconds (the year 5138).
pub const UNIX_MAX_S: f64 = 1e11;

/// Whether `v` is within ±`bound` (false for NaN and infinities). Always inlined: `bound` is
/// a constant, so an f32 device converts it at compile time, never with a soft-float call.
#[inline(always)]
pub(crate) fn within<F: Real>(v: F, bound: f64) -> bool {
    let b = F::from_f64(bound);
    v >= -b && v <= b
}
