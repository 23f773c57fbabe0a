//! Bad rows: an error naming file, line and column (`--on-error fail`, the default), or a
//! counted skip reported per reason with the first few line numbers (`--on-error skip`).

use std::collections::BTreeMap;

use serde::Serialize;

use crate::error::TrainerError;

/// What to do with a bad row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum OnError {
    /// Stop at the first bad row with an error naming file, line and column.
    #[default]
    Fail,
    /// Leave the row out, count it by reason and go on.
    Skip,
}

impl std::str::FromStr for OnError {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "fail" => Ok(OnError::Fail),
            "skip" => Ok(OnError::Skip),
            other => Err(format!("`{other}` is neither `fail` nor `skip`")),
        }
    }
}

/// Why a row was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Reason {
    /// Fewer or more cells than the header (or than the peak counts need), e.g. a truncated
    /// last line.
    RaggedRow,
    /// A cell that should hold a number or a time does not.
    NonNumeric,
    /// A time earlier than the previous row's.
    TimeBackwards,
    /// The same time as the previous row.
    DuplicateTime,
    /// A value whose magnitude does not fit its declared unit (nm vs pm, absolute vs shift,
    /// kelvin vs °C).
    UnitMismatch,
    /// ENLIGHT: the per-channel peak counts do not add up to the number of wavelengths.
    PeakCountMismatch,
    /// ENLIGHT: two peaks in one grating's wavelength window.
    AmbiguousPeak,
}

impl Reason {
    pub const ALL: [Reason; 7] = [
        Reason::RaggedRow,
        Reason::NonNumeric,
        Reason::TimeBackwards,
        Reason::DuplicateTime,
        Reason::UnitMismatch,
        Reason::PeakCountMismatch,
        Reason::AmbiguousPeak,
    ];
    pub fn as_str(self) -> &'static str {
        match self {
            Reason::RaggedRow => "ragged_row",
            Reason::NonNumeric => "non_numeric",
            Reason::TimeBackwards => "time_backwards",
            Reason::DuplicateTime => "duplicate_time",
            Reason::UnitMismatch => "unit_mismatch",
            Reason::PeakCountMismatch => "peak_count_mismatch",
            Reason::AmbiguousPeak => "ambiguous_peak",
        }
    }
}

/// How many line numbers each reason keeps for the summary.
pub(crate) const FIRST_LINES: usize = 5;

/// One reason's count and its first line numbers.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct ReasonCount {
    pub count: usize,
    pub first_lines: Vec<u64>,
}

/// The bad rows of one input file.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FileSkips {
    pub file: String,
    /// Data rows in the file (header and metadata lines not counted).
    pub rows_read: usize,
    /// Rows left out for a reason below.
    pub rows_skipped: usize,
    pub by_reason: BTreeMap<Reason, ReasonCount>,
}

impl FileSkips {
    /// Count of one reason (0 when absent).
    pub fn count(&self, r: Reason) -> usize {
        self.by_reason.get(&r).map_or(0, |c| c.count)
    }
}

/// A refused row: where and why.
#[derive(Clone, Debug)]
pub(crate) struct RowError {
    pub reason: Reason,
    pub line: u64,
    pub column: String,
    pub message: String,
}

impl RowError {
    pub fn new(reason: Reason, line: u64, column: impl Into<String>, message: impl Into<String>) -> Self {
        RowError { reason, line, column: column.into(), message: message.into() }
    }
}

/// Collects the refused rows of one file under the chosen policy.
pub(crate) struct Problems {
    pub file: String,
    policy: OnError,
    pub rows_read: usize,
    by_reason: BTreeMap<Reason, ReasonCount>,
    /// Unit mix-ups per column: count and the first one, to refuse a whole column declared in
    /// the wrong unit even under `skip`.
    units: BTreeMap<String, (usize, RowError)>,
}

impl Problems {
    pub fn new(file: &str, policy: OnError) -> Self {
        Problems { file: file.to_string(), policy, rows_read: 0, by_reason: BTreeMap::new(), units: BTreeMap::new() }
    }

    /// Fail with an error naming the place, or count the row as skipped.
    pub fn reject(&mut self, e: RowError) -> Result<(), TrainerError> {
        if self.policy == OnError::Fail {
            let hint = match e.reason {
                Reason::UnitMismatch => "",
                _ => " (--on-error skip leaves such rows out and counts them)",
            };
            return Err(TrainerError::data(&self.file, e.line, &e.column, format!("{}{hint}", e.message)));
        }
        let c = self.by_reason.entry(e.reason).or_default();
        c.count += 1;
        if c.first_lines.len() < FIRST_LINES {
            c.first_lines.push(e.line);
        }
        if e.reason == Reason::UnitMismatch {
            self.units.entry(e.column.clone()).or_insert((0, e)).0 += 1;
        }
        Ok(())
    }

    /// Under `skip`, a column whose values mostly fail the unit check is declared in the wrong
    /// unit: refuse it rather than skip most of the file.
    pub(crate) fn refuse_wrong_unit_columns(&self) -> Result<(), TrainerError> {
        for (count, first) in self.units.values() {
            if *count * 2 > self.rows_read {
                return Err(TrainerError::data(
                    &self.file,
                    first.line,
                    &first.column,
                    format!(
                        "{} of {} rows fail the unit check, so the column is declared in the wrong unit; first: {}",
                        count, self.rows_read, first.message
                    ),
                ));
            }
        }
        Ok(())
    }

    pub fn skipped(&self) -> usize {
        self.by_reason.values().map(|c| c.count).sum()
    }

    pub fn summary(&self) -> FileSkips {
        FileSkips {
            file: self.file.clone(),
            rows_read: self.rows_read,
            rows_skipped: self.skipped(),
            by_reason: self.by_reason.clone(),
        }
    }
}

/// Under `--on-error skip`, a file that loses more than `max` of its rows is not imported: so
/// large a loss means a wrong map or a damaged export, not a few bad rows.
pub(super) fn refuse_too_many_skipped(skips: &[FileSkips], max: f64) -> Result<(), TrainerError> {
    for f in skips {
        if f.rows_read == 0 || (f.rows_skipped as f64) <= max * f.rows_read as f64 {
            continue;
        }
        let reasons: Vec<String> = f
            .by_reason
            .iter()
            .map(|(r, c)| {
                let lines: Vec<String> = c.first_lines.iter().map(u64::to_string).collect();
                let more = if c.count > c.first_lines.len() { ", …" } else { "" };
                format!("{} × {} (lines {}{more})", c.count, r.as_str(), lines.join(", "))
            })
            .collect();
        return Err(TrainerError::Config {
            origin: f.file.clone(),
            key: "--max-skipped".into(),
            message: format!(
                "{} of {} rows ({:.1} %) would be skipped as bad, more than the {} % allowed: {}; nothing written (fix the export or the map, or raise --max-skipped)",
                f.rows_skipped,
                f.rows_read,
                100.0 * f.rows_skipped as f64 / f.rows_read as f64,
                100.0 * max,
                reasons.join(", ")
            ),
        });
    }
    Ok(())
}
