//! A grating's search window: the wavelength range its peak is looked for in.

use super::grid::Grid;
use super::num::{ceil_index, floor_index};
use super::view::Spectrum;
use crate::real::Real;

/// A search window \[nm\]: `lo_nm ≤ λ ≤ hi_nm`, like a map's peak window. Windows of different
/// gratings should not overlap: a neighbour's peak inside a window is flagged
/// ([`super::PeakFlags::SECOND_PEAK`]) and may be taken instead.
///
/// ```
/// use fbg_shared::spectrum::{Grid, Spectrum, Window};
/// let s = [0.0f64; 100];
/// let sp = Spectrum::new(&s, Grid::uniform(1500.0, 1.0));
/// let w = Window::centred(1550.0, 2.5);
/// assert_eq!(w.span(&sp).map(|s| (s.first, s.last)), Some((48, 52)));
/// assert!(Window::new(1700.0, 1710.0).span(&sp).is_none());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Window<R> {
    /// Lower bound \[nm\].
    pub lo_nm: R,
    /// Upper bound \[nm\].
    pub hi_nm: R,
}

/// The pixels of a spectrum inside a window: `first..=last`, at least three of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Span {
    /// First pixel inside.
    pub first: usize,
    /// Last pixel inside.
    pub last: usize,
}

impl<R: Real> Window<R> {
    /// The window `lo_nm..=hi_nm` (bounds in either order).
    pub fn new(lo_nm: R, hi_nm: R) -> Self {
        if hi_nm < lo_nm {
            Window { lo_nm: hi_nm, hi_nm: lo_nm }
        } else {
            Window { lo_nm, hi_nm }
        }
    }

    /// The window `centre_nm ± half_width_nm`.
    pub fn centred(centre_nm: R, half_width_nm: R) -> Self {
        Window::new(centre_nm - half_width_nm, centre_nm + half_width_nm)
    }

    /// The pixels of `spectrum` whose wavelength lies in the window (on a grid increasing or
    /// decreasing with the pixel), `None` when fewer than three do or a bound is not finite.
    /// Grid pixels: for a [`Spectrum::part`], within `first_pixel ..= first_pixel + len − 1`.
    pub fn span(&self, spectrum: &Spectrum<'_, R>) -> Option<Span> {
        self.span_of(spectrum.grid(), spectrum.first_pixel(), spectrum.len())
    }

    /// [`Window::span`] on `len` pixels of `grid` from `first_pixel` (no samples needed: a
    /// device sets its windows up before any frame arrives).
    pub fn span_of(&self, grid: &Grid<R>, first_pixel: usize, len: usize) -> Option<Span> {
        let last_px = first_pixel.checked_add(len.checked_sub(1)?)?;
        let (mut a, mut b) = (grid.pixel(self.lo_nm), grid.pixel(self.hi_nm));
        if b < a {
            core::mem::swap(&mut a, &mut b);
        }
        let limit = R::from_f64(f64::from(1u32 << 24));
        if !(a.is_finite() && b.is_finite()) || b < R::ZERO || a > limit {
            return None;
        }
        let first = ceil_index(a).max(first_pixel);
        let last = floor_index(if b > limit { limit } else { b })?.min(last_px);
        (last >= first.checked_add(2)?).then_some(Span { first, last })
    }
}
