//! What an import did ([`ImportSummary`]): the counts, the gratings' zeros, the references
//! found, the time span and the split, as JSON (`--json`) and as a few lines for a terminal.

use std::collections::BTreeMap;

use serde::Serialize;

use super::problems::FileSkips;
use super::scale::Scale;
use super::time_axis::{self, TimeKind};
use super::Format;
use crate::data::{Measurand, T_AMB_COLUMN};

/// Rows left out because no ambient temperature was known at their time.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Dropped {
    pub count: usize,
    pub first_lines: Vec<u64>,
}

/// One output grating.
#[derive(Clone, Debug, Serialize)]
pub struct GratingSummary {
    /// Output column (`dl1_pm`, ...).
    pub output: String,
    /// Where it comes from (column and unit, or channel and window).
    pub source: String,
    /// Reference wavelength \[nm\] the shift is taken from (absent for shift columns).
    pub ref_nm: Option<f64>,
    /// `map`, `first reading (line N)` or `shifts in the file`.
    pub ref_source: String,
    /// Rows with no reading (empty dl cell).
    pub gaps: usize,
    /// Range of the shifts written \[pm\].
    pub min_pm: Option<f64>,
    pub max_pm: Option<f64>,
}

/// One reference column found.
#[derive(Clone, Debug, Serialize)]
pub struct RefSummary {
    /// The source column (in the input or the refs file).
    pub column: String,
    /// Written rows that have a value.
    pub values: usize,
}

/// The ambient temperature and the references found. In JSON, one key per dataset column:
/// `T_amb_C` (null without a thermometer) and each measurand found (`T_C`, `strain2_ue`, ...).
#[derive(Clone, Debug)]
pub struct References {
    /// The ambient thermometer, if the record has one.
    pub ambient: Option<RefSummary>,
    /// The measurands found, in canonical order.
    pub measurands: Vec<(Measurand, RefSummary)>,
}

impl References {
    /// The source of measurand `m`, if found.
    pub fn get(&self, m: Measurand) -> Option<&RefSummary> {
        self.measurands.iter().find(|(x, _)| *x == m).map(|(_, r)| r)
    }
}

impl Serialize for References {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut map = s.serialize_map(Some(1 + self.measurands.len()))?;
        map.serialize_entry(T_AMB_COLUMN, &self.ambient)?;
        for (m, r) in &self.measurands {
            map.serialize_entry(&m.column(), r)?;
        }
        map.end()
    }
}

/// What the imported record is good for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Purpose {
    /// References present: `train`, `evaluate` (and `compensate`, which also scores).
    Training,
    /// No references: every row kept, for `compensate` only.
    Compensation,
}

/// The written record's time span.
#[derive(Clone, Debug, Serialize)]
pub struct TimeSummary {
    /// Timestamps or seconds in the input.
    pub kind: TimeKind,
    /// First and last written row as timestamps (calendar time only).
    pub start: Option<String>,
    pub end: Option<String>,
    pub span_s: f64,
    /// Median sampling interval \[s\].
    pub median_dt_s: f64,
}

/// The split written.
#[derive(Clone, Debug, Serialize)]
pub struct SplitSummary {
    /// `fraction 0.5` or `until <TIME>`.
    pub rule: String,
    /// Rows with t_s at or before this calibrate.
    pub cal_until_s: f64,
    pub cal_rows: usize,
    pub holdout_rows: usize,
}

/// ENLIGHT file facts.
#[derive(Clone, Debug, Serialize)]
pub struct EnlightInfo {
    pub channels: usize,
    pub delimiter: String,
    /// Lines before the first data row.
    pub metadata_lines: usize,
    /// Without a map: rows where a channel's peak count differed from its usual count (that
    /// channel's gratings are gaps there).
    pub unassigned_rows: usize,
    /// The culture the file was read in and where it came from (`de-DE (line 2)`), if any.
    pub culture: Option<String>,
    /// Day/month order of numeric dates (`day_first`, `month_first`; absent for year-first
    /// dates or seconds) ...
    pub date_order: Option<time_axis::DateOrder>,
    /// ... and what decided it (the culture, or a date with a day above 12).
    pub date_order_from: Option<String>,
}

/// A spectrum file's facts and what its peak detection found.
#[derive(Clone, Debug, Serialize)]
pub struct SpectraInfo {
    /// The spectrum format.
    pub format: Format,
    /// Channels seen.
    pub channels: usize,
    /// Frames (times) read.
    pub frames: usize,
    /// Samples per spectrum.
    pub points: usize,
    /// The wavelength grid in words.
    pub grid: String,
    /// The intensity scale of the file ...
    pub scale: Scale,
    /// ... and what decided it (`--scale`, the map, the format's own, the default).
    pub scale_from: String,
    /// The peak method (`cross-correlation`, ...).
    pub method: String,
    /// The culture the file was read in and where it came from, if any.
    pub culture: Option<String>,
    /// Lines before the first spectrum.
    pub metadata_lines: usize,
    /// Where the gratings' search windows come from (the map, or discovered).
    pub windows_from: String,
    /// The flags whose frames are gaps in the dataset.
    pub gap_on: Vec<String>,
    /// Per grating: the flagged frames and the gaps they made.
    pub flagged: Vec<FlaggedFrames>,
}

/// One grating's peak method and flagged frames.
#[derive(Clone, Debug, Serialize)]
pub struct FlaggedFrames {
    /// Output column (`dl1_pm`, ...).
    pub output: String,
    /// Its peak method: the file's, `+shape` where the map gives the grating's measured shape
    /// (the peaks table's `method` column).
    pub method: String,
    /// Frames holding the grating's channel.
    pub frames: usize,
    /// Frames with any flag raised.
    pub flagged: usize,
    /// Frames made gaps (no peak, or a flag of `gap_on`).
    pub gaps: usize,
    /// Frames per flag raised (`low-snr`, `saturated`, ...).
    pub by_flag: BTreeMap<String, usize>,
}

/// How the references were joined onto the peak times.
#[derive(Clone, Debug, Serialize)]
pub struct JoinInfo {
    pub max_gap_s: f64,
    /// `map` or `3 × median refs spacing`.
    pub max_gap_source: String,
    pub refs_rows: usize,
    pub refs_start: String,
    pub refs_end: String,
}

/// What an import did; `--json` prints it.
#[derive(Clone, Debug, Serialize)]
pub struct ImportSummary {
    pub format: Format,
    pub input: String,
    pub map: Option<String>,
    pub refs: Option<String>,
    pub out: Option<String>,
    /// Data rows in the input.
    pub rows_read: usize,
    pub rows_written: usize,
    /// Bad input rows left out (`--on-error skip`).
    pub rows_skipped: usize,
    /// Bad rows per file (the input, then the refs) and reason.
    pub skipped: Vec<FileSkips>,
    /// What the record is for: training (references present) or compensation (none; every
    /// row kept).
    pub purpose: Purpose,
    /// Rows without an ambient temperature (outside the refs, or in a gap longer than
    /// max_gap_s, or an empty ambient cell) — dropped only from a record with references and
    /// an ambient thermometer.
    pub dropped_no_ambient: Dropped,
    /// Gaps per grating (dl1..dlN).
    pub gaps: Vec<usize>,
    pub gratings: Vec<GratingSummary>,
    pub references: References,
    pub time: TimeSummary,
    pub split: SplitSummary,
    pub enlight: Option<EnlightInfo>,
    pub join: Option<JoinInfo>,
    /// Spectrum formats: the file, the detection and the flagged frames.
    pub spectra: Option<SpectraInfo>,
}

impl ImportSummary {
    /// A few lines for a terminal.
    pub fn text(&self) -> String {
        let mut s = String::new();
        let out = self.out.as_deref().unwrap_or("(not written)");
        s.push_str(&format!(
            "imported {} ({}): {} rows read, {} written to {out}, {} skipped as bad, {} without ambient temperature\n",
            self.input,
            match self.format {
                Format::Enlight => "ENLIGHT peaks",
                Format::Csv => "logger CSV",
                Format::SpectraCsv => "spectra CSV",
                Format::EnlightResponses => "ENLIGHT Responses spectra",
                Format::Pixels => "spectrometer pixels",
            },
            self.rows_read,
            self.rows_written,
            self.rows_skipped,
            self.dropped_no_ambient.count
        ));
        for f in &self.skipped {
            for (r, c) in &f.by_reason {
                let lines: Vec<String> = c.first_lines.iter().map(u64::to_string).collect();
                let more = if c.count > c.first_lines.len() { ", …" } else { "" };
                s.push_str(&format!(
                    "  skipped {} × {} in {} (lines {}{more})\n",
                    c.count,
                    r.as_str(),
                    f.file,
                    lines.join(", ")
                ));
            }
        }
        if self.dropped_no_ambient.count > 0 {
            let lines: Vec<String> = self.dropped_no_ambient.first_lines.iter().map(u64::to_string).collect();
            s.push_str(&format!(
                "  dropped {} rows with no ambient temperature (lines {}…)\n",
                self.dropped_no_ambient.count,
                lines.join(", ")
            ));
        }
        if let Some(e) = &self.enlight {
            s.push_str(&format!(
                "  {} channels, {}-separated, {} metadata lines",
                e.channels, e.delimiter, e.metadata_lines
            ));
            if e.unassigned_rows > 0 {
                s.push_str(&format!(", {} rows with an unusual peak count (gaps)", e.unassigned_rows));
            }
            if let Some(c) = &e.culture {
                s.push_str(&format!(", culture {c}"));
            }
            if let (Some(o), Some(from)) = (e.date_order, &e.date_order_from) {
                s.push_str(&format!(", dates {} ({from})", o.words()));
            }
            s.push('\n');
        }
        if let Some(sp) = &self.spectra {
            s.push_str(&sp.text());
        }
        for g in &self.gratings {
            let r = match g.ref_nm {
                Some(r) => format!("λ_ref {r:.4} nm from {}", g.ref_source),
                None => g.ref_source.clone(),
            };
            let range = match (g.min_pm, g.max_pm) {
                (Some(a), Some(b)) => format!("{a:.1} … {b:.1} pm"),
                _ => "no values".into(),
            };
            s.push_str(&format!("  {}: {}; {r}; {range}; {} gaps\n", g.output, g.source, g.gaps));
        }
        let r = &self.references;
        let ambient = match &r.ambient {
            Some(a) => format!("T_amb_C ← `{}` ({} values)", a.column, a.values),
            None => "no ambient thermometer (no T_amb_C column)".to_string(),
        };
        let refs: Vec<String> =
            r.measurands.iter().map(|(m, x)| format!("{m} ← `{}` ({} values)", x.column, x.values)).collect();
        let refs = if refs.is_empty() { "no references".to_string() } else { refs.join("; ") };
        s.push_str(&format!("  references: {ambient}; {refs}\n"));
        if self.purpose == Purpose::Compensation {
            s.push_str(
                "  no reference columns: imported row for row (every row kept, gaps as gaps) — a field record for `fbg-trainer compensate`, not for training\n",
            );
        }
        if let Some(j) = &self.join {
            s.push_str(&format!(
                "  refs joined by linear interpolation, max gap {} s ({}); refs {} – {}, {} rows\n",
                j.max_gap_s, j.max_gap_source, j.refs_start, j.refs_end, j.refs_rows
            ));
        }
        let t = &self.time;
        let when = match (&t.start, &t.end) {
            (Some(a), Some(b)) => format!("{a} – {b}, "),
            _ => String::new(),
        };
        s.push_str(&format!("  time: {when}{:.3} s span, median step {:.3} s\n", t.span_s, t.median_dt_s));
        let sp = &self.split;
        s.push_str(&format!(
            "  split ({}): cal up to t_s = {:.3} s: {} cal rows, {} hold-out rows",
            sp.rule, sp.cal_until_s, sp.cal_rows, sp.holdout_rows
        ));
        s
    }
}

impl SpectraInfo {
    /// The summary's lines on the spectra: frames, grid, scale, method, flagged frames.
    pub fn text(&self) -> String {
        let sp = self;
        let mut s = String::new();
        s.push_str(&format!(
            "  {} frames, {} channels, {}; {} ({}); method {}; windows from {}",
            sp.frames,
            sp.channels,
            sp.grid,
            sp.scale.name(),
            sp.scale_from,
            sp.method,
            sp.windows_from
        ));
        if let Some(c) = &sp.culture {
            s.push_str(&format!(", culture {c}"));
        }
        s.push('\n');
        let shaped: Vec<&str> =
            sp.flagged.iter().filter(|f| f.method != sp.method).map(|f| f.output.as_str()).collect();
        if !shaped.is_empty() {
            s.push_str(&format!("  refined by the measured shape the map gives: {}\n", shaped.join(", ")));
        }
        for f in sp.flagged.iter().filter(|f| f.flagged > 0 || f.gaps > 0) {
            let by: Vec<String> = f.by_flag.iter().map(|(k, v)| format!("{k} {v}")).collect();
            s.push_str(&format!(
                "  {}: {} of {} frames flagged ({}), {} gaps (gaps on {})\n",
                f.output,
                f.flagged,
                f.frames,
                by.join(", "),
                f.gaps,
                sp.gap_on.join(", ")
            ));
        }
        s
    }
}
