//! Simulated spectra: each grating's reflection spectrum from coupled-mode
//! theory, on a broadband source, through a detector, on a pixel grid — from the same record as
//! the peaks, so the chain spectrum → peaks → compensation runs with the truth known.
//!
//! One concept per file:
//!
//! - [`grating`]: the reflection spectrum of a uniform or apodised grating (closed form and
//!   transfer matrix), and a design of given FWHM and peak reflectivity;
//! - [`profile`]: that spectrum tabulated once and shifted to each sample's wavelength;
//! - [`source`]: the SLED's envelope;
//! - [`detector`]: the pixel grids (a 512-pixel spectrometer with its pixel polynomial, an 8 pm
//!   swept laser) and the detector (noise at an SNR, counts in u16);
//! - [`frames`]: a record's wavelengths → one frame per channel and sample;
//! - [`accuracy`]: the detector's methods on these spectra, swept over a pixel, per SNR;
//! - [`chain`]: frames → peaks (`fbg_shared::spectrum::PeakDetector`) → the record again;
//! - [`csv`]: the frames as the spectra CSV.
//!
//! SNR is 10·log₁₀(peak height/noise σ), the convention of `fbg_shared::spectrum`
//! ([`detector::DetectorModel`] says which height). Nothing here changes the peaks simulator: a
//! record simulated with or without spectra is the same record.

pub mod accuracy;
pub mod chain;
pub mod csv;
pub mod detector;
pub mod frames;
pub mod grating;
pub mod profile;
pub mod source;

pub use chain::{find_peaks, peaks_from_spectra, PeakFinding, SpectrumChain};
pub use detector::{DetectorModel, PixelGrid};
pub use frames::FrameSimulator;
pub use grating::{Apodisation, GratingDesign};
pub use source::SourceEnvelope;

/// How the spectra of a record are simulated.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpectrumConfig {
    /// The pixel grid (default the 512-pixel spectrometer).
    pub grid: PixelGrid,
    /// The detector (default 30 dB SNR).
    pub detector: DetectorModel,
    /// The source (default a C-band SLED).
    pub source: SourceEnvelope,
    /// The gratings' apodisation (default uniform, with its side lobes).
    pub apodisation: Apodisation,
    /// The gratings' main-lobe FWHM \[nm\] (default 0.3).
    pub fwhm_nm: f64,
    /// The gratings' peak reflectivity (default 0.5).
    pub peak_reflectivity: f64,
}

impl Default for SpectrumConfig {
    fn default() -> Self {
        SpectrumConfig {
            grid: PixelGrid::default(),
            detector: DetectorModel::default(),
            source: SourceEnvelope::default(),
            apodisation: Apodisation::default(),
            fwhm_nm: grating::DEFAULT_FWHM_NM,
            peak_reflectivity: grating::DEFAULT_PEAK_REFLECTIVITY,
        }
    }
}
