//! A spectrum: intensities on a wavelength grid, borrowed.

use super::grid::Grid;
use crate::real::Real;

/// 10^(dB/10): a level in dB (dBm, or dB against any reference) as a linear intensity (mW, or
/// the reference's unit). Valid for |dB| < 340 (0 below, +∞ above).
///
/// ```
/// use fbg_shared::spectrum::from_db;
/// assert!((from_db(-30.0f64) - 1e-3).abs() < 1e-15);
/// assert!((from_db(3.0f32) - 1.995_262).abs() < 1e-5);
/// ```
pub fn from_db<R: Real>(db: R) -> R {
    super::num::exp(db * R::from_f64(core::f64::consts::LN_10 / 10.0))
}

/// Convert a whole frame of dB levels to linear intensities in place ([`from_db`]).
pub fn from_db_in_place<R: Real>(values: &mut [R]) {
    for v in values {
        *v = from_db(*v);
    }
}

/// One spectrum: linear intensities (any unit: counts, mW; never dB — see [`from_db`]) at the
/// pixels of a [`Grid`]. Borrowed: a frame buffer is read in place.
///
/// It may be a part of a frame ([`Spectrum::part`]): sample k is then at pixel
/// `first_pixel + k` of the grid, so that a device keeping only the pixels of its gratings'
/// windows finds the very peaks (bit for bit) the whole frame gives.
///
/// ```
/// use fbg_shared::spectrum::{Grid, Spectrum};
/// let s = [0.0f32, 1.0, 4.0, 1.0, 0.0];
/// let sp = Spectrum::new(&s, Grid::uniform(1550.0, 0.1));
/// assert_eq!(sp.len(), 5);
/// assert!((sp.grid().wavelength(2.0) - 1550.2).abs() < 1e-4);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Spectrum<'a, R> {
    samples: &'a [R],
    grid: Grid<R>,
    first_pixel: usize,
}

impl<'a, R: Real> Spectrum<'a, R> {
    /// The spectrum of `samples` (sample k at pixel k of `grid`).
    pub fn new(samples: &'a [R], grid: Grid<R>) -> Self {
        Spectrum { samples, grid, first_pixel: 0 }
    }
    /// A part of a frame: sample k at pixel `first_pixel + k` of `grid`.
    ///
    /// ```
    /// use fbg_shared::spectrum::{Grid, Spectrum, Window};
    /// let s = [0.0f32; 20];
    /// let part = Spectrum::part(&s[8..14], Grid::uniform(1500.0, 1.0), 8);
    /// let w = Window::new(1509.0, 1530.0);
    /// assert_eq!(w.span(&part).map(|s| (s.first, s.last)), Some((9, 13)));
    /// ```
    pub fn part(samples: &'a [R], grid: Grid<R>, first_pixel: usize) -> Self {
        Spectrum { samples, grid, first_pixel }
    }
    /// The grid pixel of the first sample (0 for a whole frame).
    pub fn first_pixel(&self) -> usize {
        self.first_pixel
    }
    /// The intensities.
    pub fn samples(&self) -> &'a [R] {
        self.samples
    }
    /// The grid.
    pub fn grid(&self) -> &Grid<R> {
        &self.grid
    }
    /// Number of pixels.
    pub fn len(&self) -> usize {
        self.samples.len()
    }
    /// True when there is no pixel.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }
}
