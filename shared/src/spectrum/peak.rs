//! One grating's detected peak.

use super::flags::PeakFlags;
use crate::real::Real;

/// A detected peak: where, how high, how wide, how clean.
///
/// SNR is the peak's height above the floor over the noise σ, both in the spectrum's linear
/// intensity unit; [`Peak::snr_db`] gives it as 10·log₁₀ (the optical-power convention: the
/// samples are powers).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Peak<R> {
    /// Centre wavelength \[nm\] (NaN with [`PeakFlags::NO_PEAK`]).
    pub wavelength_nm: R,
    /// Centre as a fractional pixel index of the spectrum (NaN with no peak).
    pub pixel: R,
    /// Height above the floor (the fitted one for the fitting methods), in the spectrum's unit.
    pub amplitude: R,
    /// The window's noise floor, in the spectrum's unit.
    pub floor: R,
    /// Full width at half maximum \[nm\]: the fit's for the Gaussian least squares and the
    /// correlation, the interpolated half-maximum crossings' for the others.
    pub fwhm_nm: R,
    /// Height over noise σ, linear (∞ on a noise-free window).
    pub snr: R,
    /// Quality flags.
    pub flags: PeakFlags,
}

impl<R: Real> Peak<R> {
    /// The result of a window without a peak: NaN wavelength, `flags` (with
    /// [`PeakFlags::NO_PEAK`]), the floor and SNR where known.
    pub fn none(floor: R, snr: R, flags: PeakFlags) -> Self {
        Peak {
            wavelength_nm: R::NAN,
            pixel: R::NAN,
            amplitude: R::NAN,
            floor,
            fwhm_nm: R::NAN,
            snr,
            flags: flags.union(PeakFlags::NO_PEAK),
        }
    }

    /// The SNR in dB, 10·log₁₀(height/σ).
    pub fn snr_db(&self) -> R {
        R::from_f64(10.0 / core::f64::consts::LN_10) * self.snr.ln()
    }
}
