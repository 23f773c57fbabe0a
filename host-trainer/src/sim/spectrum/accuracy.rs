//! The peak detector's accuracy on simulated grating spectra: every method × grid × SNR, with
//! the sub-pixel sweep that shows peak-locking (what `cargo xtask bench` tabulates).

use fbg_shared::spectrum::{DetectorConfig, Method, PeakDetector, Spectrum};

use super::chain::design_tables;
use super::detector::{DetectorModel, PixelGrid, FULL_SCALE_COUNTS};
use super::frames::{row_rng, FrameSimulator};
use super::grating::Apodisation;
use super::SpectrumConfig;
use crate::data::import::spectra::refine;
use crate::error::TrainerError;

/// The grating's Bragg wavelength in the sweep \[nm\] (the default source's centre: the SNR of
/// the frames is the stated one).
pub const SWEEP_BRAGG_NM: f64 = 1550.0;
/// Sub-pixel positions of the sweep over one pixel.
pub const SWEEP_STEPS: usize = 20;
/// Noise realisations per position.
pub const REALISATIONS: usize = 25;

pub use fbg_report::AccuracyRow;

/// The errors of every method in `methods` on `grid` for one grating of `apodisation` and
/// `peak_reflectivity` (0.3 nm FWHM) at [`SWEEP_BRAGG_NM`] swept over one pixel in
/// [`SWEEP_STEPS`] steps: noise-free, then [`REALISATIONS`] frames per position at each SNR of
/// `snrs_db` (detector noise seeded by `seed`; each frame is detected by every method).
///
/// With `template`, one more row: the default method's peak refined by a fit of the grating's
/// designed shape ([`super::PeakFinding::DesignTemplate`]).
pub fn accuracy_rows(
    grid: PixelGrid,
    apodisation: Apodisation,
    peak_reflectivity: f64,
    methods: &[Method],
    snrs_db: &[f64],
    seed: u64,
    template: bool,
) -> Result<Vec<AccuracyRow>, TrainerError> {
    let g = grid.grid();
    let p0 = g.pixel(SWEEP_BRAGG_NM).floor();
    let positions: Vec<f64> = (0..SWEEP_STEPS).map(|k| g.wavelength(p0 + k as f64 / SWEEP_STEPS as f64)).collect();
    let detectors: Vec<PeakDetector<f64, 1>> = methods
        .iter()
        .map(|&method| {
            let cfg = SpectrumConfig { grid, apodisation, peak_reflectivity, ..SpectrumConfig::default() };
            let f = FrameSimulator::new(&cfg, &[SWEEP_BRAGG_NM])?;
            let config = DetectorConfig { method, full_scale: FULL_SCALE_COUNTS, ..DetectorConfig::default() };
            PeakDetector::new(config, &[f.window(0)])
                .ok_or_else(|| TrainerError::Dataset { message: "accuracy: one window".into() })
        })
        .collect::<Result<_, _>>()?;
    // Errors [pm] per method of the frames at each position with `snr` (None: noise-free).
    let errors = |snr: Option<f64>| -> Result<Vec<Vec<Vec<f64>>>, TrainerError> {
        let detector = match snr {
            Some(s) => DetectorModel { snr_db: s, ..DetectorModel::default() },
            None => DetectorModel { snr_db: f64::INFINITY, ..DetectorModel::default() },
        };
        let cfg = SpectrumConfig { grid, apodisation, peak_reflectivity, detector, ..SpectrumConfig::default() };
        let f = FrameSimulator::new(&cfg, &[SWEEP_BRAGG_NM])?;
        let reps = if snr.is_some() { REALISATIONS } else { 1 };
        let tables = if template { design_tables(&f) } else { Vec::new() };
        let fit = tables.first().and_then(|t| t.template());
        let default_det = PeakDetector::<f64, 1>::new(
            DetectorConfig { full_scale: FULL_SCALE_COUNTS, ..DetectorConfig::default() },
            &[f.window(0)],
        )
        .ok_or_else(|| TrainerError::Dataset { message: "accuracy: one window".into() })?;
        let mut out = vec![vec![Vec::with_capacity(reps); positions.len()]; methods.len() + usize::from(template)];
        let (mut scratch, mut counts, mut samples) = (Vec::new(), Vec::new(), Vec::new());
        for (k, &wl) in positions.iter().enumerate() {
            for r in 0..reps {
                let mut rng = row_rng(seed, k * REALISATIONS + r);
                f.frame(0, &[wl], &mut rng, &mut scratch, &mut counts);
                samples.clear();
                samples.extend(counts.iter().map(|&c| f64::from(c)));
                for (m, det) in detectors.iter().enumerate() {
                    let [p] = det.detect(&Spectrum::new(&samples, g));
                    let e = p.map_or(f64::NAN, |p| (p.wavelength_nm - wl) * 1e3);
                    if let Some(v) = out.get_mut(m).and_then(|o| o.get_mut(k)) {
                        v.push(e);
                    }
                }
                if let Some(t) = &fit {
                    let spectrum = Spectrum::new(&samples, g);
                    let [p] = default_det.detect(&spectrum);
                    let e = p
                        .and_then(|p| refine(&spectrum, &f.window(0), t, p.pixel))
                        .map_or(f64::NAN, |w| (w - wl) * 1e3);
                    if let Some(v) = out.get_mut(methods.len()).and_then(|o| o.get_mut(k)) {
                        v.push(e);
                    }
                }
            }
        }
        Ok(out)
    };
    let clean = errors(None)?;
    let noisy: Vec<(f64, Vec<Vec<Vec<f64>>>)> =
        snrs_db.iter().map(|&s| errors(Some(s)).map(|e| (s, e))).collect::<Result<_, _>>()?;
    let mut names: Vec<String> = methods.iter().map(|m| m.name().to_string()).collect();
    if template {
        names.push(format!("{} + design template", Method::default().name()));
    }
    Ok(names
        .iter()
        .enumerate()
        .map(|(m, name)| {
            let c: Vec<f64> = clean.get(m).into_iter().flatten().flatten().copied().collect();
            let (lo, hi) = c.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &e| (a.min(e), b.max(e)));
            let rms_pm = noisy
                .iter()
                .map(|(s, e)| (*s, crate::stats::rms(e.get(m).into_iter().flatten().flatten().copied())))
                .collect();
            AccuracyRow {
                method: name.clone(),
                grid: grid.name().into(),
                apodisation: apodisation.name().into(),
                peak_reflectivity,
                locking_pp_pm: hi - lo,
                bias_pm: c.iter().sum::<f64>() / c.len().max(1) as f64,
                rms_pm,
            }
        })
        .collect())
}
