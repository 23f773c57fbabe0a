//! Spectrum files: a spectrometer's or a swept laser's frames, their peaks found per grating by
//! `fbg_shared::spectrum::PeakDetector`, so that `import` writes the dataset exactly as from a
//! peaks export and `peaks` writes each frame's peaks with their quality.
//!
//! - `spectra_csv.rs`: `t_s,channel,` and one column per wavelength (nm), linear or dB;
//! - `responses.rs`: an ENLIGHT / Hyperion Responses export (dB levels, the culture's decimal
//!   mark);
//! - `pixels.rs`: `t_s,channel,p0,p1,…` raw counts with the map's pixel-to-wavelength
//!   polynomial.
//!
//! The two CSV layouts share `wide_csv.rs`; every reader hands its spectra, converted to linear
//! intensities, to the detection of `detect.rs` (the hand-over is `frames.rs`; what it keeps of
//! each peak is `kept.rs`), which runs one detector per channel over the map's windows or,
//! without a map, over the windows `discover.rs` finds in each channel's first spectrum;
//! `settings.rs` turns the map's `[spectra]` table into the detector's settings;
//! `peak_table.rs` writes the `peaks` command's table.
//!
//! # Flagged frames in the dataset
//!
//! A frame whose peak is flagged keeps its wavelength or becomes a gap, by flag: `no-peak` is
//! always a gap (there is no wavelength); the faults `saturated` (a clipped top: the centre of
//! what is left is biased), `second-peak` (a neighbour in the window: the wrong peak may be
//! taken) and `at-edge` (the peak may lie outside the window) are gaps by default; `low-snr`,
//! `too-wide`, `too-narrow` and `asymmetric` keep the wavelength (usable, noisier or biased by
//! a shape the detector does not expect). The map's `[spectra] gap_on` changes the list. A peak
//! the grating cannot make (far above its usual height or far narrower than its usual width,
//! `plausible.rs`) is a fault named `implausible` and always a gap. The import summary counts
//! the flagged frames per grating and flag, and the gaps they made.

mod detect;
mod discover;
mod frames;
mod kept;
pub(crate) mod peak_table;
mod pixels;
mod plausible;
mod responses;
mod settings;
mod shape;
mod shape_table;
mod spectra_csv;
mod wide_csv;

use std::collections::BTreeMap;

use super::mapping::{Map, SpectraMap};
use super::problems::OnError;
use super::scale::Scale;
use super::summary::{FlaggedFrames, SpectraInfo};
use super::Format;
use crate::data::measurand::grating_column;
use crate::error::TrainerError;
pub(crate) use detect::ChannelDetector;
use detect::{Detected, Detection, GratingPeaks};
use frames::{describe_grid, FileFacts};
pub(crate) use kept::{Found, Kept};
use settings::Settings;
pub(crate) use shape_table::{refine, ShapeTable};

/// A spectrum file read and its peaks detected, each kept as `T` ([`Kept`]).
pub(crate) struct SpectraRead<T> {
    /// The frames and each grating's peaks.
    pub detected: Detected<T>,
    /// What the reader found.
    pub facts: FileFacts,
    /// Channels seen.
    pub channels: usize,
    /// The detector's settings and the gap rule.
    pub settings: Settings,
    /// The intensity scale and what decided it.
    pub scale: (Scale, String),
}

/// Read `input` in `format` (a spectrum format) and detect its peaks. `map` is `None` without
/// `--map`; `scale` is `--scale`.
pub(crate) fn read<T: Kept>(
    format: Format,
    input: &std::path::Path,
    map: Option<&Map>,
    origin: &str,
    scale: Option<Scale>,
    policy: OnError,
) -> Result<SpectraRead<T>, TrainerError> {
    let default_map = Map::default();
    let m = map.unwrap_or(&default_map);
    let scale = match (scale, m.spectra.scale, format) {
        (Some(s), _, _) => (s, "--scale".to_string()),
        (None, Some(s), _) => (s, format!("map key spectra.scale in {origin}")),
        (None, None, Format::EnlightResponses) => (Scale::Db, "Responses exports are in dB".to_string()),
        (None, None, _) => (Scale::Linear, "default (--scale db for a trace in dB)".to_string()),
    };
    let settings = Settings::of(&m.spectra, scale.0);
    // Responses give the channel by its line's place in the block, the tables by a column.
    let columns = match format {
        Format::EnlightResponses => ("1 (time)", "1 (channel line)"),
        _ => ("1 (t_s)", "2 (channel)"),
    };
    let mut detection = Detection::<T>::new(settings.config, &m.windows(), origin, columns)?;
    let (facts, channels) = match format {
        Format::SpectraCsv => wide_csv::read(input, scale.0, policy, &spectra_csv::grid_of, &mut detection)?,
        Format::Pixels => {
            let coefficients = pixel_polynomial(&m.spectra, origin, map.is_some())?;
            let grid_of = |c: &[&str]| pixels::grid_of(c, &coefficients);
            wide_csv::read(input, scale.0, policy, &grid_of, &mut detection)?
        }
        Format::EnlightResponses => responses::read(input, m, origin, scale.0, policy, &mut detection)?,
        Format::Enlight | Format::Csv => {
            return Err(TrainerError::Config {
                origin: "--format".into(),
                key: String::new(),
                message: "not a spectrum format (spectra-csv, enlight-responses, pixels)".into(),
            })
        }
    };
    let name = input.display().to_string();
    if detection.is_empty() {
        let why = if facts.problems.rows_read == 0 { "no spectra" } else { "every spectrum was skipped" };
        return Err(TrainerError::data(&name, facts.metadata_lines as u64 + 1, "-", why));
    }
    let detected = detection.finish(&name, origin, channels)?;
    Ok(SpectraRead { detected, facts, channels, settings, scale })
}

/// The map's pixel polynomial, required for `--format pixels`.
fn pixel_polynomial(s: &SpectraMap, origin: &str, have_map: bool) -> Result<Vec<f64>, TrainerError> {
    s.pixel_to_nm.clone().ok_or_else(|| TrainerError::Config {
        origin: if have_map { origin.to_string() } else { "--map".to_string() },
        key: "spectra.pixel_to_nm".into(),
        message: "--format pixels needs the spectrometer's pixel-to-wavelength polynomial: give a map with [spectra] pixel_to_nm = [c0, c1, …] (nm, c0 first)".into(),
    })
}

impl<T: Kept> SpectraRead<T> {
    /// A grating's peak method: the file's, with `+shape` where a measured shape refines it.
    pub(crate) fn method_of(&self, gp: &GratingPeaks<T>) -> String {
        let m = self.settings.config.method.name();
        if gp.shaped {
            format!("{m}+shape")
        } else {
            m.to_string()
        }
    }

    /// Each grating's wavelength per frame \[nm\] (NaN: a gap, by the gap rule) and the
    /// summary's facts, with the flagged frames counted.
    pub(crate) fn series(&self, format: Format) -> (Vec<Vec<f64>>, SpectraInfo) {
        let gap_on = self.settings.gap_on;
        let mut nm = Vec::with_capacity(self.detected.gratings.len());
        let mut flagged = Vec::with_capacity(self.detected.gratings.len());
        for (g, gp) in self.detected.gratings.iter().enumerate() {
            let mut f = FlaggedFrames {
                output: grating_column(g + 1),
                method: self.method_of(gp),
                frames: 0,
                flagged: 0,
                gaps: 0,
                by_flag: BTreeMap::new(),
            };
            let series: Vec<f64> = gp
                .peaks
                .iter()
                .zip(&gp.implausible)
                .map(|(p, &implausible)| {
                    let Some(p): Option<Found> = p.map(T::into) else { return f64::NAN };
                    f.frames += 1;
                    let flags = p.flags;
                    if !flags.is_ok() || implausible {
                        f.flagged += 1;
                        for (bit, name) in settings::flag_names() {
                            if flags.contains(bit) {
                                *f.by_flag.entry(name).or_insert(0) += 1;
                            }
                        }
                    }
                    if implausible {
                        *f.by_flag.entry(plausible::IMPLAUSIBLE.to_string()).or_insert(0) += 1;
                    }
                    if flags.0 & gap_on.0 != 0 || implausible || !p.wavelength_nm.is_finite() {
                        f.gaps += 1;
                        f64::NAN
                    } else {
                        p.wavelength_nm
                    }
                })
                .collect();
            nm.push(series);
            flagged.push(f);
        }
        let info = SpectraInfo {
            format,
            channels: self.channels,
            frames: self.detected.t.len(),
            points: self.facts.points,
            grid: describe_grid(&self.facts.grid, self.facts.points),
            scale: self.scale.0,
            scale_from: self.scale.1.clone(),
            method: self.settings.config.method.name().to_string(),
            culture: self.facts.culture.clone(),
            metadata_lines: self.facts.metadata_lines,
            windows_from: if self.detected.from_map {
                "map".to_string()
            } else {
                "the peaks of each channel's first spectrum (no map)".to_string()
            },
            gap_on: self.settings.gap_on_names(),
            flagged,
        };
        (nm, info)
    }
}
