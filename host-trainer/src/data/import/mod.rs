//! `fbg-trainer import`: real interrogator exports into the dataset CSV of DESIGN §3.
//!
//! - `--format enlight`: a Micron Optics ENLIGHT / Hyperion peaks export (`enlight.rs`),
//!   optionally with a `--refs` CSV holding the ambient temperature and the references, joined
//!   onto the peak times by linear interpolation (`join.rs`);
//! - `--format csv`: any logger CSV whose columns a map names (`logger_csv.rs`);
//! - `--format spectra-csv|enlight-responses|pixels`: spectra, whose peaks are detected per
//!   grating and frame ([`spectra`]) and then imported as an ENLIGHT peaks export would be
//!   (the same `--refs` join, zero, split and summary).
//!
//! All take 1 to 8 gratings and up to 4 measurands. References and the ambient thermometer are
//! optional: a record without references is imported row for row (every row kept, gaps as
//! gaps) for `compensate`, not for training, and the summary says so.
//!
//! The map is described in [`mapping`]. Bad rows are an error naming file, line and column, or
//! counted skips ([`problems`]); the output is written atomically (`Dataset::write_csv`).

mod assemble;
mod culture;
mod dates;
mod enlight;
mod join;
mod logger_csv;
pub mod mapping;
mod merge;
pub mod problems;
mod scale;
pub mod spectra;
mod summary;
pub mod time_axis;

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::data::Dataset;
use crate::error::{quote_cell, TrainerError};
pub use mapping::Map;
pub use problems::{FileSkips, OnError, Reason, ReasonCount};
pub use scale::Scale;
pub use spectra::peak_table::{peaks_to_csv, PeaksSummary, PEAKS_HEADER};
pub use summary::{
    Dropped, EnlightInfo, FlaggedFrames, GratingSummary, ImportSummary, JoinInfo, Purpose, RefSummary, References,
    SpectraInfo, SplitSummary, TimeSummary,
};
pub use time_axis::TimeKind;

use mapping::For;
use merge::Merged;

/// The input layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// An ENLIGHT / Hyperion peaks export.
    Enlight,
    /// A logger CSV.
    Csv,
    /// Spectra: `t_s,channel,` and one column per wavelength \[nm\].
    SpectraCsv,
    /// An ENLIGHT / Hyperion Responses (spectrum) export.
    EnlightResponses,
    /// A spectrometer's pixels, with the map's pixel-to-wavelength polynomial.
    Pixels,
}

impl Format {
    /// True for the spectrum formats (peaks detected from spectra).
    pub fn is_spectra(self) -> bool {
        matches!(self, Format::SpectraCsv | Format::EnlightResponses | Format::Pixels)
    }
}

impl std::str::FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "enlight" => Ok(Format::Enlight),
            "csv" => Ok(Format::Csv),
            "spectra-csv" => Ok(Format::SpectraCsv),
            "enlight-responses" => Ok(Format::EnlightResponses),
            "pixels" => Ok(Format::Pixels),
            other => Err(format!("`{other}` is not a format: enlight, csv, spectra-csv, enlight-responses or pixels")),
        }
    }
}

/// How the calibration / hold-out split is drawn.
#[derive(Clone, Debug, PartialEq)]
pub enum SplitChoice {
    /// Rows up to this fraction of the record's duration calibrate.
    Fraction(f64),
    /// Rows up to this time calibrate: seconds from the first written row, or a timestamp
    /// (for files with calendar time).
    Until(String),
}

impl SplitChoice {
    /// Refuse a split no record can make right: a fraction outside (0, 1]. Needs no file, so
    /// it is checked before anything is read (a time is checked against the record).
    pub fn check(&self) -> Result<(), TrainerError> {
        match self {
            SplitChoice::Fraction(f) if !(f.is_finite() && *f > 0.0 && *f <= 1.0) => Err(TrainerError::Config {
                origin: "--cal-fraction".into(),
                key: String::new(),
                message: format!("{} is not a fraction in (0, 1]", crate::error::ShortNumber(*f)),
            }),
            _ => Ok(()),
        }
    }
}

impl Default for SplitChoice {
    fn default() -> Self {
        SplitChoice::Fraction(0.5)
    }
}

/// Everything `import` needs.
#[derive(Clone, Debug)]
pub struct ImportOptions {
    pub format: Format,
    pub input: PathBuf,
    pub map: Option<PathBuf>,
    pub refs: Option<PathBuf>,
    pub split: SplitChoice,
    pub on_error: OnError,
    /// `--on-error skip`: the largest fraction of a file's rows that may be skipped as bad;
    /// above it the import fails with the counts by reason ([`DEFAULT_MAX_SKIPPED`]).
    pub max_skipped: f64,
    /// `--model`: zero absolute wavelengths on a model's λ_ref instead of the map's or the
    /// first reading (a field record read against the calibration's zero).
    pub zero_from: Option<ModelZero>,
    /// `--start`: absolute time (Unix s) of the first row, for a record whose times are plain
    /// seconds.
    pub start_unix_s: Option<f64>,
    /// `--scale`: the spectrum formats' intensity scale, over the map's and the format's own.
    pub scale: Option<Scale>,
}

/// A model's zero, for [`ImportOptions::zero_from`].
#[derive(Clone, Debug, PartialEq)]
pub struct ModelZero {
    /// The model file (for messages).
    pub model: String,
    /// λ_ref per grating \[nm\], `None` where the model does not know it.
    pub lambda_ref_nm: Vec<Option<f64>>,
}

/// Default of [`ImportOptions::max_skipped`]: 5 % of a file's rows.
pub const DEFAULT_MAX_SKIPPED: f64 = 0.05;
/// Import and write `out` atomically; the summary names `out`.
pub fn import_to_csv(opts: &ImportOptions, out: &Path) -> Result<ImportSummary, TrainerError> {
    let (d, mut s) = import(opts)?;
    d.write_csv(out)?;
    s.out = Some(out.display().to_string());
    Ok(s)
}

/// Read the input (and refs) into a dataset with its split, without writing anything.
///
/// A logger CSV without a map: `t_s` in seconds, the file's own `dl1_pm` shifts, `T_amb_C`
/// and the reference `T_C`; the first half of the record's duration calibrates.
///
/// ```
/// use fbg_trainer::data::import::{import, Format, ImportOptions, OnError, SplitChoice, DEFAULT_MAX_SKIPPED};
///
/// let dir = tempfile::tempdir()?;
/// let input = dir.path().join("logger.csv");
/// std::fs::write(&input, "t_s,T_C,T_amb_C,dl1_pm\n0,20.0,19.5,1.5\n10,20.5,19.6,6.5\n20,21.0,19.7,11.5\n")?;
/// let opts = ImportOptions {
///     format: Format::Csv,
///     input,
///     map: None,
///     refs: None,
///     split: SplitChoice::Fraction(0.5),
///     on_error: OnError::Fail,
///     max_skipped: DEFAULT_MAX_SKIPPED,
///     zero_from: None,
///     start_unix_s: None,
///     scale: None,
/// };
/// let (d, summary) = import(&opts)?;
/// assert_eq!((d.len(), d.n_gratings()), (3, 1));
/// assert_eq!((summary.split.cal_rows, summary.split.holdout_rows), (2, 1));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn import(opts: &ImportOptions) -> Result<(Dataset, ImportSummary), TrainerError> {
    // The options that need no file first: refused before anything is read.
    opts.split.check()?;
    let input_name = opts.input.display().to_string();
    let map_origin = opts.map.as_ref().map(|p| p.display().to_string());
    let map = match &opts.map {
        Some(p) => Some(Map::load(p)?),
        None => None,
    };
    let what = match opts.format {
        Format::Csv => For::Csv,
        Format::Enlight => For::Enlight,
        Format::SpectraCsv | Format::EnlightResponses | Format::Pixels => For::Spectra,
    };
    if opts.scale.is_some() && !opts.format.is_spectra() {
        return Err(TrainerError::Config {
            origin: "--scale".into(),
            key: String::new(),
            message: "only for the spectrum formats (spectra-csv, enlight-responses, pixels)".into(),
        });
    }
    if let (Some(m), Some(o)) = (&map, &map_origin) {
        m.validate(o, what)?;
    }
    let default_map = Map::default();
    let m = map.as_ref().unwrap_or(&default_map);
    let merged = match opts.format {
        Format::Csv => Merged::from_logger_csv(opts, m, &input_name)?,
        Format::Enlight => Merged::from_enlight(opts, map.as_ref(), map_origin.as_deref(), m, &input_name)?,
        Format::SpectraCsv | Format::EnlightResponses | Format::Pixels => {
            Merged::from_spectra(opts, map.as_ref(), map_origin.as_deref(), m, &input_name)?
        }
    };
    problems::refuse_too_many_skipped(&merged.skips, opts.max_skipped)?;
    assemble::finish(merged, opts, map_origin)
}

/// A file as text (invalid UTF-8 replaced, byte-order mark removed): what [`TextLines`] splits
/// line by line (its tests compare the two).
#[cfg(test)]
pub(crate) fn read_text(path: &Path) -> Result<String, TrainerError> {
    let bytes = std::fs::read(path).map_err(|e| TrainerError::io(path, e))?;
    let text = String::from_utf8_lossy(&bytes).into_owned();
    Ok(match text.strip_prefix('\u{feff}') {
        Some(t) => t.to_string(),
        None => text,
    })
}

/// A text file read line by line, as [`read_text`] would split it on `\n` (invalid UTF-8
/// replaced, the byte-order mark removed, a `\r` before the line end dropped), holding one line
/// at a time: what a reader of a file of any length uses.
pub(crate) struct TextLines {
    reader: std::io::BufReader<std::fs::File>,
    path: PathBuf,
    bytes: Vec<u8>,
    line: String,
    /// Lines read so far (the number of the line last returned).
    number: u64,
    /// Bytes read so far (through the end of the line last returned).
    consumed: u64,
    /// The byte where the line last returned starts.
    line_start: u64,
}

/// Bytes read from a file at a time.
pub(crate) const READ_BUFFER: usize = 1 << 20;

impl TextLines {
    /// Open `path`; errors name it.
    pub(crate) fn open(path: &Path) -> Result<TextLines, TrainerError> {
        let f = std::fs::File::open(path).map_err(|e| TrainerError::io(path, e))?;
        Ok(TextLines {
            reader: std::io::BufReader::with_capacity(READ_BUFFER, f),
            path: path.to_path_buf(),
            bytes: Vec::new(),
            line: String::new(),
            number: 0,
            consumed: 0,
            line_start: 0,
        })
    }

    /// Bytes of the file read so far: where the next line starts (the file's length at its end).
    pub(crate) fn consumed(&self) -> u64 {
        self.consumed
    }

    /// The byte where the text of the line last returned starts: after its byte-order mark on
    /// the first line, as the text [`TextLines::next_line`] gave.
    pub(crate) fn text_start(&self) -> u64 {
        let bom = self.number == 1 && self.bytes.starts_with("\u{feff}".as_bytes());
        self.line_start + if bom { 3 } else { 0 }
    }

    /// The next line: its number (from 1), its text without the line end, and whether it
    /// ended with `\n` (only the file's last line may not); `None` at the end of the file
    /// (an empty file has no line; a file ending with `\n` has no empty line after it).
    pub(crate) fn next_line(&mut self) -> Result<Option<(u64, &str, bool)>, TrainerError> {
        use std::io::BufRead;
        self.bytes.clear();
        let n = self.reader.read_until(b'\n', &mut self.bytes).map_err(|e| TrainerError::io(&self.path, e))?;
        if n == 0 {
            return Ok(None);
        }
        self.number += 1;
        self.line_start = self.consumed;
        self.consumed += n as u64;
        let ended = self.bytes.last() == Some(&b'\n');
        if ended {
            self.bytes.pop();
        }
        if self.bytes.last() == Some(&b'\r') {
            self.bytes.pop();
        }
        // `\n` is never part of a multi-byte sequence: replacing line by line is replacing the
        // whole text.
        self.line.clear();
        self.line.push_str(&String::from_utf8_lossy(&self.bytes));
        let text = if self.number == 1 { self.line.strip_prefix('\u{feff}').unwrap_or(&self.line) } else { &self.line };
        Ok(Some((self.number, text, ended)))
    }
}

/// A numeric cell: `Ok(None)` when empty or a missing marker (NaN, NA, N/A, null).
pub(crate) fn number(cell: &str) -> Result<Option<f64>, String> {
    let c = cell.trim();
    if c.is_empty() || ["nan", "na", "n/a", "null"].iter().any(|m| c.eq_ignore_ascii_case(m)) {
        return Ok(None);
    }
    match c.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        Ok(_) => Err(format!("`{}` is not a finite number", quote_cell(c))),
        Err(_) if c.matches(',').count() == 1 && c.replace(',', ".").parse::<f64>().is_ok() => Err(format!(
            "`{}` is not a number (a decimal comma? use a point, or a delimiter other than the decimal mark)",
            quote_cell(c)
        )),
        Err(_) => Err(format!("`{}` is not a number", quote_cell(c))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every line `TextLines` gives, with its number and line end.
    fn streamed(bytes: &[u8]) -> Vec<(u64, String, bool)> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.txt");
        std::fs::write(&path, bytes).unwrap();
        let mut lines = TextLines::open(&path).unwrap();
        let mut out = Vec::new();
        while let Some((n, l, ended)) = lines.next_line().unwrap() {
            out.push((n, l.to_string(), ended));
        }
        // The whole text split as the readers did before they streamed: the same lines, but
        // for the empty one after a final line end.
        let text = read_text(&path).unwrap();
        let mut split: Vec<&str> = text.split('\n').map(|l| l.strip_suffix('\r').unwrap_or(l)).collect();
        if text.ends_with('\n') || text.is_empty() {
            split.pop();
        }
        assert_eq!(out.iter().map(|(_, l, _)| l.as_str()).collect::<Vec<_>>(), split, "{bytes:?}");
        out
    }

    #[test]
    fn text_lines_are_the_whole_text_split_one_line_at_a_time() {
        let l = |n: u64, s: &str, e: bool| (n, s.to_string(), e);
        assert_eq!(streamed(b""), []);
        assert_eq!(streamed(b"a\r\nb\n"), [l(1, "a", true), l(2, "b", true)]);
        assert_eq!(streamed(b"\xef\xbb\xbfh,x\n\n1,2"), [l(1, "h,x", true), l(2, "", true), l(3, "1,2", false)]);
        assert_eq!(streamed(b"ok\xff\xfe\nx\r"), [l(1, "ok\u{fffd}\u{fffd}", true), l(2, "x", false)]);
        // A byte-order mark only counts on the first line.
        assert_eq!(streamed(b"a\n\xef\xbb\xbfb\n")[1], l(2, "\u{feff}b", true));
    }
}
