//! The import map (TOML): which column or peak is what, in which unit.
//!
//! One map format serves both importers. The top-level keys describe a CSV file (the logger
//! file of `--format csv`, or the `--refs` file of `--format enlight`): `[time]`, `[ambient]`,
//! `[temperature]`, `[strain]`, `[pressure]` (the measurands `T_C`, `strain_ue`, `p_kPa`),
//! `[[measurand]]` (any measurand by its column name, e.g. `strain2_ue`), `delimiter`,
//! `header_lines`. `[[grating]]` (one to eight of them, for dl1..dlN) says where each
//! grating's wavelength is: a `column` and `unit` for a CSV, a `channel` and `window_nm` for
//! ENLIGHT and the spectrum formats. `[enlight]` holds the peaks file's own
//! settings, `[spectra]` the spectrum formats' (pixel polynomial, scale, the detector's),
//! `max_gap_s` the join of references onto peak times. See README.md, "Real data:
//! import and field recalibration".

use std::path::Path;

use serde::Deserialize;

use super::scale::Scale;
use super::time_axis::TimeUnit;
use crate::data::measurand::{Measurand, MAX_GRATINGS, MAX_MEASURANDS};
use crate::data::timestamp::parse_timestamp;
use crate::data::units::{WlUnit, NM_RANGE};
use crate::error::{line_col, TrainerError};

/// The whole map file.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Map {
    /// CSV delimiter: `","`, `";"`, `"\t"` (or `"tab"`), `"|"`. Default: detected on the
    /// header line.
    pub delimiter: Option<String>,
    /// Metadata lines before the CSV header row. Default: the header is the first line with a
    /// cell naming the time column.
    pub header_lines: Option<usize>,
    /// Magnitude checks of wavelengths and ambient temperature (default true).
    pub check_units: Option<bool>,
    /// ENLIGHT: the largest time gap \[s\] between two reference samples across which a value is
    /// interpolated; beyond it (or outside the refs' time range) the value is missing.
    /// Default: 3 × the median spacing of the refs file.
    pub max_gap_s: Option<f64>,
    #[serde(default)]
    pub time: TimeMap,
    /// Interrogator ambient temperature [°C]. Default: the column `T_amb_C` when there is
    /// one; an installation without an ambient thermometer has none.
    pub ambient: Option<RefMap>,
    /// Reference temperature [°C] (thermocouple, PT100, ...).
    pub temperature: Option<RefMap>,
    /// Reference strain \[µε\] (or a load cell with `gain` µε per unit).
    pub strain: Option<RefMap>,
    /// Reference pressure \[kPa\].
    pub pressure: Option<RefMap>,
    /// Further measurands by name (`strain2_ue`, `T2_C`, ...; also `T_C` etc. instead of the
    /// tables above).
    #[serde(default)]
    pub measurand: Vec<MeasurandMap>,
    /// The gratings (1 to 8), for dl1_pm, dl2_pm, ... in that order.
    #[serde(default)]
    pub grating: Vec<GratingMap>,
    #[serde(default)]
    pub enlight: EnlightMap,
    /// Spectrum files (`--format spectra-csv|enlight-responses|pixels`): the pixel grid, the
    /// intensity scale and the peak detector's settings.
    #[serde(default)]
    pub spectra: SpectraMap,
    /// The map file's directory (relative `shape` paths start there); `None` for a map read
    /// from text.
    #[serde(skip)]
    pub dir: Option<std::path::PathBuf>,
}

/// The time column.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TimeMap {
    /// Column name. Default: the first of t_s, time, timestamp, datetime (any case).
    pub column: Option<String>,
    /// `auto` (default), `s`, `ms`, `min`, `h`, `timestamp`.
    #[serde(default)]
    pub unit: TimeUnit,
    /// chrono layout of the timestamps, e.g. `"%d.%m.%Y %H:%M:%S%.f"`. Default: ISO-8601 and
    /// `YYYY-MM-DD hh:mm:ss[.fff]` (also with `/`).
    pub format: Option<String>,
    /// For a time column in seconds: the timestamp of t = 0, so the file can be joined with a
    /// timestamped one.
    pub start: Option<String>,
}

/// A reference or ambient column: value = gain × cell + offset.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefMap {
    pub column: String,
    #[serde(default = "one")]
    pub gain: f64,
    #[serde(default)]
    pub offset: f64,
}

fn one() -> f64 {
    1.0
}

/// A measurand named by its dataset column: value = gain × cell + offset.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeasurandMap {
    /// The dataset column it becomes: `T_C`, `T2_C`, `strain_ue`, `strain2_ue`, `p_kPa`, ...
    pub name: Measurand,
    pub column: String,
    #[serde(default = "one")]
    pub gain: f64,
    #[serde(default)]
    pub offset: f64,
}

/// One grating.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GratingMap {
    /// CSV: the column holding this grating's wavelength.
    pub column: Option<String>,
    /// CSV: `nm`, `pm` (absolute), `shift_pm`, `shift_nm`.
    pub unit: Option<WlUnit>,
    /// ENLIGHT: channel number (1-based).
    pub channel: Option<usize>,
    /// ENLIGHT: the grating's wavelength window [lo, hi] in nm; exactly one peak of the
    /// channel is expected inside it.
    pub window_nm: Option<[f64; 2]>,
    /// Absolute wavelength \[nm\] at the reference condition; Δλ = (λ − ref_nm) × 1000 pm.
    /// Default: the first valid reading of the grating in the output.
    pub ref_nm: Option<f64>,
    /// Spectrum files: the grating's measured reflection shape (a CSV with `wavelength_nm`
    /// and `reflectance`, relative to the map's directory), which refines each frame's peak by
    /// a template fit (`spectra/shape.rs`).
    pub shape: Option<std::path::PathBuf>,
}

/// Settings of an ENLIGHT / Hyperion peaks file.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EnlightMap {
    /// Number of channels (peak-count cells). Default: worked out from the first data row.
    pub channels: Option<usize>,
    /// Unit of the peak wavelengths: `nm` (default) or `pm`.
    pub unit: Option<WlUnit>,
    /// `"\t"` or `","`. Default: tab if the first data line has one, else comma.
    pub delimiter: Option<String>,
    /// chrono layout of the timestamps (default: as `[time]`'s default).
    pub time_format: Option<String>,
    /// Metadata lines before the table. Default: everything before the first line that starts
    /// with a time and a peak count.
    pub header_lines: Option<usize>,
    /// The export's culture (`de-DE`, `en-US`, ...) for a file without a `Culture:` line:
    /// decimal mark and day/month order of its dates.
    pub culture: Option<String>,
}

/// Settings of a spectrum file and of its peak detection (`[spectra]`). The gratings' search
/// windows are the `[[grating]]` entries' `channel` and `window_nm`, as for ENLIGHT peaks.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpectraMap {
    /// Intensity scale: `linear` or `db`. Default: dB for ENLIGHT Responses, linear for the
    /// others; `--scale` overrides it.
    pub scale: Option<Scale>,
    /// `--format pixels`: the pixel-to-wavelength polynomial λ(p) = Σₖ cₖ·pᵏ \[nm\], c₀ first,
    /// 2 to 6 coefficients (a spectrometer's calibration sheet), p = 0 the first pixel column.
    pub pixel_to_nm: Option<Vec<f64>>,
    /// Peak method: `maximum`, `centroid`, `gaussian3`, `gaussian-fit`,
    /// `cross-correlation` (default).
    pub method: Option<String>,
    /// Where a peak's samples start, as a fraction of its height above the floor (0–1,
    /// default 0.5).
    pub threshold: Option<f64>,
    /// The cross-correlation's reference FWHM \[nm\] (default: twice each peak's own).
    pub reference_fwhm_nm: Option<f64>,
    /// The detector's full scale in the file's unit (counts, or dB for a dB file): a sample at
    /// or above it flags the peak `saturated`. Default: none.
    pub full_scale: Option<f64>,
    /// `low-snr` below this SNR \[dB\], 10·log₁₀(height/σ) (default 10 dB).
    pub min_snr_db: Option<f64>,
    /// No peak below this SNR \[dB\] (default 7 dB).
    pub no_peak_snr_db: Option<f64>,
    /// `too-narrow` below this FWHM \[nm\] (default: never).
    pub min_fwhm_nm: Option<f64>,
    /// `too-wide` above this FWHM \[nm\] (default: never).
    pub max_fwhm_nm: Option<f64>,
    /// `asymmetric` above this ratio of the half-widths (default 1.5).
    pub max_asymmetry: Option<f64>,
    /// `second-peak` when another peak in the window rises above this fraction of the main
    /// one (default 0.25).
    pub second_peak_fraction: Option<f64>,
    /// The flags whose frames become gaps in the imported dataset (their wavelength is
    /// suspect). Default: `saturated`, `second-peak`, `at-edge`; a frame with `no-peak` is a
    /// gap whatever this says.
    pub gap_on: Option<Vec<String>>,
}

/// A CSV grating after defaults: column, unit, reference.
#[derive(Clone, Debug)]
pub(crate) struct CsvGrating {
    pub column: String,
    pub unit: WlUnit,
    pub ref_nm: Option<f64>,
    /// Map key of the unit, for hints.
    pub unit_key: String,
}

/// An ENLIGHT grating window after validation (channel 0-based).
#[derive(Clone, Debug)]
pub(crate) struct Window {
    pub channel: usize,
    pub lo: f64,
    pub hi: f64,
    pub key: String,
    /// The measured shape's file, resolved against the map's directory.
    pub shape: Option<std::path::PathBuf>,
}

/// The importer a map is checked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum For {
    Csv,
    Enlight,
    /// A spectrum file: gratings by channel and window, like ENLIGHT peaks, and `[spectra]`.
    Spectra,
}

impl Map {
    /// Read and check a map file; errors name the file and the key (or TOML line/column).
    pub fn load(path: &Path) -> Result<Map, TrainerError> {
        let text = std::fs::read_to_string(path).map_err(|e| TrainerError::io(path, e))?;
        let mut m = Self::from_toml_str(&text, &path.display().to_string())?;
        m.dir = path.parent().map(Path::to_path_buf);
        Ok(m)
    }

    /// Parse TOML text; `origin` names the source in errors.
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Map, TrainerError> {
        toml::from_str(text).map_err(|e| TrainerError::Config {
            origin: origin.to_string(),
            key: e.span().map(|s| line_col(text, s.start)).unwrap_or_default(),
            message: e.message().to_string(),
        })
    }

    pub(crate) fn check_units(&self) -> bool {
        self.check_units.unwrap_or(true)
    }

    /// Check the keys that matter for one importer.
    pub(crate) fn validate(&self, origin: &str, what: For) -> Result<(), TrainerError> {
        let err = |key: String, message: String| TrainerError::Config { origin: origin.to_string(), key, message };
        self.validate_layout(&err)?;
        self.validate_references(&err)?;
        if self.grating.len() > MAX_GRATINGS {
            return Err(err(
                "grating".into(),
                format!(
                    "{} [[grating]] entries; 1 to {MAX_GRATINGS} are supported (dl1_pm, dl2_pm, ..., in that order)",
                    self.grating.len()
                ),
            ));
        }
        for (i, g) in self.grating.iter().enumerate() {
            let key = |k: &str| format!("grating[{}].{k}", i + 1);
            if let Some(r) = g.ref_nm {
                if !(NM_RANGE.0..=NM_RANGE.1).contains(&r) {
                    return Err(err(
                        key("ref_nm"),
                        format!("{r} is not a wavelength in nm ({}–{} nm)", NM_RANGE.0, NM_RANGE.1),
                    ));
                }
            }
            if g.shape.is_some() && what != For::Spectra {
                return Err(err(
                    key("shape"),
                    "a measured shape refines peaks found in spectra: --format spectra-csv, enlight-responses or pixels".into(),
                ));
            }
            match what {
                For::Csv => g.validate_csv().map_err(|(k, m)| err(key(k), m))?,
                For::Enlight | For::Spectra => {
                    g.validate_enlight(&self.grating[..i]).map_err(|(k, m)| err(key(k), m))?
                }
            }
        }
        if what == For::Enlight {
            if let Some(u) = self.enlight.unit {
                if u.is_shift() {
                    return Err(err("enlight.unit".into(), "ENLIGHT peaks are absolute wavelengths: nm or pm".into()));
                }
            }
            if self.enlight.channels == Some(0) {
                return Err(err("enlight.channels".into(), "at least one channel".into()));
            }
        }
        if what == For::Spectra {
            self.spectra.validate().map_err(|(k, m)| err(format!("spectra.{k}"), m))?;
        }
        Ok(())
    }

    /// The delimiters, the time axis and the join's largest gap.
    fn validate_layout(&self, err: &impl Fn(String, String) -> TrainerError) -> Result<(), TrainerError> {
        if let Some(d) = &self.delimiter {
            delimiter(d).map_err(|m| err("delimiter".into(), m))?;
        }
        if let Some(d) = &self.enlight.delimiter {
            delimiter(d).map_err(|m| err("enlight.delimiter".into(), m))?;
        }
        if let Some(s) = &self.time.start {
            if parse_timestamp(s, None).is_none() {
                return Err(err(
                    "time.start".into(),
                    format!("`{s}` is not a timestamp (YYYY-MM-DD hh:mm:ss[.fff] or ISO-8601)"),
                ));
            }
            if self.time.unit == TimeUnit::Timestamp || self.time.format.is_some() {
                return Err(err("time.start".into(), "only a time column in seconds needs a start".into()));
            }
        }
        if let Some(g) = self.max_gap_s {
            if !(g.is_finite() && g > 0.0) {
                return Err(err("max_gap_s".into(), format!("{g} is not a positive number of seconds")));
            }
        }
        Ok(())
    }

    /// The ambient thermometer's and the measurands' gains and offsets; each measurand mapped
    /// once, at most [`MAX_MEASURANDS`].
    fn validate_references(&self, err: &impl Fn(String, String) -> TrainerError) -> Result<(), TrainerError> {
        let ambient = self.ambient.as_ref().map(|r| ("ambient".to_string(), r.gain, r.offset));
        for (name, gain, offset) in
            ambient.into_iter().chain(self.measurands().into_iter().map(|(_, r, k)| (k, r.gain, r.offset)))
        {
            if !(gain.is_finite() && gain != 0.0) {
                return Err(err(format!("{name}.gain"), format!("{gain} is not a finite, non-zero gain")));
            }
            if !offset.is_finite() {
                return Err(err(format!("{name}.offset"), format!("{offset} is not finite")));
            }
        }
        let ms = self.measurands();
        for (i, (m, _, key)) in ms.iter().enumerate() {
            if let Some((_, _, first)) = ms[..i].iter().find(|(o, _, _)| o == m) {
                return Err(err(format!("{key}.name"), format!("`{m}` is mapped twice (also by `{first}`)")));
            }
        }
        if ms.len() > MAX_MEASURANDS {
            return Err(err("measurand".into(), format!("{} measurands; at most {MAX_MEASURANDS}", ms.len())));
        }
        Ok(())
    }

    /// The measurands the map names: the `[temperature]`, `[strain]`, `[pressure]` tables and
    /// every `[[measurand]]`, with the map key of each.
    pub(crate) fn measurands(&self) -> Vec<(Measurand, RefMap, String)> {
        let mut out = Vec::new();
        for (name, m, r) in [
            ("temperature", Measurand::T, &self.temperature),
            ("strain", Measurand::STRAIN, &self.strain),
            ("pressure", Measurand::P, &self.pressure),
        ] {
            if let Some(r) = r {
                out.push((m, r.clone(), name.to_string()));
            }
        }
        for (i, x) in self.measurand.iter().enumerate() {
            let r = RefMap { column: x.column.clone(), gain: x.gain, offset: x.offset };
            out.push((x.name, r, format!("measurand[{}]", i + 1)));
        }
        out
    }

    /// The CSV gratings the map lists (empty: the file's `dl1_pm..dlN_pm` columns in pm shifts).
    pub(crate) fn csv_gratings(&self) -> Vec<CsvGrating> {
        self.grating
            .iter()
            .enumerate()
            .map(|(i, g)| CsvGrating {
                column: g.column.clone().unwrap_or_default(),
                unit: g.unit.unwrap_or(WlUnit::Nm),
                ref_nm: g.ref_nm,
                unit_key: format!("grating[{}].unit", i + 1),
            })
            .collect()
    }

    /// The ENLIGHT windows (empty without `[[grating]]`).
    pub(crate) fn windows(&self) -> Vec<Window> {
        self.grating
            .iter()
            .enumerate()
            .map(|(i, g)| {
                let [lo, hi] = g.window_nm.unwrap_or([0.0, 0.0]);
                let shape = g.shape.as_ref().map(|p| self.dir.as_deref().map_or_else(|| p.clone(), |d| d.join(p)));
                let channel = g.channel.unwrap_or(1).saturating_sub(1);
                Window { channel, lo, hi, key: format!("grating[{}]", i + 1), shape }
            })
            .collect()
    }
}

/// A delimiter key → its byte.
pub(crate) fn delimiter(s: &str) -> Result<u8, String> {
    match s {
        "tab" | "\t" | "\\t" => Ok(b'\t'),
        s if s.len() == 1 && s.is_ascii() && s != "\"" && s != "\n" && s != "\r" => Ok(s.as_bytes()[0]),
        other => Err(format!("`{other}` is not a one-character delimiter (`,`, `;`, `\\t` or `tab`, `|`)")),
    }
}

impl GratingMap {
    /// A logger CSV's grating: a column and its unit. Errors are (key within the grating,
    /// message).
    fn validate_csv(&self) -> Result<(), (&'static str, String)> {
        if self.channel.is_some() || self.window_nm.is_some() {
            let k = if self.channel.is_some() { "channel" } else { "window_nm" };
            return Err((
                k,
                "channel and window_nm belong to --format enlight; a CSV grating has `column` and `unit`".into(),
            ));
        }
        if self.column.is_none() {
            return Err(("column", "missing: the column holding this grating's wavelength".into()));
        }
        let Some(u) = self.unit else {
            return Err(("unit", "missing: one of nm, pm (absolute wavelengths), shift_pm, shift_nm (shifts)".into()));
        };
        if u.is_shift() && self.ref_nm.is_some() {
            return Err((
                "ref_nm",
                format!("the column holds shifts (unit {}), so it has no reference wavelength", u.name()),
            ));
        }
        Ok(())
    }

    /// An ENLIGHT grating: a channel and a wavelength window that overlaps none of the
    /// `earlier` gratings' on that channel. Errors are (key within the grating, message).
    fn validate_enlight(&self, earlier: &[GratingMap]) -> Result<(), (&'static str, String)> {
        if self.column.is_some() || self.unit.is_some() {
            let k = if self.column.is_some() { "column" } else { "unit" };
            return Err((k, "column and unit belong to --format csv; an ENLIGHT grating has `channel` and `window_nm` (peaks are in [enlight] unit)".into()));
        }
        let Some(c) = self.channel else {
            return Err(("channel", "missing: the interrogator channel (1-based)".into()));
        };
        if c == 0 {
            return Err(("channel", "channels are numbered from 1".into()));
        }
        let Some([lo, hi]) = self.window_nm else {
            return Err(("window_nm", "missing: [lo, hi] in nm around the grating's wavelength".into()));
        };
        if !(NM_RANGE.0..=NM_RANGE.1).contains(&lo) || !(NM_RANGE.0..=NM_RANGE.1).contains(&hi) || lo >= hi {
            return Err((
                "window_nm",
                format!("[{lo}, {hi}] is not a window [lo < hi] in nm ({}–{} nm)", NM_RANGE.0, NM_RANGE.1),
            ));
        }
        if let Some(r) = self.ref_nm {
            if r < lo || r > hi {
                return Err(("ref_nm", format!("{r} nm lies outside the grating's window [{lo}, {hi}] nm")));
            }
        }
        for (j, o) in earlier.iter().enumerate() {
            if let (Some(oc), Some([olo, ohi])) = (o.channel, o.window_nm) {
                if oc == c && lo <= ohi && olo <= hi {
                    return Err((
                        "window_nm",
                        format!("[{lo}, {hi}] overlaps grating[{}].window_nm [{olo}, {ohi}] on channel {c}", j + 1),
                    ));
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {

    /// A relative `shape` starts at the map's directory; a map read from text leaves it as
    /// written.
    #[test]
    fn a_shape_path_is_relative_to_the_map() {
        let d = tempfile::tempdir().unwrap();
        let sub = d.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        let text = "[[grating]]\nchannel = 1\nwindow_nm = [1549.0, 1551.0]\nshape = \"scan.csv\"\n";
        std::fs::write(sub.join("map.toml"), text).unwrap();
        let m = Map::load(&sub.join("map.toml")).unwrap();
        assert_eq!(m.windows()[0].shape.as_deref(), Some(sub.join("scan.csv").as_path()));
        let m = Map::from_toml_str(text, "m.toml").unwrap();
        assert_eq!(m.windows()[0].shape.as_deref(), Some(Path::new("scan.csv")));
    }
    use super::*;

    #[test]
    fn map_errors_name_the_key() {
        let m = Map::from_toml_str("[[grating]]\nchannel = 1\nunit = \"nm\"\n", "m.toml").unwrap();
        let e = m.validate("m.toml", For::Csv).unwrap_err().to_string();
        assert!(e.contains("m.toml") && e.contains("grating[1].channel"), "{e}");
        let m = Map::from_toml_str("[[grating]]\ncolumn = \"a\"\nunit = \"nm\"\n", "m.toml").unwrap();
        assert!(m.validate("m.toml", For::Csv).is_ok());
        let nine = "[[grating]]\ncolumn = \"a\"\nunit = \"nm\"\n".repeat(9);
        let e = Map::from_toml_str(&nine, "m.toml").unwrap().validate("m.toml", For::Csv).unwrap_err().to_string();
        assert!(e.contains("9 [[grating]]"), "{e}");
        let twice = "[strain]\ncolumn = \"a\"\n[[measurand]]\nname = \"strain_ue\"\ncolumn = \"b\"\n";
        let e = Map::from_toml_str(twice, "m.toml").unwrap().validate("m.toml", For::Csv).unwrap_err().to_string();
        assert!(e.contains("measurand[1].name") && e.contains("twice"), "{e}");
        let e =
            Map::from_toml_str("[[measurand]]\nname = \"T1_C\"\ncolumn = \"b\"\n", "m.toml").unwrap_err().to_string();
        assert!(e.contains("T1_C") && e.contains("line 2"), "{e}");
        let e = Map::from_toml_str("[time]\ncolum = \"x\"\n", "m.toml").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("colum"), "{e}");
    }
}
