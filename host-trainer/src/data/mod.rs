//! A time series of measured inputs and reference measurands, and its CSV form (DESIGN §3):
//! `t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split`.
//!
//! For real data the reference columns `T_C`, `strain_ue`, `p_kPa` and the `split`
//! column are optional: an absent reference is an output that cannot be fitted, an empty cell
//! is a missing reference at that time, an empty `dlN_pm` cell is a gap (a peak the
//! interrogator did not report), and so is an empty `T_amb_C`. Text that is not a number, or a non-finite number, is still an
//! error naming file, line and column.

pub mod files;
pub mod import;
pub mod units;

use std::io::Write;
use std::path::Path;

use fbg_shared::Sample;

use crate::data::files::write_atomically;
use crate::data::units::{absolute_nm_column_message, check_ambient, check_wavelength, looks_absolute_nm, WlUnit};
use crate::error::TrainerError;

/// The import map keys of the three gratings' units (named in unit-check messages).
const UNIT_KEYS: [&str; 3] = ["grating[1].unit", "grating[2].unit", "grating[3].unit"];

/// Appended to a unit-check message on a dataset CSV: the check and its words are `import`'s.
const REIMPORT: &str =
    " (the unit check of `fbg-trainer import`: convert the column, or re-import the export with that map key)";

/// The CSV header, in column order.
pub const COLUMNS: [&str; 9] = ["t_s", "T_C", "strain_ue", "p_kPa", "T_amb_C", "dl1_pm", "dl2_pm", "dl3_pm", "split"];

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

/// Column-oriented samples.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Dataset {
    /// Time since the start \[s\].
    pub t_s: Vec<f64>,
    /// Reference temperature [°C].
    pub temp_c: Vec<f64>,
    /// Reference strain \[µε\].
    pub strain_ue: Vec<f64>,
    /// Reference pressure \[kPa\].
    pub p_kpa: Vec<f64>,
    /// Ambient thermometer reading [°C].
    pub t_amb_c: Vec<f64>,
    /// Measured wavelength shifts \[pm\].
    pub dl_pm: [Vec<f64>; 3],
    pub split: Vec<Split>,
    /// Which references (T, ε, p) the data carry; absent ones are NaN throughout.
    pub has_target: [bool; 3],
}

impl Dataset {
    pub fn len(&self) -> usize {
        self.t_s.len()
    }
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }
    /// The model inputs of sample `i`.
    pub fn sample(&self, i: usize) -> Sample<f64> {
        Sample::new([self.dl_pm[0][i], self.dl_pm[1][i], self.dl_pm[2][i]], self.t_amb_c[i], self.t_s[i])
    }
    /// The reference measurands (T, ε, p) of sample `i`.
    pub fn truth(&self, i: usize) -> [f64; 3] {
        [self.temp_c[i], self.strain_ue[i], self.p_kpa[i]]
    }
    /// Reference channel by output index (0 T, 1 ε, 2 p).
    pub fn target(&self, c: usize) -> &[f64] {
        match c {
            0 => &self.temp_c,
            1 => &self.strain_ue,
            _ => &self.p_kpa,
        }
    }
    /// Indices of the calibration samples.
    pub fn cal_indices(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.split[i] == Split::Cal).collect()
    }
    /// True when sample `i` can be used for fitting: finite inputs and every available
    /// reference present.
    pub fn usable(&self, i: usize) -> bool {
        self.dl_pm.iter().all(|c| c[i].is_finite())
            && self.t_amb_c[i].is_finite()
            && self.t_s[i].is_finite()
            && (0..3).all(|c| !self.has_target[c] || self.target(c)[i].is_finite())
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
    /// Indices of the hold-out samples.
    pub fn holdout_indices(&self) -> Vec<usize> {
        (0..self.len()).filter(|&i| self.split[i] == Split::Holdout).collect()
    }
    /// A new dataset with the rows `idx`, in that order.
    pub fn select(&self, idx: &[usize]) -> Dataset {
        let pick = |v: &Vec<f64>| idx.iter().map(|&i| v[i]).collect::<Vec<f64>>();
        Dataset {
            t_s: pick(&self.t_s),
            temp_c: pick(&self.temp_c),
            strain_ue: pick(&self.strain_ue),
            p_kpa: pick(&self.p_kpa),
            t_amb_c: pick(&self.t_amb_c),
            dl_pm: [pick(&self.dl_pm[0]), pick(&self.dl_pm[1]), pick(&self.dl_pm[2])],
            split: idx.iter().map(|&i| self.split[i]).collect(),
            has_target: self.has_target,
        }
    }

    /// Write the CSV atomically: a temporary file in the target directory, renamed into place
    /// only when complete.
    pub fn write_csv(&self, path: &Path) -> Result<(), TrainerError> {
        // Absent references are left out; a missing value (gap) is an empty cell.
        let cell = |v: f64, digits: usize| if v.is_finite() { format!("{v:.digits$}") } else { String::new() };
        let refs: Vec<usize> = (0..3).filter(|&c| self.has_target[c]).collect();
        write_atomically(path, |w| {
            let mut head = vec!["t_s"];
            head.extend(refs.iter().map(|&c| COLUMNS[1 + c]));
            head.extend(["T_amb_C", "dl1_pm", "dl2_pm", "dl3_pm", "split"]);
            writeln!(w, "{}", head.join(","))?;
            let mut line = String::with_capacity(128);
            for i in 0..self.len() {
                line.clear();
                // Microseconds: enough for kHz interrogators.
                line.push_str(&format!("{:.6}", self.t_s[i]));
                for &c in &refs {
                    line.push(',');
                    line.push_str(&cell(self.target(c)[i], 6));
                }
                for v in [self.t_amb_c[i], self.dl_pm[0][i], self.dl_pm[1][i], self.dl_pm[2][i]] {
                    line.push(',');
                    line.push_str(&cell(v, 6));
                }
                line.push(',');
                line.push_str(self.split[i].as_str());
                writeln!(w, "{line}")?;
            }
            Ok(())
        })
    }

    /// Read a CSV with the columns of [`COLUMNS`] (any order, extra columns ignored). `t_s`,
    /// `T_amb_C` and `dl1_pm..dl3_pm` are required; the references and `split` are optional
    /// (without `split` every row is calibration until the caller assigns a split), but at
    /// least one reference must be there to calibrate or evaluate against. Errors name the
    /// file, line and column.
    pub fn read_csv(path: &Path) -> Result<Dataset, TrainerError> {
        Self::read_csv_with(path, true)
    }

    /// [`read_csv`](Self::read_csv) for a field record to compensate: references are welcome
    /// (the errors are then reported) but none is needed.
    pub fn read_field_csv(path: &Path) -> Result<Dataset, TrainerError> {
        Self::read_csv_with(path, false)
    }

    fn read_csv_with(path: &Path, need_reference: bool) -> Result<Dataset, TrainerError> {
        let name = path.display().to_string();
        let mut file = std::fs::File::open(path).map_err(|e| TrainerError::io(path, e))?;
        let ends_with_newline = last_byte(&mut file).map_err(|e| TrainerError::io(path, e))? == Some(b'\n');
        let mut rdr = csv::ReaderBuilder::new().has_headers(true).trim(csv::Trim::All).from_reader(file);
        let headers = rdr
            .headers()
            .map_err(|e| TrainerError::data(&name, 1, "-", format!("cannot read the header: {e}")))?
            .clone();
        let find = |want: &str| headers.iter().position(|h| h == want);
        let mut col = [None; 9];
        for (k, want) in COLUMNS.iter().enumerate() {
            col[k] = find(want);
            let optional = matches!(k, 1..=3 | 8);
            if col[k].is_none() && !optional {
                return Err(TrainerError::data(
                    &name,
                    1,
                    want,
                    format!("missing column `{want}` (required: t_s, T_amb_C, dl1_pm, dl2_pm, dl3_pm; optional: T_C, strain_ue, p_kPa, split)"),
                ));
            }
        }
        let mut d =
            Dataset { has_target: [col[1].is_some(), col[2].is_some(), col[3].is_some()], ..Dataset::default() };
        let mut first_line = 0;
        let mut records = rdr.records().peekable();
        while let Some(rec) = records.next() {
            let rec = rec.map_err(|e| {
                let line = e.position().map(|p| p.line()).unwrap_or(0);
                TrainerError::data(&name, line, "-", format!("malformed row: {e}"))
            })?;
            let line = rec.position().map(|p| p.line()).unwrap_or(0);
            if first_line == 0 {
                first_line = line;
            }
            if !ends_with_newline && records.peek().is_none() {
                // The file ends inside this row, so its last cell may be cut short
                // (`1545.0440` read as `1545.04`): `ragged_row`, as `import` says.
                let last = headers.get(rec.len().saturating_sub(1)).unwrap_or("-");
                return Err(TrainerError::data(
                    &name,
                    line,
                    last,
                    format!("truncated last row (no line end): the file ends inside this row, so its last cell `{}` may be cut short (ragged_row)", rec.get(rec.len().saturating_sub(1)).unwrap_or("")),
                ));
            }
            // `blank_ok`: an empty cell is a missing value (NaN) rather than an error.
            let num = |k: usize, blank_ok: bool| -> Result<f64, TrainerError> {
                let Some(c) = col[k] else { return Ok(f64::NAN) };
                let cell = rec.get(c).ok_or_else(|| {
                    TrainerError::data(
                        &name,
                        line,
                        COLUMNS[k],
                        format!("row has {} cells, column `{}` is number {}", rec.len(), COLUMNS[k], c + 1),
                    )
                })?;
                if cell.is_empty() {
                    return if blank_ok {
                        Ok(f64::NAN)
                    } else {
                        Err(TrainerError::data(&name, line, COLUMNS[k], "empty cell"))
                    };
                }
                let v: f64 = cell
                    .parse()
                    .map_err(|_| TrainerError::data(&name, line, COLUMNS[k], format!("`{cell}` is not a number")))?;
                if !v.is_finite() {
                    return Err(TrainerError::data(&name, line, COLUMNS[k], format!("`{cell}` is not finite")));
                }
                Ok(v)
            };
            let t = num(0, false)?;
            if let Some(&prev) = d.t_s.last() {
                if t <= prev {
                    return Err(TrainerError::data(
                        &name,
                        line,
                        "t_s",
                        format!("time does not increase ({t} after {prev})"),
                    ));
                }
            }
            d.t_s.push(t);
            d.temp_c.push(num(1, true)?);
            d.strain_ue.push(num(2, true)?);
            d.p_kpa.push(num(3, true)?);
            // An empty ambient reading is a gap like an empty dl cell (not fitted, flagged).
            // Magnitudes get the unit checks of `import` (kelvin for °C, nm or absolute
            // wavelengths for shifts in pm), with its messages.
            let amb = num(4, true)?;
            if amb.is_finite() {
                check_ambient(amb).map_err(|m| TrainerError::data(&name, line, "T_amb_C", format!("{m}{REIMPORT}")))?;
            }
            d.t_amb_c.push(amb);
            for g in 0..3 {
                let v = num(5 + g, true)?;
                if v.is_finite() {
                    check_wavelength(WlUnit::ShiftPm, v, UNIT_KEYS[g])
                        .map_err(|m| TrainerError::data(&name, line, COLUMNS[5 + g], format!("{m}{REIMPORT}")))?;
                }
                d.dl_pm[g].push(v);
            }
            let split = match col[8] {
                None => Split::Cal,
                Some(c) => match rec.get(c).unwrap_or("") {
                    "cal" => Split::Cal,
                    "holdout" => Split::Holdout,
                    other => {
                        return Err(TrainerError::data(
                            &name,
                            line,
                            "split",
                            format!("`{other}` is neither `cal` nor `holdout`"),
                        ))
                    }
                },
            };
            d.split.push(split);
        }
        if d.is_empty() {
            return Err(TrainerError::data(&name, 2, "-", "no data rows"));
        }
        for g in 0..3 {
            if looks_absolute_nm(&d.dl_pm[g]) {
                return Err(TrainerError::data(
                    &name,
                    first_line,
                    COLUMNS[5 + g],
                    format!("{}{REIMPORT}", absolute_nm_column_message(&d.dl_pm[g], UNIT_KEYS[g])),
                ));
            }
        }
        if need_reference && !d.has_target.iter().any(|&h| h) {
            return Err(TrainerError::data(
                &name,
                1,
                "T_C",
                "no reference column (T_C, strain_ue or p_kPa): nothing to calibrate against",
            ));
        }
        Ok(d)
    }
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
