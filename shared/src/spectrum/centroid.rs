//! The pixel maximum and the centroid above the threshold.

use super::estimate::Estimate;
use super::num::{at, real};
use super::region::Region;
use crate::real::Real;

/// The maximum's pixel: locks to the grid by construction (error uniform over ±½ pixel).
/// Cost: the region's scan only.
pub fn maximum<R: Real>(r: &Region<'_, R>) -> Estimate<R> {
    Estimate { pixel: real(r.imax), height: r.height(), fwhm_px: R::NAN }
}

/// The centroid of the run above the threshold, weighted by the excess over it:
/// p = Σᵢ (xᵢ − T)·i / Σᵢ (xᵢ − T), i over the contiguous run above T that holds the maximum
/// (the weights vanish at the threshold, so the result moves continuously as samples cross it).
/// Unbiased on a symmetric peak sampled densely; on a peak a few pixels wide it locks to the
/// grid, and an asymmetric peak pulls it towards its wider side. Cost: one multiply-add and
/// one add per sample of the run, one divide.
pub fn centroid<R: Real>(r: &Region<'_, R>) -> Estimate<R> {
    let (mut sw, mut swu) = (R::ZERO, R::ZERO);
    let mut u = real::<R>(r.lo) - real(r.imax);
    for i in r.lo..=r.hi {
        let w = at(r.samples, i) - r.level;
        sw += w;
        swu = w.mul_add(u, swu);
        u += R::ONE;
    }
    let pixel = if sw > R::ZERO { real::<R>(r.imax) + swu / sw } else { real(r.imax) };
    Estimate { pixel, height: r.height(), fwhm_px: R::NAN }
}
