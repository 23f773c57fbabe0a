//! The detector side of a simulated interrogator: its pixel grid, its noise and its counts.

use fbg_shared::spectrum::Grid;

use crate::rng::Rng;

/// First wavelength of both grids \[nm\].
pub const GRID_START_NM: f64 = 1510.0;
/// Last wavelength of both grids \[nm\].
pub const GRID_END_NM: f64 = 1595.0;
/// Pixels of the spectrometer (an InGaAs array such as the I-MON 512's).
pub const SPECTROMETER_PIXELS: usize = 512;
/// The spectrometer's quadratic calibration term \[nm/pixel²\]: a slightly nonlinear
/// pixel-to-wavelength polynomial, as a grating spectrometer's is.
pub const SPECTROMETER_C2: f64 = -2e-5;
/// Step of the swept-laser grid \[nm\].
pub const SWEPT_STEP_NM: f64 = 0.008;

/// Which pixel grid the frames are sampled on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PixelGrid {
    /// 512 pixels over 1510–1595 nm, λ(p) = c₀ + c₁·p + c₂·p² with c₀ = 1510 nm,
    /// c₂ = [`SPECTROMETER_C2`] and c₁ such that λ(511) = 1595 nm (≈ 166 pm/pixel).
    #[default]
    Spectrometer,
    /// A swept laser sampled every 8 pm over 1510–1595 nm (10 626 points).
    Swept,
}

impl PixelGrid {
    /// Its name on the command line (`spectrometer`, `swept`).
    pub fn name(self) -> &'static str {
        match self {
            PixelGrid::Spectrometer => "spectrometer",
            PixelGrid::Swept => "swept",
        }
    }

    /// The grid of the name `s`.
    pub fn parse(s: &str) -> Option<PixelGrid> {
        match s {
            "spectrometer" => Some(PixelGrid::Spectrometer),
            "swept" => Some(PixelGrid::Swept),
            _ => None,
        }
    }

    /// λ(p) \[nm\].
    pub fn grid(self) -> Grid<f64> {
        match self {
            PixelGrid::Spectrometer => {
                let last = (SPECTROMETER_PIXELS - 1) as f64;
                let c1 = (GRID_END_NM - GRID_START_NM - SPECTROMETER_C2 * last * last) / last;
                Grid::polynomial([GRID_START_NM, c1, SPECTROMETER_C2, 0.0, 0.0, 0.0])
            }
            PixelGrid::Swept => Grid::uniform(GRID_START_NM, SWEPT_STEP_NM),
        }
    }

    /// Number of pixels.
    pub fn pixels(self) -> usize {
        match self {
            PixelGrid::Spectrometer => SPECTROMETER_PIXELS,
            PixelGrid::Swept => ((GRID_END_NM - GRID_START_NM) / SWEPT_STEP_NM).round() as usize + 1,
        }
    }

    /// The wavelength of every pixel \[nm\].
    pub fn wavelengths(self) -> Vec<f64> {
        let g = self.grid();
        (0..self.pixels()).map(|p| g.wavelength(p as f64)).collect()
    }
}

/// The detector's response: counts = dark + signal + white noise, rounded and clamped to u16.
///
/// SNR convention (the one of `fbg_shared::spectrum`, `Peak::snr_db`): SNR = 10·log₁₀(H/σ),
/// H a peak's height above the floor and σ the noise's standard deviation, both in counts. The
/// noise is set from the *reference* height `peak_counts` (a grating of the design's peak
/// reflectivity at the source's maximum): σ = `peak_counts`/10^(SNR/10). A grating on the
/// envelope's flank is lower, so its own SNR is lower by 10·log₁₀(1/S(λ_B)) (about 1.3 dB at
/// 15 nm from the centre of the default source). The noise is Gaussian and independent from
/// pixel to pixel (read noise); the rounding adds its 1/√12 count.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct DetectorModel {
    /// SNR \[dB\] of the reference height (see above).
    pub snr_db: f64,
    /// The reference peak height above the dark level \[counts\].
    pub peak_counts: f64,
    /// The dark level \[counts\].
    pub dark_counts: f64,
}

/// The detector's full scale \[counts\] (a 16-bit ADC).
pub use fbg_link::spectrum::FULL_SCALE_COUNTS;

impl Default for DetectorModel {
    /// 30 dB, a reference height of 40 000 counts on a dark level of 1 000.
    fn default() -> Self {
        DetectorModel { snr_db: 30.0, peak_counts: 40_000.0, dark_counts: 1_000.0 }
    }
}

impl DetectorModel {
    /// Whether `snr_db` is an SNR a detector may have: any finite number of dB (a negative one:
    /// noise above the peak), or +∞ for no noise.
    pub fn accepts_snr_db(snr_db: f64) -> bool {
        snr_db.is_finite() || snr_db == f64::INFINITY
    }

    /// σ \[counts\] = `peak_counts`/10^(SNR/10).
    pub fn sigma_counts(&self) -> f64 {
        self.peak_counts / 10f64.powf(self.snr_db / 10.0)
    }

    /// One frame: `signal` \[counts above dark\] per pixel → dark + signal + σ·N(0, 1), rounded
    /// to the nearest count and clamped to 0..=65 535 (a saturated pixel reads full scale).
    pub fn expose(&self, signal: &[f64], rng: &mut Rng, out: &mut Vec<u16>) {
        let sigma = self.sigma_counts();
        let noise = || if sigma > 0.0 { sigma * rng.normal() } else { 0.0 };
        fbg_link::spectrum::expose(signal.iter().copied(), self.dark_counts, noise, out);
    }
}
