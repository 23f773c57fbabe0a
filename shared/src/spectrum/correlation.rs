//! Cross-correlation with a reference peak shape.

use super::centroid::maximum;
use super::estimate::Estimate;
use super::gauss3::{vertex, FWHM_PER_SIGMA};
use super::num::{at, positive, real};
use super::region::Region;
use crate::real::Real;

/// Largest half-length of the reference \[pixels\]: the reference is sampled over
/// ±min(2·FWHM, 64) pixels, on the stack.
pub const MAX_REFERENCE_HALF: usize = 64;

/// Largest number of one-pixel moves from the maximum to the correlation's maximum.
const MAX_MOVES: usize = 3;

/// The cross-correlation estimate: the reference g(k) = e^(−k²/(2σᵣ²)), a Gaussian of FWHM
/// `reference_fwhm_px` = 2.3548·σᵣ sampled at integer offsets k over ±min(⌈2·FWHM⌉, 64),
/// correlated with the samples above the floor, C(j) = Σₖ y(j + k)·g(k) (the terms inside the
/// window), at integer shifts j from the maximum uphill to C's maximum; then a parabola through
/// ln C at that shift and its neighbours (the correlation of two Gaussians is a Gaussian, so
/// the log-parabola is exact for a Gaussian peak sampled densely enough). FWHM: from the
/// curvature, √(FWHM_C² − FWHM_ref²).
///
/// The correlation averages the whole peak, so it is the least sensitive to noise when the
/// reference matches the peak; a reference much narrower than the peak makes it the 3-point,
/// one much wider blurs neighbours in. Truncation at the window's edges biases a peak less
/// than two FWHM from an edge. Cost: 2·half + 1 ≤ 129 exponentials for the reference, then
/// (2·half + 1) multiply-adds per shift, at least 3 shifts (one more per move), 3 logarithms.
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
    match vertex(cm.ln(), c0.ln(), cp.ln()) {
        Some((delta, d, _)) => {
            let fwhm_c2 = R::from_f64(FWHM_PER_SIGMA * FWHM_PER_SIGMA) / -d;
            let w2 = fwhm_c2 - reference_fwhm_px * reference_fwhm_px;
            let fwhm_px = if w2 > R::ZERO { w2.sqrt() } else { R::NAN };
            Estimate { pixel: real::<R>(j) + delta, height: r.height(), fwhm_px }
        }
        None => maximum(r),
    }
}

/// ⌈2·FWHM⌉ clamped to 2..=[`MAX_REFERENCE_HALF`].
fn half_length<R: Real>(fwhm_px: R) -> usize {
    let two = fwhm_px + fwhm_px;
    let max = real::<R>(MAX_REFERENCE_HALF);
    if two >= max {
        MAX_REFERENCE_HALF
    } else {
        super::num::ceil_index(two).max(2)
    }
}
