//! The dataset's CSV form: the writer, the whole-file readers, and the streaming
//! [`RowReader`] they are built on.

mod line_limit;
mod rows;

use std::path::Path;

use crate::data::files::{refuse_non_regular, OutputSet};
use crate::data::measurand::grating_column;
use crate::data::record_meta::{sidecar_path, Digesting, TableDigest};
use crate::data::{Dataset, Measurand, Split, T_AMB_COLUMN};
use crate::error::TrainerError;
pub use line_limit::MAX_LINE_BYTES;
pub use rows::{quote_cell, QUOTE_CHARS};
pub(crate) use rows::{Row, RowReader};

impl Dataset {
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

    /// Write the CSV and its sidecar `NAME.record.json` (the record's zero and clock,
    /// [`record_meta`](crate::data::record_meta)) as one output set: temporary files in the
    /// target directory, renamed into place only when both are complete, so neither is ever
    /// half-written nor left beside the other's old version. Columns in canonical order
    /// ([`header`](Self::header)).
    pub fn write_csv(&self, path: &Path) -> Result<(), TrainerError> {
        refuse_non_regular(path)?;
        let set = OutputSet::beside(path)?;
        self.stage_csv(&set, path)?;
        set.commit()
    }

    /// Stage the CSV `path` and its sidecar in `set` (as [`write_csv`](Self::write_csv)
    /// writes them): for a caller that writes them with other files.
    /// The sidecar records the CSV's length and digest as written ([`TableDigest`]), so that
    /// a reader knows a CSV rewritten since by another tool.
    pub fn stage_csv(&self, set: &OutputSet, path: &Path) -> Result<(), TrainerError> {
        let mut table = TableDigest::default();
        set.stage(path, |w| {
            use std::io::Write as _;
            let mut out = std::io::BufWriter::new(Digesting::new(w));
            self.write_csv_to(&mut out)?;
            out.flush()?;
            table = out.get_ref().digest().clone();
            Ok(())
        })?;
        set.stage_bytes(&sidecar_path(path), self.meta.sidecar_json(path, &table).as_bytes())
    }

    /// Write the CSV's table to `w` (one header line, then the rows; the sidecar is
    /// [`stage_csv`](Self::stage_csv)'s).
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
    ///
    /// ```
    /// use fbg_trainer::data::{Dataset, Measurand, Split};
    ///
    /// let dir = tempfile::tempdir()?;
    /// let path = dir.path().join("data.csv");
    /// std::fs::write(
    ///     &path,
    ///     "t_s,T_C,T_amb_C,dl1_pm,split\n0,20.0,19.5,1.5,cal\n1,20.1,19.5,,holdout\n",
    /// )?;
    /// let d = Dataset::read_csv(&path)?;
    /// assert_eq!((d.len(), d.n_gratings()), (2, 1));
    /// assert_eq!(d.measurands(), [Measurand::T]);
    /// assert_eq!(d.split, [Split::Cal, Split::Holdout]);
    /// assert!(d.dl_pm[0][1].is_nan(), "an empty cell is a gap");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
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

    /// The columns and metadata of a dataset CSV without its rows (as the streaming reader's
    /// header dataset), refused like [`read_csv`](Self::read_csv) when it has no
    /// reference column.
    pub fn read_csv_header(path: &Path) -> Result<Dataset, TrainerError> {
        let rows = RowReader::open(path)?;
        let d = rows.header_dataset();
        if d.refs.is_empty() {
            return Err(no_reference(&rows.name));
        }
        Ok(d)
    }

    /// The zero and clock of a dataset CSV (its sidecar's, or its older comment lines'),
    /// read with its header only.
    pub fn read_csv_meta(path: &Path) -> Result<crate::data::RecordMeta, TrainerError> {
        Ok(RowReader::open(path)?.header_dataset().meta)
    }

    /// The rows of a dataset CSV up to and including the first one for which `stop` is true
    /// (every row when none is), with the row checks of [`read_csv`](Self::read_csv): a bounded
    /// read for what needs only the start of a long record. The whole-file checks of
    /// [`RowReader::finish`] are the caller's (they need every row).
    pub(crate) fn read_csv_prefix(path: &Path, mut stop: impl FnMut(&Row) -> bool) -> Result<Dataset, TrainerError> {
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
