//! The Gaussian 3-point estimator: a parabola through the log of the top three samples.

use super::centroid::maximum;
use super::estimate::Estimate;
use super::num::{clamp, exp, positive, real};
use super::region::Region;
use crate::real::Real;

/// FWHM / σ of a Gaussian: 2·√(2 ln 2).
pub const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949;

/// Samples below this fraction of the height count as this fraction in the logs (a noisy
/// neighbour at or under the floor).
const LOG_FLOOR: f64 = 1e-6;

/// The vertex of the parabola through (−1, l₋), (0, l₀), (1, l₊): the offset
/// δ = (l₋ − l₊) / (2 (l₋ − 2 l₀ + l₊)), clamped to ±1, the curvature d = l₋ − 2 l₀ + l₊ (< 0)
/// and the vertex's excess over l₀, e = −(l₊ − l₋)²/(8 d) ≥ 0. `None` when the three points do
/// not make a maximum (d ≥ 0).
pub(crate) fn vertex<R: Real>(lm: R, l0: R, lp: R) -> Option<(R, R, R)> {
    let d = lm - (l0 + l0) + lp;
    if !positive(-d) {
        return None;
    }
    let delta = clamp((lm - lp) / (d + d), -R::ONE, R::ONE);
    let s = lp - lm;
    let e = -(s * s) / (R::from_f64(8.0) * d);
    Some((delta, d, e))
}

/// The Gaussian 3-point estimate at the maximum: with aₖ the samples above the floor at
/// imax − 1, imax, imax + 1 and lₖ = ln aₖ, the sub-pixel offset δ = (l₋ − l₊) /
/// (2 (l₋ − 2 l₀ + l₊)), σ² = −1/(l₋ − 2 l₀ + l₊) pixels², height a₀·e^(−(l₊ − l₋)²/(8 (l₋ −
/// 2 l₀ + l₊))).
///
/// Exact on a noise-free Gaussian on a flat floor at any sampling; biased on other shapes
/// (peak-locking) and noisy on a finely sampled peak, where the top three samples barely
/// differ. A maximum on the window's edge, or three samples that do not curve down, give the
/// pixel maximum. Cost: 3 logarithms, ≈ 15 operations and 1 exponential.
pub fn gaussian3<R: Real>(r: &Region<'_, R>) -> Estimate<R> {
    let i = r.imax;
    if i == 0 || i >= r.last() {
        return maximum(r);
    }
    let h = r.height();
    let eps = h * R::from_f64(LOG_FLOOR);
    let (am, a0, ap) = (r.above_floor(i - 1), r.above_floor(i), r.above_floor(i + 1));
    // Logs of ratios to the middle sample (l₀ = 0): near 0 on a fine grid, where the logs
    // themselves would agree to most of an f32's digits.
    let ln = |a: R| ((if a > eps { a } else { eps }) / a0).ln();
    match vertex(ln(am), R::ZERO, ln(ap)) {
        Some((delta, d, e)) if h > R::ZERO => Estimate {
            pixel: real::<R>(i) + delta,
            height: a0 * exp(e),
            fwhm_px: R::from_f64(FWHM_PER_SIGMA) / (-d).sqrt(),
        },
        _ => maximum(r),
    }
}
