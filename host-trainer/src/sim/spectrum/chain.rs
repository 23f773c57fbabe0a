//! The spectrum chain: frames → peaks → the same record as the peaks chain, shifts in pm from
//! each grating's λ_ref.

use fbg_shared::layout::MAX_GRATINGS;
use fbg_shared::spectrum::{DetectorConfig, Grid, Method, PeakDetector, Spectrum};
use rayon::prelude::*;

use super::detector::FULL_SCALE_COUNTS;
use super::frames::{row_rng, wavelengths_at, FrameSimulator};
use crate::data::Dataset;
use crate::error::TrainerError;

/// What the spectrum chain made of a record.
#[derive(Clone, Debug)]
pub struct SpectrumChain {
    /// The record with each grating's shift replaced by the detected one, (λ_det − λ_ref)·1000
    /// \[pm\] (NaN where the window held no peak).
    pub data: Dataset,
    /// Per grating and row, the detected wavelength minus the one the frame was rendered at
    /// \[pm\].
    pub errors_pm: Vec<Vec<f64>>,
    /// Per grating, the rows whose peak raised a fault flag (`PeakFlags::FAULTS`).
    pub faults: Vec<usize>,
    /// The method the peaks were found with.
    pub method: Method,
}

impl SpectrumChain {
    /// RMS of [`SpectrumChain::errors_pm`] per grating \[pm\] over its finite entries.
    pub fn rms_error_pm(&self) -> Vec<f64> {
        self.errors_pm.iter().map(|e| crate::stats::rms(e.iter().copied().filter(|v| v.is_finite()))).collect()
    }
}

/// Render every row's frames of `data` with `frames` (noise seeded by `seed`), find each
/// grating's peak in its window with `method` (one `PeakDetector` per channel, reused for
/// every frame) and rebuild the record from the peaks.
pub fn peaks_from_spectra(
    data: &Dataset,
    frames: &FrameSimulator,
    method: Method,
    seed: u64,
) -> Result<SpectrumChain, TrainerError> {
    let n_g = data.n_gratings();
    if n_g > MAX_GRATINGS || n_g != data.meta.zero.len() {
        return Err(TrainerError::Dataset {
            message: format!("spectrum chain: {n_g} gratings and {} zeros (1 to {MAX_GRATINGS})", data.meta.zero.len()),
        });
    }
    let config = DetectorConfig { method, full_scale: FULL_SCALE_COUNTS, ..DetectorConfig::default() };
    let detectors: Vec<PeakDetector<f64, MAX_GRATINGS>> = (0..frames.channels())
        .map(|c| {
            let windows: Vec<_> = frames.gratings_of(c).iter().map(|&g| frames.window(g)).collect();
            PeakDetector::new(config, &windows).ok_or_else(|| TrainerError::Dataset {
                message: format!("spectrum chain: too many gratings on channel {c}"),
            })
        })
        .collect::<Result<_, _>>()?;
    let grid: Grid<f64> = frames.grid().grid();
    let rows: Vec<Vec<(f64, bool)>> = (0..data.len())
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new(), Vec::new()),
            |(scratch, counts, samples): &mut (Vec<f64>, Vec<u16>, Vec<f64>), i| {
                let wl = wavelengths_at(data, i);
                let mut rng = row_rng(seed, i);
                let mut out = vec![(f64::NAN, true); n_g];
                for (c, det) in detectors.iter().enumerate() {
                    frames.frame(c, &wl, &mut rng, scratch, counts);
                    samples.clear();
                    samples.extend(counts.iter().map(|&v| f64::from(v)));
                    let peaks = det.detect(&Spectrum::new(samples, grid));
                    for (&g, p) in frames.gratings_of(c).iter().zip(peaks.iter().flatten()) {
                        if let Some(slot) = out.get_mut(g) {
                            *slot = (p.wavelength_nm, p.flags.is_fault());
                        }
                    }
                }
                out
            },
        )
        .collect();
    let mut d = data.clone();
    let mut errors_pm = vec![Vec::with_capacity(data.len()); n_g];
    let mut faults = vec![0; n_g];
    for (i, row) in rows.iter().enumerate() {
        let wl = wavelengths_at(data, i);
        for (g, &(det, fault)) in row.iter().enumerate() {
            let zero = data.meta.zero.get(g).map_or(f64::NAN, |z| z.nm);
            if let Some(v) = d.dl_pm.get_mut(g).and_then(|c| c.get_mut(i)) {
                *v = (det - zero) * 1e3;
            }
            if let Some(e) = errors_pm.get_mut(g) {
                e.push((det - wl.get(g).copied().unwrap_or(f64::NAN)) * 1e3);
            }
            if let Some(f) = faults.get_mut(g) {
                *f += usize::from(fault);
            }
        }
    }
    Ok(SpectrumChain { data: d, errors_pm, faults, method })
}
