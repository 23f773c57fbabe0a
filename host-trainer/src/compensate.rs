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

use fbg_shared::{Compensator, Estimate, Flags, ZeroSource};

use crate::data::files::write_atomically;
use crate::data::measurand::grating_column;
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::score;
use crate::export;
use crate::fit::{self, HostParams, HOST_CAP};
use crate::warning::Warning;

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
    /// Rows with a fault flag (non-finite, out of envelope, weak support), and with each flag:
    /// non-finite, out of envelope, weak support, lead unknown (not a fault).
    pub flagged_rows: usize,
    pub flag_rows: [usize; 4],
    /// The band's clock: `absolute` (lead = absolute time since the end of calibration) or
    /// `unknown` (the model's largest validated lead, flag `lead-unknown`).
    pub clock: String,
    /// The record's zero against the model's, per grating (λ_ref in nm; `None` unknown).
    pub zero: Vec<ZeroCheck>,
    /// What the user should know (no zero in the record, unknown clock, …).
    pub warnings: Vec<Warning>,
    /// First and last time stamp \[s\].
    pub t_first_s: f64,
    pub t_last_s: f64,
    pub seconds: f64,
    /// Present when the record has at least one reference column.
    pub reference_errors: Option<ReferenceErrors>,
}

/// One grating's zero: the record's and the model's λ_ref \[nm\] and their difference \[pm\].
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ZeroCheck {
    /// Grating column (`dl1_pm`, …).
    pub grating: String,
    pub record_nm: Option<f64>,
    pub record_source: String,
    pub model_nm: Option<f64>,
    pub difference_pm: Option<f64>,
}

/// Compensate every row of `d` with `params`, the band's lead on the record's clock
/// ([`Dataset::field_clock`]).
pub fn estimates(params: &HostParams, d: &Dataset, precision: Precision) -> Result<Vec<Estimate<f64>>, TrainerError> {
    let clock = d.field_clock();
    match precision {
        Precision::F64 => {
            let all: Vec<usize> = (0..d.len()).collect();
            fit::run_on_clock(params, d, &all, clock)
        }
        Precision::F32 => {
            let p32 = params.convert::<f32, HOST_CAP>().map_err(|e| TrainerError::fit(e.to_string()))?;
            let mut dev = Compensator::<f32, HOST_CAP>::new(&p32).map_err(|e| TrainerError::fit(e.to_string()))?;
            dev.set_clock(clock);
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

/// How `compensate` runs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FieldOptions {
    /// Absolute time (Unix s) of the record's `t_s = 0`, overriding the record's own.
    pub start_unix_s: Option<f64>,
    /// Skip the unit check of the shifts against the model's calibration envelope.
    pub trust_units: bool,
}

/// A record's shifts this many envelope spans away from the envelope's centre are in another
/// unit (or zeroed elsewhere).
const UNIT_FAR_SPANS: f64 = 100.0;
/// A record whose every shift on every grating stays within this fraction of the envelope's
/// span around zero reads like shifts in nm written in a pm column (1000× too small).
const UNIT_TINY_SPAN: f64 = 1.0 / 300.0;

/// Read `data`, compensate it with the model in `model`, write `out` (atomically).
pub fn run(
    model: &Path,
    data: &Path,
    out: &Path,
    precision: Precision,
    field: FieldOptions,
    progress: bool,
) -> Result<Summary, TrainerError> {
    let t0 = Instant::now();
    let params = export::read_blob(model)?;
    let mut d = Dataset::read_field_csv(data)?;
    let name = data.display().to_string();
    d.inputs_for(&params.dims, &name, "compensate")?;
    if field.start_unix_s.is_some() {
        d.meta.t0_unix_s = field.start_unix_s;
    }
    let mut warnings = Vec::new();
    let zero = check_zero(&params, &d, model, &name, &mut warnings)?;
    if !field.trust_units {
        check_units(&params, &d, &name)?;
    }
    let clock = match (d.field_clock(), params.field.cal_end_unix_s) {
        (fbg_shared::StreamClock::StartUnix(_), Some(_)) => "absolute",
        _ => "unknown",
    };
    if clock == "unknown" && params.resid_var_growth.iter().any(|&q| q > 0.0) {
        let why = if d.meta.t0_unix_s.is_none() {
            format!("{name} has no absolute start time (import it from an export with timestamps, or pass --start)")
        } else {
            format!("{} was calibrated on a record without absolute time", model.display())
        };
        warnings.push(
            Warning::new(
                "lead_unknown",
                format!(
                    "the band's lead time is unknown: {why}; every band is taken at the largest lead the calibration validated ({:.1} h) and flagged lead-unknown",
                    params.field.lead_max_s / 3600.0
                ),
            )
            .with("lead_max_h", f64::from(params.field.lead_max_s) / 3600.0),
        );
    }
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
    // A gap is a missing input of this model: a thermometer the model does not read is no gap.
    let dims = params.dims;
    let gap_rows = (0..d.len())
        .filter(|&i| {
            let s = d.sample(i);
            !s.dl().iter().all(|v| v.is_finite()) || (dims.ambient() && !s.t_amb_c.is_finite())
        })
        .count();
    let bits = [Flags::NON_FINITE, Flags::OUT_OF_ENVELOPE, Flags::WEAK_SUPPORT, Flags::LEAD_UNKNOWN];
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
        flagged_rows: est.iter().filter(|e| e.flags.is_fault()).count(),
        flag_rows: bits.map(|b| est.iter().filter(|e| e.flags.contains(b)).count()),
        clock: clock.to_string(),
        zero,
        warnings,
        t_first_s: d.t_s.first().copied().unwrap_or(f64::NAN),
        t_last_s: d.t_s.last().copied().unwrap_or(f64::NAN),
        seconds: t0.elapsed().as_secs_f64(),
        reference_errors,
    })
}

/// The record's zero against the model's: a grating whose stated λ_ref differs from the
/// model's by more than the model's tolerance is refused (its shifts are from another zero);
/// a record that states none is compensated as if its shifts were from the model's, with a
/// warning.
fn check_zero(
    params: &HostParams,
    d: &Dataset,
    model: &Path,
    name: &str,
    warnings: &mut Vec<Warning>,
) -> Result<Vec<ZeroCheck>, TrainerError> {
    let fc = &params.field;
    let tol = f64::from(fc.lambda_ref_tol_pm);
    let mut out = Vec::new();
    let mut unstated = Vec::new();
    for g in 0..params.dims.gratings() {
        let col = grating_column(g + 1);
        let (rec, mine) = (d.meta.lambda_ref(g), fc.lambda_ref(g));
        let source = d.meta.zero.get(g).map_or(ZeroSource::Unknown, |z| z.source);
        let diff = rec.zip(mine).map(|(r, m)| (r - m) * 1e3);
        if let (Some(dp), Some(r), Some(m)) = (diff, rec, mine) {
            if dp.abs() > tol {
                return Err(TrainerError::data(
                    name,
                    1,
                    &col,
                    format!(
                        "the record's shifts are from λ_ref {r:.6} nm ({}) but {} was calibrated against {m:.6} nm: {dp:+.1} pm apart, more than the model's tolerance of {tol:.2} pm (a {}-pm zero error reads as a measurand change). Re-import the export with `--model {}` to take the model's zero",
                        source.name(),
                        model.display(),
                        dp.abs().round(),
                        model.display()
                    ),
                ));
            }
        }
        if rec.is_none() && mine.is_some() {
            unstated.push(col.clone());
        }
        out.push(ZeroCheck {
            grating: col,
            record_nm: rec,
            record_source: source.name().to_string(),
            model_nm: mine,
            difference_pm: diff,
        });
    }
    if !unstated.is_empty() {
        warnings.push(Warning::new(
            "zero_unstated",
            format!(
                "{name} does not say which λ_ref its shifts on {} are from: they are taken as from {}'s (a record zeroed on its own first reading would read wrong without a flag; import exports with `--model`)",
                unstated.join(", "),
                model.display()
            ),
        ));
    }
    if (0..params.dims.gratings()).all(|g| fc.lambda_ref(g).is_none()) {
        warnings.push(Warning::new(
            "model_zero_unknown",
            format!(
                "{} does not know its gratings' λ_ref (it was calibrated on shifts): nothing checks that {name}'s shifts share its zero",
                model.display()
            ),
        ));
    }
    Ok(out)
}

/// Shifts in another unit than pm: a grating whose median lies [`UNIT_FAR_SPANS`] envelope
/// spans from the model's calibration envelope, or a record whose shifts on every grating stay
/// within [`UNIT_TINY_SPAN`] of a span around zero (nm written in a pm column), is refused
/// naming the column and the likely unit.
fn check_units(params: &HostParams, d: &Dataset, name: &str) -> Result<(), TrainerError> {
    let n = params.dims.gratings();
    let mut tiny = Vec::new();
    for g in 0..n {
        let (lo, hi) = (params.envelope_lo[g], params.envelope_hi[g]);
        let span = hi - lo;
        let col = grating_column(g + 1);
        let mut v: Vec<f64> = d.dl_pm[g].iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() || span.is_nan() || span <= 0.0 {
            continue;
        }
        v.sort_by(f64::total_cmp);
        let median = v[v.len() / 2];
        if (median - 0.5 * (lo + hi)).abs() > UNIT_FAR_SPANS * span {
            return Err(TrainerError::data(
                name,
                1,
                &col,
                format!(
                    "median shift {median:.6} pm lies far outside the model's calibration envelope {lo:.1} … {hi:.1} pm (more than {UNIT_FAR_SPANS} spans): the column is likely in another unit (fm? absolute nm?) or zeroed elsewhere; convert it to pm shifts from the model's λ_ref (pass --trust-units to compensate anyway)"
                ),
            ));
        }
        let worst = v.iter().fold(0.0f64, |a, x| a.max(x.abs()));
        tiny.push((col, worst, span));
    }
    if tiny.len() == n && tiny.iter().all(|(_, w, s)| *w < UNIT_TINY_SPAN * s) {
        let (col, w, s) = &tiny[0];
        return Err(TrainerError::data(
            name,
            1,
            col,
            format!(
                "every shift of every grating stays within ±{w:.4} pm while the calibration spanned {s:.1} pm: the columns look like shifts in nm written as pm (1000× too small); multiply by 1000 (pass --trust-units to compensate anyway)"
            ),
        ));
    }
    Ok(())
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
            "flagged rows: {} ({:.1} %): non-finite {} ({:.1} %), out of the calibration envelope {} ({:.1} %), weak RBF support {} ({:.1} %); band lead {} ({} rows flagged lead-unknown)",
            self.flagged_rows,
            pct(self.flagged_rows),
            self.flag_rows[0],
            pct(self.flag_rows[0]),
            self.flag_rows[1],
            pct(self.flag_rows[1]),
            self.flag_rows[2],
            pct(self.flag_rows[2]),
            self.clock,
            self.flag_rows[3],
        ));
        for z in &self.zero {
            if let (Some(r), Some(m)) = (z.record_nm, z.model_nm) {
                s.push_str(&format!(
                    "\n  zero {}: record λ_ref {r:.6} nm ({}), model {m:.6} nm ({:+.2} pm)",
                    z.grating,
                    z.record_source,
                    (r - m) * 1e3
                ));
            }
        }
        for w in &self.warnings {
            s.push_str(&format!("\nwarning: {w}"));
        }
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
