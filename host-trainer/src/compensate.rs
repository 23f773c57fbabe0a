//! `fbg-trainer compensate`: run a model over a logged field record, as the device would.
//!
//! The record needs only the inputs (`t_s`, `T_amb_C`, `dl1_pm..dl3_pm`); references are
//! optional. Every row is compensated in order through `fbg-shared` — in f64 by the same code
//! path as `evaluate` (so the estimates are identical where both run), or with `--f32` by the
//! device's `Compensator<f32, K>` on inputs rounded to f32 as the device receives them. Rows with
//! a gap (an empty input cell) stay gaps: empty value cells and the non-finite flag. Where the
//! record has references, the errors of the compensated values are reported too.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use fbg_shared::{Compensator, Estimate, Flags};

use crate::data::files::write_atomically;
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::score;
use crate::export;
use crate::fit::{self, HostParams, HOST_CAP};

/// The dataset column of each output of `params` (`T_C`, `strain_ue`, …).
pub fn output_columns(params: &HostParams) -> Vec<String> {
    params.dims.outputs().iter().map(|o| o.column().as_str().to_string()).collect()
}

/// Rows per progress-bar tick.
const TICK: usize = 16_384;

/// Which arithmetic runs the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Precision {
    /// The host's f64 path (as `evaluate`).
    F64,
    /// The device's f32 path.
    F32,
}

/// Errors against references present in the record, per output (NaN where absent).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ReferenceErrors {
    /// The model's outputs (`T`, `strain`, …), in output order: every list below follows it.
    pub channels: Vec<String>,
    /// Their units.
    pub units: Vec<String>,
    /// Rows with finite inputs and every reference of the record.
    pub rows: Vec<usize>,
    pub rmse: Vec<f64>,
    pub bias: Vec<f64>,
    /// Fraction of those rows whose reference lies inside the 95 % band.
    pub coverage: Vec<f64>,
}

/// What `compensate` did.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Summary {
    pub model: PathBuf,
    pub data: PathBuf,
    pub out: PathBuf,
    pub precision: Precision,
    pub rows: usize,
    /// Rows whose inputs had a gap (written as gaps).
    pub gap_rows: usize,
    /// Rows with any flag, and with each flag: non-finite, out of envelope, weak support.
    pub flagged_rows: usize,
    pub flag_rows: [usize; 3],
    /// First and last time stamp \[s\].
    pub t_first_s: f64,
    pub t_last_s: f64,
    pub seconds: f64,
    /// Present when the record has at least one reference column.
    pub reference_errors: Option<ReferenceErrors>,
}

/// Compensate every row of `d` with `params`.
pub fn estimates(params: &HostParams, d: &Dataset, precision: Precision) -> Result<Vec<Estimate<f64>>, TrainerError> {
    match precision {
        Precision::F64 => {
            let all: Vec<usize> = (0..d.len()).collect();
            fit::run(params, d, &all)
        }
        Precision::F32 => {
            let p32 = params.convert::<f32, HOST_CAP>().map_err(|e| TrainerError::fit(e.to_string()))?;
            let mut dev = Compensator::<f32, HOST_CAP>::new(&p32).map_err(|e| TrainerError::fit(e.to_string()))?;
            Ok((0..d.len())
                .map(|i| {
                    let e = dev.step(&d.sample(i).cast::<f32>());
                    Estimate {
                        values: e.values.map(f64::from),
                        band95: e.band95.map(f64::from),
                        outputs: e.outputs,
                        flags: e.flags,
                    }
                })
                .collect())
        }
    }
}

fn cell(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        String::new()
    }
}

/// Read `data`, compensate it with the model in `model`, write `out` (atomically).
pub fn run(
    model: &Path,
    data: &Path,
    out: &Path,
    precision: Precision,
    progress: bool,
) -> Result<Summary, TrainerError> {
    let t0 = Instant::now();
    let params = export::read_blob(model)?;
    let d = Dataset::read_field_csv(data)?;
    d.inputs_for(&params.dims, &data.display().to_string(), "compensate")?;
    let est = estimates(&params, &d, precision)?;
    let bar = fit::select::progress_bar(progress, d.len() as u64, "compensate");
    write_atomically(out, |w| {
        write!(w, "t_s")?;
        for c in output_columns(&params) {
            write!(w, ",{c},{c}_band95")?;
        }
        writeln!(w, ",flags,flag_names")?;
        for (i, e) in est.iter().enumerate() {
            write!(w, "{}", d.t_s[i])?;
            for c in 0..params.dims.n_outputs() {
                write!(w, ",{},{}", cell(e.values[c]), cell(e.band95[c]))?;
            }
            writeln!(w, ",{},{}", e.flags.0, e.flags)?;
            if i % TICK == TICK - 1 {
                bar.inc(TICK as u64);
            }
        }
        Ok(())
    })?;
    bar.finish_and_clear();
    let gap_rows = (0..d.len()).filter(|&i| !d.sample(i).inputs_finite()).count();
    let bits = [Flags::NON_FINITE, Flags::OUT_OF_ENVELOPE, Flags::WEAK_SUPPORT];
    let reference_errors = (0..params.dims.n_outputs())
        .any(|c| d.reference_of(&params.dims, c).is_present())
        .then(|| reference_errors(&params, &d, &est));
    Ok(Summary {
        model: model.to_path_buf(),
        data: data.to_path_buf(),
        out: out.to_path_buf(),
        precision,
        rows: d.len(),
        gap_rows,
        flagged_rows: est.iter().filter(|e| !e.flags.is_ok()).count(),
        flag_rows: bits.map(|b| est.iter().filter(|e| e.flags.contains(b)).count()),
        t_first_s: d.t_s.first().copied().unwrap_or(f64::NAN),
        t_last_s: d.t_s.last().copied().unwrap_or(f64::NAN),
        seconds: t0.elapsed().as_secs_f64(),
        reference_errors,
    })
}

/// `evaluate`'s statistics over the rows with finite inputs and every reference the record has.
fn reference_errors(params: &HostParams, d: &Dataset, est: &[Estimate<f64>]) -> ReferenceErrors {
    let dims = &params.dims;
    let rows: Vec<usize> = (0..d.len()).filter(|&i| d.usable(i)).collect();
    let at: Vec<Estimate<f64>> = rows.iter().map(|&i| est[i]).collect();
    let ch = score::score(dims, d, &rows, &at).channels;
    let present = |c: usize| d.reference_of(dims, c).is_present() && !rows.is_empty();
    let m = dims.n_outputs();
    ReferenceErrors {
        channels: score::channels(dims),
        units: score::units(dims),
        rows: (0..m).map(|c| if present(c) { ch[c].n } else { 0 }).collect(),
        rmse: (0..m).map(|c| if present(c) { ch[c].rmse } else { f64::NAN }).collect(),
        bias: (0..m).map(|c| if present(c) { ch[c].bias } else { f64::NAN }).collect(),
        coverage: (0..m).map(|c| if present(c) { ch[c].coverage } else { f64::NAN }).collect(),
    }
}

impl Summary {
    /// A few human-readable lines.
    pub fn text(&self) -> String {
        let mut s = format!(
            "compensated {} rows ({:.1} h, {} with gaps kept as gaps) with {} in {:.2} s ({} arithmetic); wrote {}\n",
            self.rows,
            (self.t_last_s - self.t_first_s) / 3600.0,
            self.gap_rows,
            self.model.display(),
            self.seconds,
            match self.precision {
                Precision::F64 => "f64",
                Precision::F32 => "device f32",
            },
            self.out.display()
        );
        let pct = |n: usize| 100.0 * n as f64 / self.rows.max(1) as f64;
        s.push_str(&format!(
            "flagged rows: {} ({:.1} %): non-finite {} ({:.1} %), out of the calibration envelope {} ({:.1} %), weak RBF support {} ({:.1} %)",
            self.flagged_rows,
            pct(self.flagged_rows),
            self.flag_rows[0],
            pct(self.flag_rows[0]),
            self.flag_rows[1],
            pct(self.flag_rows[1]),
            self.flag_rows[2],
            pct(self.flag_rows[2]),
        ));
        if let Some(r) = &self.reference_errors {
            s.push_str("\nagainst the references in the record (the rows with finite inputs and every reference):");
            for c in (0..r.rows.len()).filter(|&c| r.rows[c] > 0) {
                s.push_str(&format!(
                    "\n  {}: RMSE {:.4} {u}, bias {:+.4} {u}, band coverage {:.1} % ({} rows)",
                    r.channels[c],
                    r.rmse[c],
                    r.bias[c],
                    100.0 * r.coverage[c],
                    r.rows[c],
                    u = r.units[c]
                ));
            }
        }
        s
    }
}
