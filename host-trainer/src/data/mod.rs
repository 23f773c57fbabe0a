//! A time series of measured inputs and reference measurands, and its CSV form (DESIGN §3):
//! `t_s`, the reference columns (measurands, [`measurand`]), `T_amb_C`, `dl1_pm..dlN_pm`,
//! `split` — the paper's file is `t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split`.
//!
//! The header says everything: the gratings are the `dlN_pm` columns (1 to 8, numbered without
//! holes), the measurands the reference columns it names (`T_C`, `strain_ue`, `strain2_ue`,
//! `p_kPa`, `T2_C`, ...; at most 4), the ambient thermometer `T_amb_C` when the
//! installation has one. Columns are found by name in any order, other columns are ignored,
//! and the writer puts them in the canonical order (measurands by kind T, ε, p, then index).
//! An empty reference cell is a missing reference at that time, an empty `dlN_pm` cell is a
//! gap (a peak the interrogator did not report), and so is an empty `T_amb_C`. Text that is
//! not a number, or a non-finite number, is an error naming file, line and column.
//!
//! A model fitted on a dataset takes its dimensions from it ([`Dataset::dims`]): N gratings,
//! the ambient input when `T_amb_C` is there, and one output per reference column in
//! canonical order, so output `c` of such a model is reference `c` ([`Dataset::target`]).
//! A model run over another record finds its references by measurand
//! ([`Dataset::reference_of`]).

pub mod files;
pub mod import;
pub mod measurand;
pub mod outliers;
pub mod record_meta;
pub mod units;

use std::path::Path;

use fbg_shared::layout::Dims;
use fbg_shared::Sample;

use crate::data::files::write_atomically;
use crate::data::measurand::{grating_column, parse_grating_column};
pub use crate::data::measurand::{Kind, Measurand, MAX_GRATINGS, MAX_MEASURANDS};
pub use crate::data::record_meta::{GratingZero, RecordMeta};
use crate::data::units::{check_ambient, check_wavelength, WlUnit};
use crate::error::TrainerError;

/// Appended to a unit-check message on a dataset CSV: the check and its words are `import`'s.
const REIMPORT: &str =
    " (the unit check of `fbg-trainer import`: convert the column, or re-import the export with that map key)";

/// The paper's CSV header, in column order.
pub const COLUMNS: [&str; 9] = ["t_s", "T_C", "strain_ue", "p_kPa", "T_amb_C", "dl1_pm", "dl2_pm", "dl3_pm", "split"];

/// The ambient thermometer's column.
pub const T_AMB_COLUMN: &str = "T_amb_C";

/// Which part of the record a sample belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Split {
    Cal,
    Holdout,
}

impl Split {
    pub fn as_str(self) -> &'static str {
        match self {
            Split::Cal => "cal",
            Split::Holdout => "holdout",
        }
    }
}

/// One reference column: what it measures and its values (NaN where missing).
#[derive(Clone, Debug, PartialEq)]
pub struct Reference {
    pub measurand: Measurand,
    pub values: Vec<f64>,
}

/// What a dataset carries: gratings, measurands, ambient thermometer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Number of gratings (`dl1_pm..dlN_pm`).
    pub gratings: usize,
    /// Reference columns, in canonical order (empty for a field record).
    pub measurands: Vec<Measurand>,
    /// Whether the ambient thermometer `T_amb_C` is there.
    pub ambient: bool,
}

impl std::fmt::Display for Shape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let g = match self.gratings {
            1 => "1 grating (dl1_pm)".to_string(),
            2 => "2 gratings (dl1_pm, dl2_pm)".to_string(),
            n => format!("{n} gratings (dl1_pm..dl{n}_pm)"),
        };
        let m = if self.measurands.is_empty() {
            "no reference columns".to_string()
        } else {
            let names: Vec<String> = self.measurands.iter().map(|m| m.column()).collect();
            format!("measurands {}", names.join(", "))
        };
        let a = if self.ambient { "ambient T_amb_C" } else { "no ambient thermometer (T_amb_C)" };
        write!(f, "{g}, {m}, {a}")
    }
}

/// A reference column ([`Dataset::target`], [`Dataset::reference_of`]): the values, or NaN at
/// every row for a reference the dataset does not have.
#[derive(Clone, Copy, Debug)]
pub struct Column<'a>(Option<&'a [f64]>);

impl<'a> Column<'a> {
    /// The values; empty for an absent reference.
    pub fn as_slice(&self) -> &'a [f64] {
        self.0.unwrap_or(&[])
    }
    /// Whether the dataset has the reference.
    pub fn is_present(&self) -> bool {
        self.0.is_some()
    }
}

impl std::ops::Index<usize> for Column<'_> {
    type Output = f64;
    fn index(&self, i: usize) -> &f64 {
        match self.0 {
            Some(v) => &v[i],
            None => &f64::NAN,
        }
    }
}

/// Column-oriented samples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Dataset {
    /// Time since the start \[s\].
    pub t_s: Vec<f64>,
    /// Reference measurands, in canonical order (sorted by [`Measurand`]), at most
    /// [`MAX_MEASURANDS`]; empty for a field record without references.
    pub refs: Vec<Reference>,
    /// Ambient thermometer reading [°C]; `None` for an installation without one.
    pub t_amb_c: Option<Vec<f64>>,
    /// Measured wavelength shifts \[pm\] per grating (1 to [`MAX_GRATINGS`]).
    pub dl_pm: Vec<Vec<f64>>,
    pub split: Vec<Split>,
    /// Each grating's zero (λ_ref) and the absolute time of `t_s = 0`, when known (written as
    /// comment lines before the CSV header, [`record_meta`]).
    pub meta: RecordMeta,
}

impl Dataset {
    pub fn len(&self) -> usize {
        self.t_s.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }
    /// Number of gratings.
    pub fn n_gratings(&self) -> usize {
        self.dl_pm.len()
    }
    /// The measurands, in canonical order.
    pub fn measurands(&self) -> Vec<Measurand> {
        self.refs.iter().map(|r| r.measurand).collect()
    }
    /// The values of measurand `m`, if the dataset has that reference.
    pub fn reference(&self, m: Measurand) -> Option<&[f64]> {
        self.refs.iter().find(|r| r.measurand == m).map(|r| r.values.as_slice())
    }
    /// The values of measurand `m` to change, if the dataset has that reference.
    pub fn reference_mut(&mut self, m: Measurand) -> Option<&mut Vec<f64>> {
        self.refs.iter_mut().find(|r| r.measurand == m).map(|r| &mut r.values)
    }
    /// Remove the reference `m` (it becomes absent, not fitted); true if it was there.
    pub fn remove_reference(&mut self, m: Measurand) -> bool {
        let before = self.refs.len();
        self.refs.retain(|r| r.measurand != m);
        self.refs.len() != before
    }
    /// Gratings, measurands and ambient thermometer.
    pub fn shape(&self) -> Shape {
        Shape { gratings: self.n_gratings(), measurands: self.measurands(), ambient: self.t_amb_c.is_some() }
    }
    /// Put the references in canonical order (what the writer and the accessors expect).
    pub fn sort_refs(&mut self) {
        self.refs.sort_by_key(|r| r.measurand);
    }

    /// The dimensions of a model fitted on this dataset: its gratings, the ambient input when
    /// the dataset has `T_amb_C`, and its measurands in canonical order. A dataset without a
    /// reference column is an error naming `origin` (nothing to fit).
    pub fn dims(&self, origin: &str) -> Result<Dims, TrainerError> {
        if self.refs.is_empty() {
            return Err(TrainerError::data(
                origin,
                1,
                "T_C",
                "no reference column (T_C, strain_ue, p_kPa, T2_C, strain2_ue, ...): nothing to calibrate against (a record without references is for `compensate`)",
            ));
        }
        let outputs: Vec<_> = self.refs.iter().map(|r| r.measurand.output()).collect();
        Dims::new(self.n_gratings(), self.t_amb_c.is_some(), &outputs)
            .map_err(|e| TrainerError::data(origin, 1, "-", format!("the data have {}: {e}", self.shape())))
    }

    /// `Ok` when the dataset carries the inputs of a model of `dims` (its N gratings, and the
    /// ambient thermometer when the model reads it; references do not matter); otherwise an
    /// error naming `origin`, the first missing column, what the data have and what the model
    /// needs.
    pub fn inputs_for(&self, dims: &Dims, origin: &str, command: &str) -> Result<(), TrainerError> {
        let n = dims.gratings();
        let column = if self.n_gratings() != n {
            grating_column(self.n_gratings().min(n) + 1)
        } else if dims.ambient() && self.t_amb_c.is_none() {
            T_AMB_COLUMN.to_string()
        } else {
            return Ok(());
        };
        let needs = match (n, dims.ambient()) {
            (1, a) => format!("1 grating (dl1_pm){}", if a { " and the ambient thermometer T_amb_C" } else { "" }),
            (n, a) => format!(
                "{n} gratings (dl1_pm..dl{n}_pm){}",
                if a { " and the ambient thermometer T_amb_C" } else { "" }
            ),
        };
        Err(TrainerError::data(
            origin,
            1,
            &column,
            format!("the data have {}; `{command}` runs a model whose inputs are {needs}", self.shape()),
        ))
    }

    /// The ambient readings; empty when the installation has no thermometer.
    pub fn ambient(&self) -> &[f64] {
        self.t_amb_c.as_deref().unwrap_or(&[])
    }

    /// The model inputs of sample `i`: every grating's shift and the ambient reading (NaN
    /// without one).
    pub fn sample(&self, i: usize) -> Sample<f64> {
        // Built in place (every compensator pass reads each row through here).
        let mut s = Sample {
            dl_pm: [0.0; MAX_GRATINGS],
            gratings: self.n_gratings().min(MAX_GRATINGS) as u8,
            t_amb_c: self.t_amb_c.as_ref().map_or(f64::NAN, |a| a[i]),
            t_s: self.t_s[i],
        };
        for (o, c) in s.dl_pm.iter_mut().zip(&self.dl_pm) {
            *o = c[i];
        }
        s
    }
    /// The reference measurands of sample `i`, in canonical order.
    pub fn truth(&self, i: usize) -> Vec<f64> {
        self.refs.iter().map(|r| r.values[i]).collect()
    }
    /// Reference `c` in canonical order: output `c` of a model fitted on this dataset
    /// ([`Dataset::dims`]); indexing it gives NaN at every row beyond the references.
    pub fn target(&self, c: usize) -> Column<'_> {
        Column(self.refs.get(c).map(|r| r.values.as_slice()))
    }
    /// The reference of output `c` of a model of `dims`, found by measurand (NaN at every row
    /// when the dataset does not have it).
    pub fn reference_of(&self, dims: &Dims, c: usize) -> Column<'_> {
        Column(dims.outputs().get(c).and_then(|&o| self.reference(Measurand::of_output(o))))
    }
    /// The references of every output of a model of `dims`, found by measurand ([`Column`]s
    /// that read NaN where the dataset lacks one).
    pub fn references_of(&self, dims: &Dims) -> Vec<Column<'_>> {
        (0..dims.n_outputs()).map(|c| self.reference_of(dims, c)).collect()
    }
    /// Indices of the calibration samples.
    pub fn cal_indices(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.split[i] == Split::Cal).collect()
    }
    /// True when sample `i` can be used for fitting: finite inputs and every available
    /// reference present.
    pub fn usable(&self, i: usize) -> bool {
        self.dl_pm.iter().all(|c| c[i].is_finite())
            && self.t_amb_c.as_ref().is_none_or(|a| a[i].is_finite())
            && self.t_s[i].is_finite()
            && self.refs.iter().all(|r| r.values[i].is_finite())
    }
    /// Assign the split by time: samples with `t_s <= cal_until_s` calibrate, later ones are
    /// the hold-out.
    pub fn split_at_time(&mut self, cal_until_s: f64) {
        for (s, &t) in self.split.iter_mut().zip(&self.t_s) {
            *s = if t <= cal_until_s { Split::Cal } else { Split::Holdout };
        }
    }
    /// Assign the split by fraction of the record's duration.
    pub fn split_at_fraction(&mut self, fraction: f64) {
        let (t0, t1) = (self.t_s.first().copied().unwrap_or(0.0), self.t_s.last().copied().unwrap_or(0.0));
        self.split_at_time(t0 + fraction * (t1 - t0));
    }
    /// The band's clock for a model run over this record as over its own calibration record
    /// (`evaluate`, `stream`, the studies): absolute when the record and the model both know
    /// absolute time, else the calibration clock (this record's `t_s` is the model's).
    pub fn calibration_clock<F: fbg_shared::Real, const K: usize>(
        &self,
        model: &fbg_shared::ModelParams<F, K>,
    ) -> fbg_shared::StreamClock {
        match (self.meta.t0_unix_s, model.field.cal_end_unix_s) {
            (Some(t0), Some(_)) => fbg_shared::StreamClock::StartUnix(t0),
            _ => fbg_shared::StreamClock::Calibration,
        }
    }

    /// The band's clock for a field record (`compensate`): absolute when the record knows its
    /// start, else unknown (the band then takes the model's largest validated lead and every
    /// estimate says the lead is unknown).
    pub fn field_clock(&self) -> fbg_shared::StreamClock {
        self.meta.t0_unix_s.map_or(fbg_shared::StreamClock::Unknown, fbg_shared::StreamClock::StartUnix)
    }

    /// Indices of the hold-out samples.
    pub fn holdout_indices(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.split[i] == Split::Holdout).collect()
    }
    /// A new dataset with the rows `idx`, in that order.
    pub fn select(&self, idx: &[usize]) -> Dataset {
        let pick = |v: &Vec<f64>| idx.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        Dataset {
            t_s: pick(&self.t_s),
            refs: self.refs.iter().map(|r| Reference { measurand: r.measurand, values: pick(&r.values) }).collect(),
            t_amb_c: self.t_amb_c.as_ref().map(pick),
            dl_pm: self.dl_pm.iter().map(pick).collect(),
            split: idx.iter().map(|&i| self.split[i]).collect(),
            meta: self.meta.clone(),
        }
    }

    /// The CSV header this dataset writes, in canonical order.
    pub fn header(&self) -> Vec<String> {
        let mut refs: Vec<Measurand> = self.measurands();
        refs.sort();
        let mut head = vec!["t_s".to_string()];
        head.extend(refs.iter().map(|m| m.column()));
        if self.t_amb_c.is_some() {
            head.push(T_AMB_COLUMN.into());
        }
        head.extend((1..=self.n_gratings()).map(grating_column));
        head.push("split".into());
        head
    }

    /// Write the CSV atomically: a temporary file in the target directory, renamed into place
    /// only when complete. Columns in canonical order ([`header`](Self::header)).
    pub fn write_csv(&self, path: &Path) -> Result<(), TrainerError> {
        write_atomically(path, |w| self.write_csv_to(w))
    }

    /// Write the CSV to `w` (as [`write_csv`](Self::write_csv) writes the file): for a caller
    /// that stages it in an output set with other files.
    pub fn write_csv_to(&self, w: &mut impl std::io::Write) -> std::io::Result<()> {
        // A missing value (gap) is an empty cell.
        fn cell(line: &mut String, v: f64) {
            use std::fmt::Write as _;
            line.push(',');
            if v.is_finite() {
                let _ = write!(line, "{v:.6}");
            }
        }
        let mut order: Vec<usize> = (0..self.refs.len()).collect();
        order.sort_by_key(|&k| self.refs[k].measurand);
        let head = self.header();
        {
            for l in self.meta.comment_lines() {
                writeln!(w, "{l}")?;
            }
            writeln!(w, "{}", head.join(","))?;
            let mut line = String::with_capacity(128);
            for i in 0..self.len() {
                line.clear();
                // Microseconds: enough for kHz interrogators.
                line.push_str(&format!("{:.6}", self.t_s[i]));
                for &k in &order {
                    cell(&mut line, self.refs[k].values[i]);
                }
                if let Some(a) = &self.t_amb_c {
                    cell(&mut line, a[i]);
                }
                for g in &self.dl_pm {
                    cell(&mut line, g[i]);
                }
                line.push(',');
                line.push_str(self.split[i].as_str());
                writeln!(w, "{line}")?;
            }
            Ok(())
        }
    }

    /// Read a dataset CSV (any column order, other columns ignored). `t_s` and `dl1_pm` are
    /// required; further gratings, the references, `T_amb_C` and `split` are optional (without
    /// `split` every row is calibration until the caller assigns a split), but at least one
    /// reference must be there to calibrate or evaluate against. Errors name the file, line
    /// and column.
    pub fn read_csv(path: &Path) -> Result<Dataset, TrainerError> {
        Self::read_csv_with(path, true)
    }

    /// [`read_csv`](Self::read_csv) for fitting (`train`): the rows after the last calibration
    /// row are dropped once read, since a fit never reads them (the compensator's stream that
    /// feeds it ends there; hold-out rows between calibration rows stay, the stream runs
    /// through them). What is held per row is the columns as f64 and the split (65 bytes for
    /// the paper's shape).
    pub fn read_calibration_csv(path: &Path) -> Result<Dataset, TrainerError> {
        let mut d = Self::read_csv_with(path, true)?;
        let end = d.split.iter().rposition(|&s| s == Split::Cal).map_or(0, |i| i + 1);
        if end < d.len() {
            let keep = |v: &mut Vec<f64>| {
                v.truncate(end);
                v.shrink_to_fit();
            };
            keep(&mut d.t_s);
            d.refs.iter_mut().for_each(|r| keep(&mut r.values));
            if let Some(a) = d.t_amb_c.as_mut() {
                keep(a);
            }
            d.dl_pm.iter_mut().for_each(keep);
            d.split.truncate(end);
            d.split.shrink_to_fit();
        }
        Ok(d)
    }

    /// [`read_csv`](Self::read_csv) for a field record to compensate: references are welcome
    /// (the errors are then reported) but none is needed.
    pub fn read_field_csv(path: &Path) -> Result<Dataset, TrainerError> {
        Self::read_csv_with(path, false)
    }

    /// The columns and metadata of a dataset CSV without its rows (as
    /// [`RowReader::header_dataset`]), refused like [`read_csv`](Self::read_csv) when it has no
    /// reference column.
    pub fn read_csv_header(path: &Path) -> Result<Dataset, TrainerError> {
        let rows = RowReader::open(path)?;
        let d = rows.header_dataset();
        if d.refs.is_empty() {
            return Err(no_reference(&rows.name));
        }
        Ok(d)
    }

    /// The rows of a dataset CSV up to and including the first one for which `stop` is true
    /// (every row when none is), with the row checks of [`read_csv`](Self::read_csv): a bounded
    /// read for what needs only the start of a long record. The whole-file checks of
    /// [`RowReader::finish`] are the caller's (they need every row).
    pub fn read_csv_prefix(path: &Path, mut stop: impl FnMut(&Row) -> bool) -> Result<Dataset, TrainerError> {
        let mut rows = RowReader::open(path)?;
        let mut d = rows.header_dataset();
        while let Some(r) = rows.next_row()? {
            d.push_row(&r);
            if stop(&r) {
                break;
            }
        }
        Ok(d)
    }

    fn read_csv_with(path: &Path, need_reference: bool) -> Result<Dataset, TrainerError> {
        let mut rows = RowReader::open(path)?;
        let mut d = rows.header_dataset();
        while let Some(r) = rows.next_row()? {
            d.push_row(&r);
        }
        rows.finish()?;
        if need_reference && d.refs.is_empty() {
            return Err(no_reference(&rows.name));
        }
        Ok(d)
    }

    /// Append one row read by [`RowReader`] (its columns are this dataset's).
    fn push_row(&mut self, r: &Row) {
        self.t_s.push(r.t_s);
        for (c, v) in self.refs.iter_mut().zip(&r.refs) {
            c.values.push(*v);
        }
        if let Some(a) = self.t_amb_c.as_mut() {
            a.push(r.t_amb_c);
        }
        for (c, v) in self.dl_pm.iter_mut().zip(&r.dl_pm) {
            c.push(*v);
        }
        self.split.push(r.split);
    }
}

fn no_reference(name: &str) -> TrainerError {
    TrainerError::data(
        name,
        1,
        "T_C",
        "no reference column (T_C, strain_ue, p_kPa, T2_C, strain2_ue, ...): nothing to calibrate against (a record without references is for `compensate`)",
    )
}

/// The longest line a dataset CSV may have \[bytes\], its `\n` excluded (a `\r` before it counts): far beyond any row of
/// numbers, and the most a reader holds of one line (a longer one is refused as it is read).
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// Characters of a cell an error message quotes; the rest is elided.
pub const QUOTE_CHARS: usize = 40;

/// A cell as an error message quotes it: at most [`QUOTE_CHARS`] characters, then `…` and the
/// cell's length.
pub fn quote_cell(cell: &str) -> String {
    match cell.char_indices().nth(QUOTE_CHARS) {
        None => cell.to_string(),
        Some((cut, _)) => format!("{}… ({} bytes)", &cell[..cut], cell.len()),
    }
}

/// A line of [`MAX_LINE_BYTES`] bytes and more, found by [`LineLimit`] (physical line number,
/// 1-based).
#[derive(Debug)]
struct LineTooLong {
    line: u64,
}

impl std::fmt::Display for LineTooLong {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "line {} is longer than {} bytes (the limit of a dataset line)", self.line, MAX_LINE_BYTES)
    }
}

impl std::error::Error for LineTooLong {}

/// A reader that fails as soon as a line grows past [`MAX_LINE_BYTES`], so that nothing above
/// it ever holds more of one line than that.
struct LineLimit<R> {
    inner: R,
    /// Bytes of the current line so far.
    run: usize,
    /// Physical line number of the current line (1-based).
    line: u64,
}

impl<R> LineLimit<R> {
    fn new(inner: R) -> Self {
        LineLimit { inner, run: 0, line: 1 }
    }
}

impl<R: std::io::Read> std::io::Read for LineLimit<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        for &b in &buf[..n] {
            if b == b'\n' {
                self.run = 0;
                self.line += 1;
            } else {
                self.run += 1;
                if self.run > MAX_LINE_BYTES {
                    return Err(std::io::Error::new(std::io::ErrorKind::InvalidData, LineTooLong { line: self.line }));
                }
            }
        }
        Ok(n)
    }
}

/// The [`LineTooLong`] inside an I/O error, if that is what it is.
fn line_too_long(e: &std::io::Error) -> Option<&LineTooLong> {
    e.get_ref().and_then(|i| i.downcast_ref::<LineTooLong>())
}

/// The error of a line over [`MAX_LINE_BYTES`].
fn line_error(name: &str, l: &LineTooLong) -> TrainerError {
    TrainerError::data(
        name,
        l.line,
        "-",
        format!("the line is longer than {MAX_LINE_BYTES} bytes (1 MiB, the limit of a dataset line): refused unread (not a dataset row?)"),
    )
}

/// One data row of a dataset CSV as [`RowReader`] reads it: NaN for an empty cell (a gap, a
/// missing reference) and for a column the file does not have.
#[derive(Clone, Copy, Debug)]
pub struct Row {
    /// Line number in the file.
    pub line: u64,
    /// Time since the start \[s\].
    pub t_s: f64,
    /// The references in canonical order ([`RowReader::header_dataset`]); NaN beyond them.
    pub refs: [f64; MAX_MEASURANDS],
    /// Ambient thermometer [°C].
    pub t_amb_c: f64,
    /// Shifts \[pm\] of the gratings; NaN beyond them.
    pub dl_pm: [f64; MAX_GRATINGS],
    /// Number of gratings.
    pub gratings: u8,
    pub split: Split,
}

impl Row {
    /// The model inputs (as [`Dataset::sample`]).
    pub fn sample(&self) -> Sample<f64> {
        let mut dl_pm = [0.0; MAX_GRATINGS];
        for (o, &v) in dl_pm.iter_mut().zip(&self.dl_pm).take(usize::from(self.gratings)) {
            *o = v;
        }
        Sample { dl_pm, gratings: self.gratings, t_amb_c: self.t_amb_c, t_s: self.t_s }
    }

    /// True when the row can be used for fitting ([`Dataset::usable`]): finite inputs and
    /// every reference the file has (`n_refs`) present; `ambient`: the file has `T_amb_C`.
    pub fn usable(&self, n_refs: usize, ambient: bool) -> bool {
        self.dl_pm.iter().take(usize::from(self.gratings)).all(|v| v.is_finite())
            && (!ambient || self.t_amb_c.is_finite())
            && self.t_s.is_finite()
            && self.refs.iter().take(n_refs).all(|v| v.is_finite())
    }
}

/// Streaming reader of a dataset CSV: the comment lines' metadata and the header first, then
/// one row at a time with the checks and errors of [`Dataset::read_csv`]; it holds one row,
/// never more than [`MAX_LINE_BYTES`] of a line, and a few numbers per grating for the
/// whole-column checks of [`RowReader::finish`].
pub struct RowReader {
    /// The file's name in messages.
    pub name: String,
    rdr: csv::Reader<LineLimit<std::fs::File>>,
    headers: csv::StringRecord,
    layout: Layout,
    unit_keys: Vec<String>,
    meta: RecordMeta,
    rec: csv::StringRecord,
    file_len: u64,
    ends_with_newline: bool,
    prev_t: Option<f64>,
    first_line: u64,
    rows: usize,
    /// Per grating: whether the column looks like absolute wavelengths so far.
    abs_nm: Vec<units::AbsNmCheck>,
}

impl RowReader {
    /// Open a dataset CSV and read its metadata and header.
    pub fn open(path: &Path) -> Result<RowReader, TrainerError> {
        let name = path.display().to_string();
        let mut file = std::fs::File::open(path).map_err(|e| TrainerError::io(path, e))?;
        let file_len = file.metadata().map_err(|e| TrainerError::io(path, e))?.len();
        let ends_with_newline = last_byte(&mut file).map_err(|e| TrainerError::io(path, e))? == Some(b'\n');
        let meta = read_meta(&mut file, &name)?;
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(LineLimit::new(file));
        let headers = match rdr.headers() {
            Ok(h) => h.clone(),
            Err(e) => {
                if let csv::ErrorKind::Io(io) = e.kind() {
                    if let Some(l) = line_too_long(io) {
                        return Err(line_error(&name, l));
                    }
                }
                return Err(TrainerError::data(&name, 1, "-", format!("cannot read the header: {e}")));
            }
        };
        let layout = Layout::of(&headers).map_err(|(col, m)| TrainerError::data(&name, 1, &quote_cell(&col), m))?;
        let n_g = layout.gratings.len();
        Ok(RowReader {
            name,
            rdr,
            headers,
            unit_keys: (1..=n_g).map(|g| format!("grating[{g}].unit")).collect(),
            abs_nm: vec![units::AbsNmCheck::default(); n_g],
            layout,
            meta,
            rec: csv::StringRecord::new(),
            file_len,
            ends_with_newline,
            prev_t: None,
            first_line: 0,
            rows: 0,
        })
    }

    /// The record's metadata (comment lines).
    pub fn meta(&self) -> &RecordMeta {
        &self.meta
    }

    /// A dataset with this file's columns and metadata and no rows: what the header says
    /// ([`Dataset::shape`], [`Dataset::inputs_for`], [`Dataset::reference_of`] work on it).
    pub fn header_dataset(&self) -> Dataset {
        Dataset {
            refs: self.layout.refs.iter().map(|&(m, _)| Reference { measurand: m, values: Vec::new() }).collect(),
            t_amb_c: self.layout.ambient.map(|_| Vec::new()),
            dl_pm: vec![Vec::new(); self.layout.gratings.len()],
            meta: self.meta.clone(),
            ..Dataset::default()
        }
    }

    /// Rows read so far.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Bytes of the file read so far (for progress).
    pub fn byte_position(&self) -> u64 {
        self.rdr.position().byte()
    }

    /// The file's length \[bytes\].
    pub fn file_len(&self) -> u64 {
        self.file_len
    }

    /// The next data row, `None` at the end; errors name the file, line and column.
    pub fn next_row(&mut self) -> Result<Option<Row>, TrainerError> {
        let name = self.name.as_str();
        let more = self.rdr.read_record(&mut self.rec).map_err(|e| {
            if let csv::ErrorKind::Io(io) = e.kind() {
                if let Some(l) = line_too_long(io) {
                    return line_error(name, l);
                }
            }
            let line = e.position().map(|p| p.line()).unwrap_or(0);
            TrainerError::data(name, line, "-", format!("malformed row: {}", quote_cell(&e.to_string())))
        })?;
        if !more {
            return Ok(None);
        }
        let (rec, headers, layout) = (&self.rec, &self.headers, &self.layout);
        let line = rec.position().map(|p| p.line()).unwrap_or(0);
        if self.first_line == 0 {
            self.first_line = line;
        }
        if !self.ends_with_newline && self.rdr.position().byte() >= self.file_len {
            // The file ends inside this row, so its last cell may be cut short
            // (`1545.0440` read as `1545.04`): `ragged_row`, as `import` says.
            let last = headers.get(rec.len().saturating_sub(1)).unwrap_or("-");
            return Err(TrainerError::data(
                name,
                line,
                &quote_cell(last),
                format!(
                    "truncated last row (no line end): the file ends inside this row, so its last cell `{}` may be cut short (ragged_row)",
                    quote_cell(rec.get(rec.len().saturating_sub(1)).unwrap_or(""))
                ),
            ));
        }
        // `blank_ok`: an empty cell is a missing value (NaN) rather than an error.
        let num = |c: usize, blank_ok: bool| -> Result<f64, TrainerError> {
            let col = headers.get(c).unwrap_or("-");
            let cell = rec.get(c).ok_or_else(|| {
                TrainerError::data(
                    name,
                    line,
                    &quote_cell(col),
                    format!("row has {} cells, column `{}` is number {}", rec.len(), quote_cell(col), c + 1),
                )
            })?;
            if cell.is_empty() {
                return if blank_ok { Ok(f64::NAN) } else { Err(TrainerError::data(name, line, col, "empty cell")) };
            }
            let v: f64 = cell
                .parse()
                .map_err(|_| TrainerError::data(name, line, col, format!("`{}` is not a number", quote_cell(cell))))?;
            if !v.is_finite() {
                return Err(TrainerError::data(name, line, col, format!("`{}` is not finite", quote_cell(cell))));
            }
            Ok(v)
        };
        let t = num(layout.t_s, false)?;
        if let Some(prev) = self.prev_t {
            if t <= prev {
                return Err(TrainerError::data(
                    name,
                    line,
                    "t_s",
                    format!("time does not increase ({t} after {prev})"),
                ));
            }
        }
        let mut row = Row {
            line,
            t_s: t,
            refs: [f64::NAN; MAX_MEASURANDS],
            t_amb_c: f64::NAN,
            dl_pm: [f64::NAN; MAX_GRATINGS],
            gratings: layout.gratings.len() as u8,
            split: Split::Cal,
        };
        for (r, &(_, c)) in row.refs.iter_mut().zip(&layout.refs) {
            *r = num(c, true)?;
        }
        // An empty ambient reading is a gap like an empty dl cell (not fitted, flagged).
        // Magnitudes get the unit checks of `import` (kelvin for °C, nm or absolute
        // wavelengths for shifts in pm), with its messages.
        if let Some(c) = layout.ambient {
            let amb = num(c, true)?;
            if amb.is_finite() {
                check_ambient(amb)
                    .map_err(|m| TrainerError::data(name, line, T_AMB_COLUMN, format!("{m}{REIMPORT}")))?;
            }
            row.t_amb_c = amb;
        }
        for (g, &c) in layout.gratings.iter().enumerate() {
            let v = num(c, true)?;
            if v.is_finite() {
                check_wavelength(WlUnit::ShiftPm, v, &self.unit_keys[g])
                    .map_err(|m| TrainerError::data(name, line, &grating_column(g + 1), format!("{m}{REIMPORT}")))?;
            }
            row.dl_pm[g] = v;
            self.abs_nm[g].push(v);
        }
        if let Some(c) = layout.split {
            row.split = match rec.get(c).unwrap_or("") {
                "cal" => Split::Cal,
                "holdout" => Split::Holdout,
                other => {
                    return Err(TrainerError::data(
                        name,
                        line,
                        "split",
                        format!("`{}` is neither `cal` nor `holdout`", quote_cell(other)),
                    ))
                }
            };
        }
        self.prev_t = Some(t);
        self.rows += 1;
        Ok(Some(row))
    }

    /// The checks on the whole file, after its last row: at least one row, and no shift
    /// column that holds absolute wavelengths.
    pub fn finish(&self) -> Result<(), TrainerError> {
        if self.rows == 0 {
            return Err(TrainerError::data(&self.name, 2, "-", "no data rows"));
        }
        for (g, (a, key)) in self.abs_nm.iter().zip(&self.unit_keys).enumerate() {
            if a.looks_absolute_nm() {
                return Err(TrainerError::data(
                    &self.name,
                    self.first_line,
                    &grating_column(g + 1),
                    format!("{}{REIMPORT}", a.message(key)),
                ));
            }
        }
        Ok(())
    }
}

/// Where the dataset columns are in a header (0-based cell indices).
struct Layout {
    t_s: usize,
    /// Canonical order.
    refs: Vec<(Measurand, usize)>,
    ambient: Option<usize>,
    /// dl1_pm, dl2_pm, ... in order.
    gratings: Vec<usize>,
    split: Option<usize>,
}

impl Layout {
    /// Classify the header's columns by name; the error is (column, message).
    fn of(headers: &csv::StringRecord) -> Result<Layout, (String, String)> {
        let mut t_s = None;
        let mut refs: Vec<(Measurand, usize)> = Vec::new();
        let mut ambient = None;
        let mut gratings: Vec<(usize, usize)> = Vec::new();
        let mut split = None;
        let dup = |h: &str| (h.to_string(), format!("column `{}` appears twice in the header", quote_cell(h)));
        for (c, h) in headers.iter().enumerate() {
            let set = |slot: &mut Option<usize>| if slot.replace(c).is_some() { Err(dup(h)) } else { Ok(()) };
            match h {
                "t_s" => set(&mut t_s)?,
                T_AMB_COLUMN => set(&mut ambient)?,
                "split" => set(&mut split)?,
                _ => {
                    if let Some(m) =
                        Measurand::parse(h).map_err(|e| (h.to_string(), format!("column `{}`: {e}", quote_cell(h))))?
                    {
                        if refs.iter().any(|&(o, _)| o == m) {
                            return Err(dup(h));
                        }
                        refs.push((m, c));
                    } else if let Some(g) = parse_grating_column(h)
                        .map_err(|e| (h.to_string(), format!("column `{}`: {e}", quote_cell(h))))?
                    {
                        if gratings.iter().any(|&(o, _)| o == g) {
                            return Err(dup(h));
                        }
                        gratings.push((g, c));
                    }
                }
            }
        }
        let required = "required: t_s and the gratings dl1_pm..dlN_pm (N from 1 to 8); optional: T_amb_C, the references (T_C, strain_ue, p_kPa, T2_C, strain2_ue, ...), split";
        let Some(t_s) = t_s else { return Err(("t_s".into(), format!("missing column `t_s` ({required})"))) };
        gratings.sort();
        for (k, &(g, _)) in gratings.iter().enumerate() {
            if g != k + 1 {
                let want = grating_column(k + 1);
                return Err((want.clone(), format!("missing column `{want}` while `{}` is there: gratings are numbered dl1_pm..dlN_pm without holes", grating_column(g))));
            }
        }
        if gratings.is_empty() {
            return Err(("dl1_pm".into(), format!("missing column `dl1_pm` ({required})")));
        }
        refs.sort();
        if refs.len() > MAX_MEASURANDS {
            let names: Vec<String> = refs.iter().map(|(m, _)| m.column()).collect();
            return Err((
                refs[MAX_MEASURANDS].0.column(),
                format!(
                    "{} reference columns ({}); at most {MAX_MEASURANDS} measurands are supported",
                    refs.len(),
                    names.join(", ")
                ),
            ));
        }
        Ok(Layout { t_s, refs, ambient, gratings: gratings.into_iter().map(|(_, c)| c).collect(), split })
    }
}

/// The record metadata in the comment lines at the top of a dataset CSV (errors name the
/// line); the read position is restored to the start.
fn read_meta(f: &mut std::fs::File, name: &str) -> Result<RecordMeta, TrainerError> {
    use std::io::{BufRead, BufReader, Seek, SeekFrom};
    let mut meta = RecordMeta::default();
    let mut r = BufReader::new(LineLimit::new(&mut *f));
    let mut line = String::new();
    let mut n = 0u64;
    loop {
        line.clear();
        // A non-UTF-8 first line, or one over the line limit, is the CSV reader's to report.
        if r.read_line(&mut line).unwrap_or(0) == 0 {
            break;
        }
        n += 1;
        let l = line.trim_start_matches('\u{feff}');
        if !l.starts_with('#') {
            break;
        }
        meta.read_comment(l.trim_end()).map_err(|m| TrainerError::data(name, n, "#", m))?;
        meta.comment_lines = n;
    }
    drop(r);
    f.seek(SeekFrom::Start(0)).map_err(|e| TrainerError::data(name, 1, "-", e.to_string()))?;
    Ok(meta)
}

/// The last byte of a file (`None` when empty); the read position is restored to the start.
fn last_byte(f: &mut std::fs::File) -> std::io::Result<Option<u8>> {
    use std::io::{Read, Seek, SeekFrom};
    let len = f.metadata()?.len();
    if len == 0 {
        return Ok(None);
    }
    let mut b = [0u8];
    f.seek(SeekFrom::Start(len - 1))?;
    f.read_exact(&mut b)?;
    f.seek(SeekFrom::Start(0))?;
    Ok(Some(b[0]))
}
