//! The spectrum chain: frames → peaks → the same record as the peaks chain, shifts in pm from
//! each grating's λ_ref.

use fbg_shared::layout::MAX_GRATINGS;
use fbg_shared::spectrum::{DetectorConfig, Grid, Method, Spectrum, Template};
use rayon::prelude::*;

use super::detector::FULL_SCALE_COUNTS;
use super::frames::{row_rng, wavelengths_at, FrameSimulator};
use crate::data::import::spectra::{refine, ChannelDetector, ShapeTable};
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
    /// The method the peaks were found with (the template fit's first estimate where
    /// [`SpectrumChain::templated`]).
    pub method: Method,
    /// Whether each peak was refined by a fit of its grating's designed shape
    /// ([`fbg_shared::spectrum::template::template_fit`]).
    pub templated: bool,
}

/// How each grating's peak is found in its window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PeakFinding {
    /// A detector method alone.
    Method(Method),
    /// The method's estimate refined by a fit of the grating's designed reflection shape (the
    /// simulator's coupled-mode spectrum, as a calibration engineer would tabulate it from
    /// the grating's datasheet or a swept-laser scan: exact here, which a real one is not).
    DesignTemplate(Method),
}

impl PeakFinding {
    /// The detector method (the template fit's first estimate).
    pub fn method(self) -> Method {
        match self {
            PeakFinding::Method(m) | PeakFinding::DesignTemplate(m) => m,
        }
    }
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
    find_peaks(data, frames, PeakFinding::Method(method), seed)
}

/// [`peaks_from_spectra`] with the peak finding chosen ([`PeakFinding`]).
pub fn find_peaks(
    data: &Dataset,
    frames: &FrameSimulator,
    finding: PeakFinding,
    seed: u64,
) -> Result<SpectrumChain, TrainerError> {
    let method = finding.method();
    let n_g = data.n_gratings();
    if n_g > MAX_GRATINGS || n_g != data.meta.zero.len() {
        return Err(TrainerError::Dataset {
            message: format!("spectrum chain: {n_g} gratings and {} zeros (1 to {MAX_GRATINGS})", data.meta.zero.len()),
        });
    }
    let config = DetectorConfig { method, full_scale: FULL_SCALE_COUNTS, ..DetectorConfig::default() };
    let detectors: Vec<ChannelDetector<usize>> = (0..frames.channels())
        .map(|c| {
            let windows = frames.gratings_of(c).iter().map(|&g| (g, frames.window(g)));
            ChannelDetector::new(config, windows).ok_or_else(|| TrainerError::Dataset {
                message: format!("spectrum chain: too many gratings on channel {c}"),
            })
        })
        .collect::<Result<_, _>>()?;
    let tables: Vec<ShapeTable> = match finding {
        PeakFinding::Method(_) => Vec::new(),
        PeakFinding::DesignTemplate(_) => design_tables(frames),
    };
    let templates: Vec<Template<'_, f64>> = tables
        .iter()
        .map(|t| {
            t.template().ok_or_else(|| TrainerError::Dataset {
                message: "spectrum chain: a grating's template is not finite".into(),
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
                    let spectrum = Spectrum::new(samples, grid);
                    for (g, w, p) in det.detect(&spectrum) {
                        let wavelength_nm = match templates.get(g) {
                            Some(t) => refine(&spectrum, w, t, p.pixel).unwrap_or(f64::NAN),
                            None => p.wavelength_nm,
                        };
                        if let Some(slot) = out.get_mut(g) {
                            *slot = (wavelength_nm, p.flags.is_fault());
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
    Ok(SpectrumChain { data: d, errors_pm, faults, method, templated: !templates.is_empty() })
}

/// Each grating's designed shape, tabulated about its nominal wavelength.
pub(crate) fn design_tables(frames: &FrameSimulator) -> Vec<ShapeTable> {
    frames
        .designs()
        .iter()
        .zip(frames.nominal_nm())
        .map(|(d, &bragg)| {
            let r = d.spectrum(bragg);
            ShapeTable::from_fn(|x_nm| r(bragg + x_nm))
        })
        .collect()
}
