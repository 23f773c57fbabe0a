//! The wavelength of each pixel: a uniform grid or a pixel-to-wavelength polynomial.

use crate::real::Real;

/// Number of coefficients of a [`Grid::Polynomial`] (degree ≤ 5, as spectrometer calibrations
/// give them).
pub const POLY_COEFFS: usize = 6;

/// Newton steps of [`Grid::pixel`] on a polynomial grid (each at least squares the error of a
/// calibration that is close to linear).
const NEWTON_STEPS: usize = 6;

/// The wavelength grid of a spectrum: λ(p) in nm at pixel p (0 = the first sample; p may be
/// fractional, as the detector's sub-pixel positions are).
///
/// - `Uniform`: λ(p) = `start_nm` + `step_nm`·p (a swept laser or a resampled OSA trace);
/// - `Polynomial`: λ(p) = Σₖ cₖ·pᵏ, k = 0..=5 (a spectrometer's calibration, e.g. an I-MON's
///   five coefficients; unused ones are 0). It must be monotonic over the pixels used.
///
/// ```
/// use fbg_shared::spectrum::Grid;
/// let g = Grid::uniform(1510.0f64, 0.008);
/// assert!((g.wavelength(2.5) - 1510.02).abs() < 1e-12);
/// assert!((g.pixel(1510.02) - 2.5).abs() < 1e-9);
/// let p = Grid::polynomial([1510.0f64, 0.166, 1e-6, 0.0, 0.0, 0.0]);
/// assert!((p.pixel(p.wavelength(300.25)) - 300.25).abs() < 1e-9);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Grid<R> {
    /// λ(p) = `start_nm` + `step_nm`·p.
    Uniform {
        /// λ of pixel 0 \[nm\].
        start_nm: R,
        /// Spacing \[nm\] (non-zero).
        step_nm: R,
    },
    /// λ(p) = Σₖ `coefficients`\[k\]·pᵏ \[nm\].
    Polynomial {
        /// c₀ … c₅ \[nm/pixelᵏ\].
        coefficients: [R; POLY_COEFFS],
    },
}

impl<R: Real> Grid<R> {
    /// A uniform grid from `start_nm` in steps of `step_nm`.
    pub fn uniform(start_nm: R, step_nm: R) -> Self {
        Grid::Uniform { start_nm, step_nm }
    }

    /// A polynomial grid λ(p) = Σₖ cₖ·pᵏ.
    pub fn polynomial(coefficients: [R; POLY_COEFFS]) -> Self {
        Grid::Polynomial { coefficients }
    }

    /// λ(p) \[nm\] at a (fractional) pixel.
    pub fn wavelength(&self, pixel: R) -> R {
        match self {
            Grid::Uniform { start_nm, step_nm } => step_nm.mul_add(pixel, *start_nm),
            Grid::Polynomial { coefficients } => {
                coefficients.iter().rev().fold(R::ZERO, |acc, &c| acc.mul_add(pixel, c))
            }
        }
    }

    /// The local spacing dλ/dp \[nm/pixel\] at a pixel.
    pub fn step_at(&self, pixel: R) -> R {
        match self {
            Grid::Uniform { step_nm, .. } => *step_nm,
            Grid::Polynomial { coefficients } => {
                let mut acc = R::ZERO;
                let mut k = R::from_f64((POLY_COEFFS - 1) as f64);
                for &c in coefficients.iter().skip(1).rev() {
                    acc = acc.mul_add(pixel, k * c);
                    k -= R::ONE;
                }
                acc
            }
        }
    }

    /// The (fractional) pixel of `wavelength_nm`: exact on a uniform grid, Newton's method from
    /// the linear term's guess on a polynomial one. NaN when the grid's spacing is 0.
    pub fn pixel(&self, wavelength_nm: R) -> R {
        match self {
            Grid::Uniform { start_nm, step_nm } => (wavelength_nm - *start_nm) / *step_nm,
            Grid::Polynomial { coefficients } => {
                let [c0, c1, ..] = *coefficients;
                let mut p = (wavelength_nm - c0) / c1;
                for _ in 0..NEWTON_STEPS {
                    p -= (self.wavelength(p) - wavelength_nm) / self.step_at(p);
                }
                p
            }
        }
    }
}
