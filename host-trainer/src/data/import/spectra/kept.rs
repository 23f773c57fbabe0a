//! What a detection keeps of each frame's peak: the whole [`Peak`] (the `peaks` command's
//! table) or only what the import reads ([`Found`]), so that a long file's frames cost the
//! import less memory.

use fbg_shared::spectrum::{Peak, PeakFlags};

/// A peak as kept: made from the detector's [`Peak`], read as a [`Found`]. Both `Peak<f64>`
/// and `Found` are, by the one impl below.
pub(crate) trait Kept: Copy + From<Peak<f64>> + Into<Found> {}

impl<T: Copy + From<Peak<f64>> + Into<Found>> Kept for T {}

/// What the import keeps of a peak: its wavelength, the height and width the plausibility
/// rule compares, the flags.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Found {
    /// Centre wavelength \[nm\] (NaN with no peak).
    pub wavelength_nm: f64,
    /// Height above the floor.
    pub amplitude: f64,
    /// FWHM \[nm\].
    pub fwhm_nm: f64,
    /// Quality flags.
    pub flags: PeakFlags,
}

impl From<Peak<f64>> for Found {
    fn from(p: Peak<f64>) -> Self {
        Found { wavelength_nm: p.wavelength_nm, amplitude: p.amplitude, fwhm_nm: p.fwhm_nm, flags: p.flags }
    }
}
