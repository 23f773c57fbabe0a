//! Small numeric helpers of the spectrum code: index ↔ real conversions without f64 on an f32
//! device, absolute value, bounded reads.

use crate::real::Real;

/// `i` as a real, exact below 2²⁴ (any spectrum's pixel index); through f32, so an f32 build
/// links no double-precision conversion.
#[inline(always)]
pub(crate) fn real<R: Real>(i: usize) -> R {
    R::from_real(i as f32)
}

/// |x|.
#[inline(always)]
pub(crate) fn abs<R: Real>(x: R) -> R {
    if x < R::ZERO {
        -x
    } else {
        x
    }
}

/// The sample at `i`, NaN past the end (callers stay inside; NaN keeps a mistake visible).
#[inline(always)]
pub(crate) fn at<R: Real>(s: &[R], i: usize) -> R {
    s.get(i).copied().unwrap_or(R::NAN)
}

/// `x` clamped to `[lo, hi]` (NaN gives `lo`).
#[inline(always)]
pub(crate) fn clamp<R: Real>(x: R, lo: R, hi: R) -> R {
    if x > hi {
        hi
    } else if x >= lo {
        x
    } else {
        lo
    }
}

/// `e^x` for `x` of either sign, from [`Real::exp_neg`] (`1/e^(−x)` above 0).
#[inline(always)]
pub(crate) fn exp<R: Real>(x: R) -> R {
    if x > R::ZERO {
        R::ONE / x.exp_neg()
    } else {
        (-x).exp_neg()
    }
}

/// The smallest integer `>= x` as an index, for finite `x` in `0..2³¹` (below 0 gives 0).
#[inline(always)]
pub(crate) fn ceil_index<R: Real>(x: R) -> usize {
    let r = x.round_to_i32_scaled(1.0);
    let r = if real_i32::<R>(r) < x { r.saturating_add(1) } else { r };
    usize::try_from(r).unwrap_or(0)
}

/// The largest integer `<= x` as an index, for finite `x` in `0..2³¹`; `None` below 0.
#[inline(always)]
pub(crate) fn floor_index<R: Real>(x: R) -> Option<usize> {
    let r = x.round_to_i32_scaled(1.0);
    let r = if real_i32::<R>(r) > x { r.saturating_sub(1) } else { r };
    usize::try_from(r).ok()
}

#[inline(always)]
fn real_i32<R: Real>(i: i32) -> R {
    R::from_real(i as f32)
}

/// `x > 0` (false for NaN): negated, it is the NaN-catching `!(x > 0)`.
#[inline(always)]
pub(crate) fn positive<R: Real>(x: R) -> bool {
    x > R::ZERO
}
