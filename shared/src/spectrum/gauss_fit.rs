//! The least-squares Gaussian: a weighted log-parabola, refined by Gauss–Newton.

use super::estimate::Estimate;
use super::gauss3::{gaussian3, FWHM_PER_SIGMA};
use super::num::{abs, exp, positive, real};
use super::region::Region;
use crate::real::Real;

/// Gauss–Newton iterations at most (fewer when the centre moves by less than 10⁻⁴ pixel).
pub const FIT_ITERATIONS: usize = 5;

/// A centre step below this many pixels ends the iterations.
const CONVERGED_PX: f64 = 1e-4;

/// Samples at least this far either side of the maximum enter the fit, however few are above
/// the threshold (a peak two pixels wide still gets five samples).
const MIN_HALF_SPAN: usize = 2;

/// The Gaussian least-squares estimate: the model y = A·e^(−(p − μ)²/(2σ²)) over the samples
/// above the floor (the floor held), over the run above the threshold widened to imax ± 2.
///
/// 1. Start: the weighted log-parabola (Caruana's): ln y = a + b·x + c·x² by least squares
///    with weights y² (the inverse variance of ln y under white noise), μ = −b/(2c),
///    σ² = −1/(2c); [`gaussian3`] when that fails.
/// 2. Refine: Gauss–Newton on y itself (unweighted: white noise), at most
///    [`FIT_ITERATIONS`] steps, stopping when the centre moves by less than 10⁻⁴ pixel.
///
/// Coordinates are scaled (by the run's half-length, then by the start's σ), so the 3 × 3
/// normal equations are well conditioned in f32. A step that is not finite, makes σ² ≤ 0 or
/// leaves the fitted span keeps the previous estimate.
///
/// Unbiased on a Gaussian (white noise, flat floor); on sinc² and asymmetric peaks its bias
/// follows the samples' weight above the threshold. Cost: per sample one logarithm and 6
/// multiply-adds (start), then per iteration and sample one exponential and ≈ 14
/// multiply-adds; per solve ≈ 30 operations and one divide.
pub fn gaussian_fit<R: Real>(r: &Region<'_, R>) -> Estimate<R> {
    let lo = r.lo.min(r.imax.saturating_sub(MIN_HALF_SPAN));
    let hi = r.hi.max(r.imax.saturating_add(MIN_HALF_SPAN)).min(r.last());
    let start = log_parabola(r, lo, hi).unwrap_or_else(|| gaussian3(r));
    if !positive(start.fwhm_px) || !start.fwhm_px.is_finite() {
        return start;
    }
    gauss_newton(r, lo, hi, start)
}

/// Caruana's weighted log-parabola over `lo..=hi` (samples above the floor only).
fn log_parabola<R: Real>(r: &Region<'_, R>, lo: usize, hi: usize) -> Option<Estimate<R>> {
    let sc = real::<R>(hi - lo) * R::from_f64(0.5);
    let sc = if sc > R::ONE { sc } else { R::ONE };
    let inv = R::ONE / sc;
    let mut n = [R::ZERO; 6];
    let mut b = [R::ZERO; 3];
    let mut x = (real::<R>(lo) - real(r.imax)) * inv;
    for i in lo..=hi {
        let y = r.above_floor(i);
        if y > R::ZERO {
            let yx = y * x;
            accumulate(&mut n, &mut b, [y, yx, yx * x], y * y.ln());
        }
        x += inv;
    }
    let [a, b, c] = solve(n, b)?;
    if !positive(-c) {
        return None;
    }
    let xm = -b / (c + c);
    let pixel = xm.mul_add(sc, real(r.imax));
    if !(pixel >= real(lo) && pixel <= real(hi)) {
        return None;
    }
    let sigma = (-R::ONE / (c + c)).sqrt() * sc;
    Some(Estimate {
        pixel,
        height: exp(a - b * b / (R::from_f64(4.0) * c)),
        fwhm_px: R::from_f64(FWHM_PER_SIGMA) * sigma,
    })
}

/// Gauss–Newton on y = A·e^(−q·(x − m)²/2), x = (p − p₀)/σ₀ from `start`'s p₀ and σ₀.
fn gauss_newton<R: Real>(r: &Region<'_, R>, lo: usize, hi: usize, start: Estimate<R>) -> Estimate<R> {
    let s0 = start.fwhm_px / R::from_f64(FWHM_PER_SIGMA);
    let inv_s0 = R::ONE / s0;
    let x_lo = (real::<R>(lo) - start.pixel) * inv_s0;
    let x_hi = (real::<R>(hi) - start.pixel) * inv_s0;
    let half = R::from_f64(0.5);
    let (mut amp, mut m, mut q) = (start.height, R::ZERO, R::ONE);
    for _ in 0..FIT_ITERATIONS {
        let mut n = [R::ZERO; 6];
        let mut b = [R::ZERO; 3];
        let mut x = x_lo;
        for i in lo..=hi {
            let d = x - m;
            let g = (half * q * d * d).exp_neg();
            let f = amp * g;
            accumulate(&mut n, &mut b, [g, f * q * d, -half * f * d * d], r.above_floor(i) - f);
            x += inv_s0;
        }
        let Some([da, dm, dq]) = solve(n, b) else { break };
        let (a1, m1, q1) = (amp + da, m + dm, q + dq);
        if !(q1 > R::ZERO && a1.is_finite() && m1 >= x_lo && m1 <= x_hi) {
            break;
        }
        (amp, m, q) = (a1, m1, q1);
        if abs(dm) * s0 < R::from_f64(CONVERGED_PX) {
            break;
        }
    }
    Estimate { pixel: m.mul_add(s0, start.pixel), height: amp, fwhm_px: start.fwhm_px / q.sqrt() }
}

/// Add one row `j` with residual `res` to the normal equations (upper triangle of JᵀJ as
/// n = [00, 01, 02, 11, 12, 22], and Jᵀr).
#[inline(always)]
fn accumulate<R: Real>(n: &mut [R; 6], b: &mut [R; 3], j: [R; 3], res: R) {
    let [j0, j1, j2] = j;
    let [n00, n01, n02, n11, n12, n22] = n;
    *n00 = j0.mul_add(j0, *n00);
    *n01 = j0.mul_add(j1, *n01);
    *n02 = j0.mul_add(j2, *n02);
    *n11 = j1.mul_add(j1, *n11);
    *n12 = j1.mul_add(j2, *n12);
    *n22 = j2.mul_add(j2, *n22);
    let [b0, b1, b2] = b;
    *b0 = j0.mul_add(res, *b0);
    *b1 = j1.mul_add(res, *b1);
    *b2 = j2.mul_add(res, *b2);
}

/// The solution of the symmetric 3 × 3 system (Cramer's rule with the adjugate), `None` when
/// its determinant is not positive and finite.
fn solve<R: Real>(n: [R; 6], b: [R; 3]) -> Option<[R; 3]> {
    let [a00, a01, a02, a11, a12, a22] = n;
    let c00 = a11 * a22 - a12 * a12;
    let c01 = a02 * a12 - a01 * a22;
    let c02 = a01 * a12 - a02 * a11;
    let det = a00 * c00 + a01 * c01 + a02 * c02;
    if !(det > R::ZERO && det.is_finite()) {
        return None;
    }
    let c11 = a00 * a22 - a02 * a02;
    let c12 = a01 * a02 - a00 * a12;
    let c22 = a00 * a11 - a01 * a01;
    let [b0, b1, b2] = b;
    let inv = R::ONE / det;
    Some([
        (c00 * b0 + c01 * b1 + c02 * b2) * inv,
        (c01 * b0 + c11 * b1 + c12 * b2) * inv,
        (c02 * b0 + c12 * b1 + c22 * b2) * inv,
    ])
}
