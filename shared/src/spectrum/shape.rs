//! A peak's shape around its centre: half-widths at half maximum, and whether another peak
//! shares the window.

use super::num::real;
use super::region::{run, Region};
use crate::real::Real;

/// Noise σ a second peak must clear above its level (so noise on the main peak's flank, where
/// it crosses the level, is not taken for a neighbour).
const SECOND_PEAK_SIGMAS: f64 = 3.0;

/// The half-widths of a peak at half its height, left and right of its centre \[pixels\].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfWidths<R> {
    /// centre − the left crossing.
    pub left: R,
    /// The right crossing − centre.
    pub right: R,
}

impl<R: Real> HalfWidths<R> {
    /// The half-maximum crossings of `r`'s samples either side of its maximum for a peak of
    /// `height` above the floor, each interpolated between the two samples that bracket it,
    /// linearly in the log of the samples above the floor (exact for a Gaussian's flank between
    /// two samples to second order), linearly where the lower one is not above the floor; a
    /// flank that stays above half to the window's edge crosses at the edge. Cost: a walk over
    /// the samples above half, 5 logarithms.
    pub fn of(r: &Region<'_, R>, centre: R, height: R) -> Self {
        let half = R::from_f64(0.5) * height;
        let ln_half = half.ln();
        let mut i = r.imax;
        while i > 0 && r.above_floor(i - 1) > half {
            i -= 1;
        }
        let left_x = if i == 0 {
            R::ZERO
        } else {
            real::<R>(i - 1) + crossing(r.above_floor(i - 1), r.above_floor(i), half, ln_half)
        };
        let mut j = r.imax;
        while j < r.last() && r.above_floor(j + 1) > half {
            j += 1;
        }
        let right_x = if j >= r.last() {
            real(j)
        } else {
            real::<R>(j + 1) - crossing(r.above_floor(j + 1), r.above_floor(j), half, ln_half)
        };
        HalfWidths { left: centre - left_x, right: right_x - centre }
    }

    /// The full width at half maximum \[pixels\].
    pub fn fwhm(&self) -> R {
        self.left + self.right
    }

    /// The larger half-width over the smaller (∞ when one is not positive).
    pub fn asymmetry(&self) -> R {
        let (a, b) = if self.left > self.right { (self.left, self.right) } else { (self.right, self.left) };
        if b > R::ZERO {
            a / b
        } else {
            R::INFINITY
        }
    }
}

/// Where between a sample `lo` (≤ `level`) and its neighbour `hi` (> `level`) the level is
/// crossed, as the fraction of the pixel from `lo`'s side.
/// `ln_level` is `level.ln()`, taken once for both crossings.
fn crossing<R: Real>(lo: R, hi: R, level: R, ln_level: R) -> R {
    let t = if lo > R::ZERO { (ln_level - lo.ln()) / (hi.ln() - lo.ln()) } else { (level - lo) / (hi - lo) };
    super::num::clamp(t, R::ZERO, R::ONE)
}

/// True when samples of `r` apart from the main peak (outside the contiguous run above
/// floor + `fraction`·`height` that holds the maximum) rise above that level by more than
/// three noise σ. Cost: one compare per sample.
pub fn second_peak<R: Real>(r: &Region<'_, R>, height: R, fraction: R) -> bool {
    let level = fraction.mul_add(height, r.noise.floor);
    let (lo, hi) = run(r.samples, r.imax, level);
    let bar = R::from_f64(SECOND_PEAK_SIGMAS).mul_add(r.noise.sigma, level);
    let before = r.samples.get(..lo).unwrap_or_default();
    let after = r.samples.get(hi.saturating_add(1)..).unwrap_or_default();
    before.iter().chain(after).any(|&v| v > bar)
}
