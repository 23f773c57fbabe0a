//! A fit of the grating's own reflection shape (a tabulated template) to the window.

use super::estimate::Estimate;
use super::grid::Grid;
use super::num::{abs, floor_index, positive, real};
use super::region::Region;
use crate::real::Real;

/// Golden-section steps of [`template_fit`]: the bracket of ±1 pixel shrinks by 0.618 per step,
/// to 2·0.618⁴⁸ ≈ 2·10⁻¹⁰ pixel, below f64's resolution of a wavelength and far below f32's.
const GOLDEN_STEPS: usize = 48;

/// 1/φ = (√5 − 1)/2.
const INV_PHI: f64 = 0.618_033_988_749_894_8;

/// A grating's reflection shape R(x) tabulated at offsets x \[nm\] from its centre (x = 0 is the
/// wavelength the fit reports): `values[k]` at x = `first_offset_nm` + k·`step_nm`, read by
/// linear interpolation, 0 outside the table. Borrowed: a table in flash or on the host's heap
/// is read in place.
///
/// It must be the grating's own shape, from outside the record: a swept-laser scan of the
/// grating or its design (coupled-mode theory, as the simulator computes it). A shape a few
/// percent too wide, or of another reflectivity, locks to the grid as much as a Gaussian
/// (`shared/tests/spectrum_template.rs`). Nor can the record teach it: frames superimposed at
/// their first estimates give the true shape warped by those estimates' own locking error,
/// periodic in the sub-pixel phase, and that warped shape fits the frames with the same error
/// (any such error is self-consistent). A table step well under the pixel spacing (a few pm
/// for a 0.3 nm grating) keeps the interpolation's error far under the noise.
///
/// ```
/// use fbg_shared::spectrum::Template;
/// let t = Template::new(&[0.0f64, 1.0, 0.0], -0.1, 0.1).unwrap();
/// assert!((t.at(0.05) - 0.5).abs() < 1e-12);
/// assert_eq!(t.at(0.2), 0.0);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Template<'a, R> {
    values: &'a [R],
    first_offset_nm: R,
    step_nm: R,
}

impl<'a, R: Real> Template<'a, R> {
    /// The table; `None` when it has fewer than 2 values, a value that is not finite, or a
    /// step that is not positive and finite.
    pub fn new(values: &'a [R], first_offset_nm: R, step_nm: R) -> Option<Self> {
        let ok = values.len() >= 2
            && values.iter().all(|v| v.is_finite())
            && first_offset_nm.is_finite()
            && positive(step_nm)
            && step_nm.is_finite();
        ok.then_some(Template { values, first_offset_nm, step_nm })
    }

    /// R(x) at offset `x_nm` from the centre (0 outside the table and for NaN).
    pub fn at(&self, x_nm: R) -> R {
        let u = (x_nm - self.first_offset_nm) / self.step_nm;
        if !u.is_finite() || u < R::ZERO {
            return R::ZERO;
        }
        let Some(k) = floor_index(u) else { return R::ZERO };
        let f = u - real::<R>(k);
        match (self.values.get(k), self.values.get(k + 1)) {
            (Some(&a), Some(&b)) => f.mul_add(b - a, a),
            (Some(&a), None) if f == R::ZERO => a,
            _ => R::ZERO,
        }
    }

    /// The table's largest value.
    pub fn max(&self) -> R {
        self.values.iter().fold(R::ZERO, |m, &v| if v > m { v } else { m })
    }
}

/// The template fit: the centre λ_c \[nm\] that best explains the window's samples yᵢ at
/// wavelengths λᵢ as yᵢ ≈ a·R(λᵢ − λ_c) + b (height a > 0 and floor b by linear least squares
/// at each λ_c), i.e. the maximum of the normalised correlation
/// S(λ_c) = (Σ (tᵢ − t̄)(yᵢ − ȳ))² / Σ (tᵢ − t̄)², tᵢ = R(λᵢ − λ_c), over λ_c within ±1 pixel
/// of `start_pixel` (a first estimate in the window's pixels, e.g. the cross-correlation's), by
/// golden-section search.
///
/// With the grating's true shape this is the least-squares estimate of the centre: no
/// peak-locking however coarsely the peak is sampled (a 0.3 nm grating covers two pixels of a
/// 512-pixel spectrometer), where every method built on a Gaussian locks to the grid by as much
/// as the shape differs from one. What remains are the template's own errors (a different
/// shape, the source's slope across the peak) and the noise. `grid` and `first_pixel` place
/// the window's samples (sample i at pixel `first_pixel` + i of `grid`). Cost per step of the
/// search: one interpolation and 4 multiply-adds per sample of the window; 48 steps.
///
/// Returns `None` when the start is not finite or no λ_c in the bracket correlates positively.
pub fn template_fit<R: Real>(
    r: &Region<'_, R>,
    grid: &Grid<R>,
    first_pixel: usize,
    template: &Template<'_, R>,
    start_pixel: R,
) -> Option<Estimate<R>> {
    let n = r.samples.len();
    if n < 3 || !start_pixel.is_finite() {
        return None;
    }
    let first = real::<R>(first_pixel);
    let nr = real::<R>(n);
    let mean_y = r.samples.iter().fold(R::ZERO, |s, &y| s + y) / nr;
    // (S, a, b) at a centre.
    let score = |centre_nm: R| -> (R, R, R) {
        let (mut st, mut stt, mut sty) = (R::ZERO, R::ZERO, R::ZERO);
        for (i, &y) in r.samples.iter().enumerate() {
            let t = template.at(grid.wavelength(first + real(i)) - centre_nm);
            st += t;
            stt = t.mul_add(t, stt);
            sty = t.mul_add(y - mean_y, sty);
        }
        let var = stt - st * st / nr;
        if !positive(var) || !positive(sty) {
            return (R::ZERO, R::ZERO, mean_y);
        }
        let a = sty / var;
        (sty * a, a, mean_y - a * st / nr)
    };
    let lo_px = first + start_pixel - R::ONE;
    let hi_px = first + start_pixel + R::ONE;
    let (mut lo, mut hi) = (grid.wavelength(lo_px), grid.wavelength(hi_px));
    if hi < lo {
        (lo, hi) = (hi, lo);
    }
    let g = R::from_f64(INV_PHI);
    let mut x1 = hi - g * (hi - lo);
    let mut x2 = lo + g * (hi - lo);
    let (mut f1, mut f2) = (score(x1).0, score(x2).0);
    for _ in 0..GOLDEN_STEPS {
        if f1 >= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = score(x1).0;
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = score(x2).0;
        }
    }
    let centre = (lo + hi) * R::from_f64(0.5);
    let (s, a, _) = score(centre);
    if !positive(s) {
        return None;
    }
    let pixel = grid.pixel(centre) - first;
    // A centre pinned to the bracket's edge: the start was more than a pixel off.
    let edge = abs(pixel - start_pixel) > R::from_f64(0.999);
    (pixel.is_finite() && !edge).then(|| Estimate { pixel, height: a * template.max(), fwhm_px: R::NAN })
}
