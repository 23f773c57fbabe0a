//! What a method gives before the detector turns it into a [`super::Peak`].

/// A method's answer in the window's pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate<R> {
    /// Centre, as a fractional pixel index local to the window.
    pub pixel: R,
    /// Peak height above the floor (the fitted one where the method fits a shape).
    pub height: R,
    /// FWHM in pixels where the method measures one (the Gaussian fits, the correlation), NaN
    /// where it does not (the detector then takes the half-maximum crossings').
    pub fwhm_px: R,
}
