//! The broadband source's envelope: what a SLED puts into the fibre, per wavelength.

/// A superluminescent diode's spectrum, relative to its maximum: a Gaussian with a linear tilt,
///
/// S(λ) = exp(−4 ln2·(λ − λ_c)²/w²)·(1 + t·(λ − λ_c)), clamped at 0,
///
/// λ_c the centre \[nm\], w the FWHM \[nm\], t the tilt \[1/nm\]. A grating away from λ_c sits on
/// a slope of d ln S/dλ = −8 ln2·(λ − λ_c)/w² + t, which pulls a centroid or a symmetric fit
/// towards the brighter side by about σ²·(d ln S/dλ) (σ the peak's Gaussian width): the bias
/// the detector's λ_ref absorbs, and which changes with λ_B as the slope does.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SourceEnvelope {
    /// Centre wavelength λ_c \[nm\].
    pub centre_nm: f64,
    /// FWHM w \[nm\].
    pub fwhm_nm: f64,
    /// Linear tilt t \[1/nm\].
    pub tilt_per_nm: f64,
}

impl Default for SourceEnvelope {
    /// A C-band SLED: centre 1550 nm, FWHM 50 nm, tilted by 0.4 %/nm.
    fn default() -> Self {
        SourceEnvelope { centre_nm: 1550.0, fwhm_nm: 50.0, tilt_per_nm: 0.004 }
    }
}

impl SourceEnvelope {
    /// S(λ), relative (1 at λ_c).
    pub fn power(&self, lambda_nm: f64) -> f64 {
        let x = lambda_nm - self.centre_nm;
        let g = (-4.0 * std::f64::consts::LN_2 * x * x / (self.fwhm_nm * self.fwhm_nm)).exp();
        (g * (1.0 + self.tilt_per_nm * x)).max(0.0)
    }
}
