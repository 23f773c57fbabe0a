//! Cross-correlation with a reference peak shape.

use super::centroid::maximum;
use super::estimate::Estimate;
use super::gauss3::{vertex, FWHM_PER_SIGMA};
use super::num::{at, exp, positive, real};
use super::region::Region;
use crate::real::Real;

/// Largest half-length of the reference \[pixels\]: the reference is sampled over
/// ±min(⌈1.5·FWHM⌉, 128) pixels (±3.5 σ), on the stack.
pub const MAX_REFERENCE_HALF: usize = 128;

/// The reference's half-length over its FWHM (±3.5 σ: the tails left out weigh 5·10⁻⁴).
const HALF_PER_FWHM: f64 = 1.5;

/// √(2π).
const SQRT_TAU: f64 = 2.506_628_274_631_000_5;

/// Largest number of one-pixel moves from the maximum to the correlation's maximum.
const MAX_MOVES: usize = 16;

/// The cross-correlation estimate: the reference g(k) = e^(−k²/(2σᵣ²)), a Gaussian of FWHM
/// `reference_fwhm_px` = 2.3548·σᵣ sampled at integer offsets k over ±h, h = min(⌈1.5·FWHM⌉,
/// 128) (at least 2),
/// correlated with the samples above the floor, C(j) = Σₖ y(j + k)·g(k) (the terms inside the
/// window), at integer shifts j from the maximum uphill to C's maximum; then a parabola through
/// ln C at that shift and its neighbours (the correlation of two Gaussians is a Gaussian, so
/// the log-parabola is exact for a Gaussian peak sampled densely enough). FWHM: from the
/// curvature, √(FWHM_C² − FWHM_ref²); height: the Gaussian's whose correlation peaks at C's
/// vertex, A = C·σ_C/(√(2π)·σ·σᵣ) (not the maximum sample, which noise lifts).
///
/// The correlation averages the whole peak, so it is the least sensitive to noise when the
/// reference matches the peak; a reference much narrower than the peak makes it the 3-point,
/// one wider averages the pixel grid out (less peak-locking on a coarse grid) but blurs
/// neighbours in. Truncation at the window's edges biases a peak less than h pixels from an
/// edge. Cost: h + 1 ≤ 129 exponentials for the reference, then 2h + 1 multiply-adds per
/// shift, at least 3 shifts (one more per move, at most 16 moves), 3 logarithms.
pub fn cross_correlation<R: Real>(r: &Region<'_, R>, reference_fwhm_px: R) -> Estimate<R> {
    let last = r.last();
    if !positive(reference_fwhm_px) || r.imax == 0 || r.imax >= last {
        return maximum(r);
    }
    let half = half_length(reference_fwhm_px);
    let sr = reference_fwhm_px / R::from_f64(FWHM_PER_SIGMA);
    let c = R::from_f64(0.5) / (sr * sr);
    let mut reference = [R::ZERO; MAX_REFERENCE_HALF + 1];
    let mut k = R::ZERO;
    for g in reference.iter_mut().take(half + 1) {
        *g = (c * k * k).exp_neg();
        k += R::ONE;
    }
    let corr = |j: usize| -> R {
        let from = j.saturating_sub(half);
        let to = j.saturating_add(half).min(last);
        let mut s = R::ZERO;
        for i in from..=to {
            s = r.above_floor(i).mul_add(at(&reference, i.abs_diff(j)), s);
        }
        s
    };
    let mut j = r.imax;
    let (mut cm, mut c0, mut cp) = (corr(j - 1), corr(j), corr(j + 1));
    for _ in 0..MAX_MOVES {
        if cp > c0 && j + 1 < last {
            j += 1;
            (cm, c0, cp) = (c0, cp, corr(j + 1));
        } else if cm > c0 && j > 1 {
            j -= 1;
            (cm, c0, cp) = (corr(j - 1), cm, c0);
        } else {
            break;
        }
    }
    if !(cm > R::ZERO && cp > R::ZERO && c0 > R::ZERO) {
        return maximum(r);
    }
    // Logs of ratios to the middle value: near 0 on a fine grid, where the logs themselves
    // would agree to most of an f32's digits.
    match vertex((cm / c0).ln(), R::ZERO, (cp / c0).ln()) {
        Some((delta, d, e)) => {
            // σ_C² = −1/d = σ² + σᵣ² (pixels²).
            let var_c = -R::ONE / d;
            let var = var_c - sr * sr;
            let (fwhm_px, height) = if var > R::ZERO {
                // C's maximum is A·√(2π)·σ·σᵣ/σ_C for a Gaussian of height A (the sum over
                // pixels taken as the integral).
                let sigma = var.sqrt();
                let a = c0 * exp(e) * var_c.sqrt() / (R::from_f64(SQRT_TAU) * sigma * sr);
                (R::from_f64(FWHM_PER_SIGMA) * sigma, a)
            } else {
                (R::NAN, r.height())
            };
            Estimate { pixel: real::<R>(j) + delta, height, fwhm_px }
        }
        None => maximum(r),
    }
}

/// ⌈1.5·FWHM⌉ clamped to 2..=[`MAX_REFERENCE_HALF`].
fn half_length<R: Real>(fwhm_px: R) -> usize {
    let h = R::from_f64(HALF_PER_FWHM) * fwhm_px;
    if h >= real::<R>(MAX_REFERENCE_HALF) {
        MAX_REFERENCE_HALF
    } else {
        super::num::ceil_index(h).max(2)
    }
}
