//! A time series of measured inputs and reference measurands, and its CSV form (DESIGN §3):
//! `t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split`.

use std::io::Write;
use std::path::Path;

use fbg_shared::Sample;

use crate::error::TrainerError;

/// The CSV header, in column order.
pub const COLUMNS: [&str; 9] =
    ["t_s", "T_C", "strain_ue", "p_kPa", "T_amb_C", "dl1_pm", "dl2_pm", "dl3_pm", "split"];

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
    /// Time since the start [s].
    pub t_s: Vec<f64>,
    /// Reference temperature [°C].
    pub temp_c: Vec<f64>,
    /// Reference strain [µε].
    pub strain_ue: Vec<f64>,
    /// Reference pressure [kPa].
    pub p_kpa: Vec<f64>,
    /// Ambient thermometer reading [°C].
    pub t_amb_c: Vec<f64>,
    /// Measured wavelength shifts [pm].
    pub dl_pm: [Vec<f64>; 3],
    pub split: Vec<Split>,
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
        Sample {
            dl_pm: [self.dl_pm[0][i], self.dl_pm[1][i], self.dl_pm[2][i]],
            t_amb_c: self.t_amb_c[i],
            t_s: self.t_s[i],
        }
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
        }
    }

    /// Write the CSV atomically: a temporary file in the target directory, renamed into place
    /// only when complete.
    pub fn write_csv(&self, path: &Path) -> Result<(), TrainerError> {
        write_atomically(path, |w| {
            writeln!(w, "{}", COLUMNS.join(","))?;
            for i in 0..self.len() {
                writeln!(
                    w,
                    "{:.3},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{}",
                    self.t_s[i],
                    self.temp_c[i],
                    self.strain_ue[i],
                    self.p_kpa[i],
                    self.t_amb_c[i],
                    self.dl_pm[0][i],
                    self.dl_pm[1][i],
                    self.dl_pm[2][i],
                    self.split[i].as_str()
                )?;
            }
            Ok(())
        })
    }

    /// Read a CSV with the columns of [`COLUMNS`] (any order, extra columns ignored). Errors
    /// name the file, line and column.
    pub fn read_csv(path: &Path) -> Result<Dataset, TrainerError> {
        let name = path.display().to_string();
        let file = std::fs::File::open(path).map_err(|e| TrainerError::io(path, e))?;
        let mut rdr = csv::ReaderBuilder::new().has_headers(true).trim(csv::Trim::All).from_reader(file);
        let headers = rdr
            .headers()
            .map_err(|e| TrainerError::data(&name, 1, "-", format!("cannot read the header: {e}")))?
            .clone();
        let mut col = [0usize; 9];
        for (k, want) in COLUMNS.iter().enumerate() {
            col[k] = headers.iter().position(|h| h == *want).ok_or_else(|| {
                TrainerError::data(
                    &name,
                    1,
                    want,
                    format!("missing column `{want}` (expected columns: {})", COLUMNS.join(",")),
                )
            })?;
        }
        let mut d = Dataset::default();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| {
                let line = e.position().map(|p| p.line()).unwrap_or(0);
                TrainerError::data(&name, line, "-", format!("malformed row: {e}"))
            })?;
            let line = rec.position().map(|p| p.line()).unwrap_or(0);
            let num = |k: usize| -> Result<f64, TrainerError> {
                let cell = rec.get(col[k]).unwrap_or("");
                let v: f64 = cell.parse().map_err(|_| {
                    TrainerError::data(&name, line, COLUMNS[k], format!("`{cell}` is not a number"))
                })?;
                if !v.is_finite() {
                    return Err(TrainerError::data(&name, line, COLUMNS[k], format!("`{cell}` is not finite")));
                }
                Ok(v)
            };
            let t = num(0)?;
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
            d.temp_c.push(num(1)?);
            d.strain_ue.push(num(2)?);
            d.p_kpa.push(num(3)?);
            d.t_amb_c.push(num(4)?);
            for g in 0..3 {
                d.dl_pm[g].push(num(5 + g)?);
            }
            let s = rec.get(col[8]).unwrap_or("");
            d.split.push(match s {
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
            });
        }
        if d.is_empty() {
            return Err(TrainerError::data(&name, 2, "-", "no data rows"));
        }
        Ok(d)
    }
}

/// Write `path` through a temporary file in the same directory and rename it into place, so
/// that a failure never leaves a half-written file.
pub fn write_atomically(
    path: &Path,
    body: impl FnOnce(&mut std::io::BufWriter<&mut std::fs::File>) -> std::io::Result<()>,
) -> Result<(), TrainerError> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let mut tmp = tempfile::Builder::new()
        .prefix(".fbg-tmp-")
        .tempfile_in(&dir)
        .map_err(|e| TrainerError::io(path, e))?;
    {
        let mut w = std::io::BufWriter::new(tmp.as_file_mut());
        body(&mut w).map_err(|e| TrainerError::io(path, e))?;
        w.flush().map_err(|e| TrainerError::io(path, e))?;
    }
    tmp.as_file().sync_all().map_err(|e| TrainerError::io(path, e))?;
    tmp.persist(path).map_err(|e| TrainerError::io(path, e.error))?;
    Ok(())
}

/// Write bytes atomically.
pub fn write_bytes_atomically(path: &Path, bytes: &[u8]) -> Result<(), TrainerError> {
    write_atomically(path, |w| w.write_all(bytes))
}
