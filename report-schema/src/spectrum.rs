//! `fbg-trainer bench-spectrum`'s rows: the peak detector on simulated grating spectra, every
//! method × grid × SNR (the trainer's `sim::spectrum::accuracy` fills them, the bench tabulates
//! them).

use serde::{Deserialize, Serialize};

/// One method on one grid and grating: errors of the detected − rendered wavelength \[pm\].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct AccuracyRow {
    /// The method's name.
    pub method: String,
    /// The grid's name.
    pub grid: String,
    /// The gratings' apodisation (`uniform`, `gaussian`, `raised-cosine`).
    pub apodisation: String,
    /// Their peak reflectivity.
    pub peak_reflectivity: f64,
    /// Noise-free (no detector noise; the counts still round): max − min over the sweep of the
    /// error \[pm\] — the peak-locking.
    pub locking_pp_pm: f64,
    /// Noise-free mean error \[pm\] (the source's slope and the shape).
    pub bias_pm: f64,
    /// Per SNR \[dB\], the RMS error over every position and realisation \[pm\].
    pub rms_pm: Vec<(f64, f64)>,
}

impl AccuracyRow {
    /// The RMS error at `snr` dB (NaN when the row has none).
    pub fn rms_at(&self, snr: f64) -> f64 {
        self.rms_pm.iter().find(|(s, _)| (*s - snr).abs() < 1e-9).map_or(f64::NAN, |(_, v)| *v)
    }
}
