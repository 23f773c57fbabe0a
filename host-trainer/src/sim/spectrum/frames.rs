//! From a simulated record's per-grating wavelengths to spectrum frames, one per channel and
//! sample.

use fbg_shared::spectrum::Window;

use super::detector::{DetectorModel, PixelGrid};
use super::grating::GratingDesign;
use super::profile::{ReflectionProfile, PROFILE_HALF_SPAN_NM, PROFILE_STEP_NM};
use super::SpectrumConfig;
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::rng::{Rng, Stream};

/// Gratings closer than this \[nm\] go on different channels (fibres): their spectra would
/// overlap within a search window.
pub const MIN_SPACING_NM: f64 = 3.0;

/// The largest half-width of a search window \[nm\].
pub const MAX_HALF_WINDOW_NM: f64 = 4.0;

/// A search window's half-width as a fraction of the gap to the nearest grating of its channel.
pub const WINDOW_PER_GAP: f64 = 0.45;

/// Renders the frames of one installation: each grating's tabulated reflection spectrum at its
/// wavelength of the sample, summed per channel, times the source envelope, through the
/// detector. Channel k (0-based; `channel` k + 1 in the CSV) holds the gratings assigned to it
/// ([`FrameSimulator::gratings_of`]): in order of nominal wavelength, each grating goes on the
/// first channel where it is at least [`MIN_SPACING_NM`] from every other (the `paper`
/// preset's three gratings, 10 nm apart, share one fibre).
#[derive(Clone, Debug)]
pub struct FrameSimulator {
    cfg: SpectrumConfig,
    nominal_nm: Vec<f64>,
    designs: Vec<GratingDesign>,
    profiles: Vec<ReflectionProfile>,
    channels: Vec<Vec<usize>>,
    wavelengths_nm: Vec<f64>,
    /// Counts per unit reflectivity at each pixel: `peak_counts`/R_peak·S(λ).
    gain: Vec<f64>,
}

impl FrameSimulator {
    /// The frames of gratings at nominal wavelengths `nominal_nm` (λ_ref, the record's zero).
    pub fn new(cfg: &SpectrumConfig, nominal_nm: &[f64]) -> Result<FrameSimulator, TrainerError> {
        let bad = |key: &str, message: String| TrainerError::Config {
            origin: "spectrum settings".into(),
            key: key.into(),
            message,
        };
        let d = &cfg.detector;
        if !DetectorModel::accepts_snr_db(d.snr_db) {
            return Err(bad("snr_db", format!("{}: a number of dB", d.snr_db)));
        }
        if !(d.peak_counts > 0.0 && d.peak_counts.is_finite() && d.dark_counts >= 0.0 && d.dark_counts.is_finite()) {
            return Err(bad("detector", format!("peak {} and dark {} counts: positive", d.peak_counts, d.dark_counts)));
        }
        let s = &cfg.source;
        if !(s.fwhm_nm > 0.0 && s.centre_nm.is_finite() && s.tilt_per_nm.is_finite()) {
            return Err(bad(
                "source",
                format!("centre {} nm, FWHM {} nm, tilt {}/nm", s.centre_nm, s.fwhm_nm, s.tilt_per_nm),
            ));
        }
        if let Some(nm) = nominal_nm.iter().find(|v| !v.is_finite()) {
            return Err(bad("nominal_nm", format!("{nm}: a wavelength in nm")));
        }
        let designs = nominal_nm
            .iter()
            .map(|&nm| GratingDesign::for_fwhm(cfg.apodisation, cfg.fwhm_nm, cfg.peak_reflectivity, nm))
            .collect::<Result<Vec<_>, _>>()?;
        let profiles = designs
            .iter()
            .zip(nominal_nm)
            .map(|(d, &nm)| ReflectionProfile::tabulate(d, nm, PROFILE_HALF_SPAN_NM, PROFILE_STEP_NM))
            .collect();
        let mut order: Vec<usize> = (0..nominal_nm.len()).collect();
        let at = |g: usize| nominal_nm.get(g).copied().unwrap_or(f64::NAN);
        order.sort_by(|&a, &b| at(a).total_cmp(&at(b)));
        let mut channels: Vec<Vec<usize>> = Vec::new();
        for g in order {
            let fits = |ch: &Vec<usize>| ch.iter().all(|&o| (at(o) - at(g)).abs() >= MIN_SPACING_NM);
            match channels.iter_mut().find(|ch| fits(ch)) {
                Some(ch) => ch.push(g),
                None => channels.push(vec![g]),
            }
        }
        let wavelengths_nm = cfg.grid.wavelengths();
        let scale = cfg.detector.peak_counts / cfg.peak_reflectivity;
        let gain = wavelengths_nm.iter().map(|&l| scale * cfg.source.power(l)).collect();
        Ok(FrameSimulator {
            cfg: *cfg,
            nominal_nm: nominal_nm.to_vec(),
            designs,
            profiles,
            channels,
            wavelengths_nm,
            gain,
        })
    }

    /// The settings.
    pub fn config(&self) -> &SpectrumConfig {
        &self.cfg
    }

    /// The pixel grid.
    pub fn grid(&self) -> PixelGrid {
        self.cfg.grid
    }

    /// The wavelength of every pixel \[nm\].
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// The gratings' nominal wavelengths \[nm\] (λ_ref), by grating.
    pub fn nominal_nm(&self) -> &[f64] {
        &self.nominal_nm
    }

    /// Each grating's design (in the record's grating order).
    pub fn designs(&self) -> &[GratingDesign] {
        &self.designs
    }

    /// Number of channels.
    pub fn channels(&self) -> usize {
        self.channels.len()
    }

    /// The gratings (indices into the record's) on channel `channel`, by wavelength.
    pub fn gratings_of(&self, channel: usize) -> &[usize] {
        self.channels.get(channel).map_or(&[], |c| c.as_slice())
    }

    /// The search window of grating `g`: its nominal wavelength ± [`WINDOW_PER_GAP`] of the
    /// gap to its nearest neighbour on the channel, at most ± [`MAX_HALF_WINDOW_NM`].
    pub fn window(&self, g: usize) -> Window<f64> {
        let centre = self.nominal_nm.get(g).copied().unwrap_or(f64::NAN);
        let gap = self
            .channels
            .iter()
            .find(|ch| ch.contains(&g))
            .into_iter()
            .flatten()
            .filter(|&&o| o != g)
            .filter_map(|&o| self.nominal_nm.get(o))
            .map(|&o| (o - centre).abs())
            .fold(f64::INFINITY, f64::min);
        Window::centred(centre, (WINDOW_PER_GAP * gap).min(MAX_HALF_WINDOW_NM))
    }

    /// The noise-free signal of `channel` \[counts above dark\] with the gratings at
    /// `wavelengths_nm` (one per grating of the record; a NaN one reflects nothing).
    pub fn signal(&self, channel: usize, wavelengths_nm: &[f64], out: &mut Vec<f64>) {
        out.clear();
        out.resize(self.wavelengths_nm.len(), 0.0);
        for &g in self.gratings_of(channel) {
            let (Some(&wl), Some(p)) = (wavelengths_nm.get(g), self.profiles.get(g)) else { continue };
            if !wl.is_finite() {
                continue;
            }
            let grid = self.cfg.grid.grid();
            let span = p.half_span_nm();
            let (a, b) = (grid.pixel(wl - span), grid.pixel(wl + span));
            let (lo, hi) = (a.min(b), a.max(b));
            let last = self.wavelengths_nm.len().saturating_sub(1) as f64;
            if !(hi >= 0.0 && lo <= last) {
                continue;
            }
            let (first, end) = (lo.max(0.0).floor() as usize, hi.min(last).ceil() as usize);
            for ((s, &l), &k) in
                out.iter_mut().zip(&self.wavelengths_nm).zip(&self.gain).skip(first).take(end + 1 - first)
            {
                *s += k * p.at(l - wl);
            }
        }
    }

    /// One frame of `channel`: [`FrameSimulator::signal`] through the detector
    /// ([`super::DetectorModel::expose`]).
    pub fn frame(
        &self,
        channel: usize,
        wavelengths_nm: &[f64],
        rng: &mut Rng,
        scratch: &mut Vec<f64>,
        out: &mut Vec<u16>,
    ) {
        self.signal(channel, wavelengths_nm, scratch);
        self.cfg.detector.expose(scratch, rng, out);
    }
}

/// The detector-noise stream of sample `row`: every frame of a row draws from its own seeded
/// stream, so frames can be made in any order (in parallel, or one row of a CSV at a time) and
/// come out the same.
pub fn row_rng(seed: u64, row: usize) -> Rng {
    Rng::new(seed ^ (row as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15), Stream::SpectrumNoise)
}

/// The absolute wavelength \[nm\] of every grating at `row` of `data`: the record's zero λ_ref
/// plus its shift, λ_ref + Δλ/1000 — the value the peaks record reports, so the two chains see
/// the same wavelengths.
pub fn wavelengths_at(data: &Dataset, row: usize) -> Vec<f64> {
    data.meta.zero.iter().zip(&data.dl_pm).map(|(z, dl)| dl.get(row).map_or(f64::NAN, |d| z.nm + d * 1e-3)).collect()
}
