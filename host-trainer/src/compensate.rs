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
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use fbg_shared::layout::Dims;
use fbg_shared::{Estimate, Flags, ZeroSource};

use crate::data::files::write_atomically;
use crate::data::measurand::grating_column;
use crate::data::{Dataset, Measurand, Row, RowReader};
use crate::error::TrainerError;
use crate::eval::score;
use crate::export;
pub use crate::fit::Precision;
use crate::fit::{self, Engine, HostParams};
use crate::warning::Warning;

/// The dataset column of each output of `params` (`T_C`, `strain_ue`, …).
pub fn output_columns(params: &HostParams) -> Vec<String> {
    params.dims.outputs().iter().map(|o| o.column().as_str().to_string()).collect()
}

/// Rows read per chunk handed from the reading thread to the writing one.
const CHUNK: usize = 4096;
/// Chunks read ahead at most (the memory of the pipeline).
const IN_FLIGHT: usize = 4;

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
    /// Rows with a fault flag (non-finite, out of envelope, weak support, implausible), and
    /// with each flag: non-finite, out of envelope, weak support, lead unknown (not a fault),
    /// implausible (an estimate beyond the model's plausible range or an absurd band).
    pub flagged_rows: usize,
    pub flag_rows: [usize; 5],
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
            let mut engine =
                Engine::load(params, precision, clock).map_err(|(_, e)| TrainerError::fit(e.to_string()))?;
            Ok((0..d.len()).map(|i| engine.step(&d.sample(i))).collect())
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

/// [`Engine::load`] for the model file `model`: a refusal is an error naming it.
fn engine_for(
    params: &HostParams,
    precision: Precision,
    clock: fbg_shared::StreamClock,
    model: &Path,
) -> Result<Engine, TrainerError> {
    Engine::load(params, precision, clock).map_err(|(what, e)| TrainerError::Model {
        path: model.display().to_string(),
        message: format!("cannot be loaded for {what} arithmetic: {e}"),
    })
}

/// Whether `params` (read from `model`) can be run in `precision`; the error names `model`.
pub fn load_check(params: &HostParams, precision: Precision, model: &Path) -> Result<(), TrainerError> {
    engine_for(params, precision, fbg_shared::StreamClock::Unknown, model).map(|_| ())
}

/// Running sums of the reference errors over the rows with finite inputs and every reference
/// of the record, in row order (so the figures are those of [`score::score`] on the same rows).
struct RefSums {
    n: usize,
    ss_res: [f64; fbg_shared::layout::MAX_OUTPUTS],
    sum_err: [f64; fbg_shared::layout::MAX_OUTPUTS],
    inside: [usize; fbg_shared::layout::MAX_OUTPUTS],
}

/// Per grating, what [`check_units`] needs of a column it never holds: the finite values, the
/// ones far above and far below the envelope's centre, and the largest magnitude.
#[derive(Clone, Copy, Debug, Default)]
struct UnitCounts {
    n: usize,
    far_above: usize,
    far_below: usize,
    worst: f64,
}

/// What is kept across rows: counts (gaps, flags), per output of the model three running sums
/// for the reference errors, per grating four numbers for the unit check, the first and last
/// time stamp.
struct Tally {
    dims: Dims,
    /// Where each output's reference is in a row (canonical order), when the record has it.
    ref_at: Vec<Option<usize>>,
    /// References and thermometer of the record (a row is scored when it has all).
    n_refs: usize,
    ambient: bool,
    /// Per grating, the centre and span of the model's calibration envelope.
    mid_span: Vec<(f64, f64)>,
    units: Vec<UnitCounts>,
    sums: RefSums,
    gap_rows: usize,
    flagged_rows: usize,
    flag_rows: [usize; 5],
    t_first: f64,
    t_last: f64,
}

/// The flags counted in [`Summary::flag_rows`], in its order.
const COUNTED_FLAGS: [Flags; 5] =
    [Flags::NON_FINITE, Flags::OUT_OF_ENVELOPE, Flags::WEAK_SUPPORT, Flags::LEAD_UNKNOWN, Flags::IMPLAUSIBLE];

impl Tally {
    fn new(params: &HostParams, d: &Dataset) -> Tally {
        let dims = params.dims;
        let ref_at = (0..dims.n_outputs())
            .map(|c| {
                dims.outputs().get(c).and_then(|&o| d.refs.iter().position(|r| r.measurand == Measurand::of_output(o)))
            })
            .collect();
        let mid_span = (0..dims.gratings())
            .map(|g| {
                let (lo, hi) = (params.envelope_lo[g], params.envelope_hi[g]);
                (0.5 * (lo + hi), hi - lo)
            })
            .collect();
        Tally {
            dims,
            ref_at,
            n_refs: d.refs.len(),
            ambient: d.t_amb_c.is_some(),
            mid_span,
            units: vec![UnitCounts::default(); dims.gratings()],
            sums: RefSums { n: 0, ss_res: [-0.0; 4], sum_err: [-0.0; 4], inside: [0; 4] },
            gap_rows: 0,
            flagged_rows: 0,
            flag_rows: [0; 5],
            t_first: f64::NAN,
            t_last: f64::NAN,
        }
    }

    /// Count row `row` (its sample `s`) compensated as `e`.
    fn add(&mut self, row: &Row, s: &fbg_shared::Sample<f64>, e: &Estimate<f64>) {
        if self.t_first.is_nan() {
            self.t_first = row.t_s;
        }
        self.t_last = row.t_s;
        // A gap is a missing input of this model: a thermometer the model does not read is
        // no gap.
        if !s.dl().iter().all(|v| v.is_finite()) || (self.dims.ambient() && !s.t_amb_c.is_finite()) {
            self.gap_rows += 1;
        }
        self.flagged_rows += usize::from(e.flags.is_fault());
        for (n, &b) in self.flag_rows.iter_mut().zip(&COUNTED_FLAGS) {
            *n += usize::from(e.flags.contains(b));
        }
        if row.usable(self.n_refs, self.ambient) {
            let sums = &mut self.sums;
            sums.n += 1;
            for (c, at) in self.ref_at.iter().enumerate() {
                if let Some(k) = *at {
                    let err = e.values[c] - row.refs[k];
                    sums.ss_res[c] += err * err;
                    sums.sum_err[c] += err;
                    sums.inside[c] += usize::from(err.abs() <= e.band95[c]);
                }
            }
        }
        for (g, u) in self.units.iter_mut().enumerate() {
            let x = row.dl_pm[g];
            if x.is_finite() {
                let (mid, span) = self.mid_span[g];
                u.n += 1;
                u.far_above += usize::from(x - mid > UNIT_FAR_SPANS * span);
                u.far_below += usize::from(x - mid < -(UNIT_FAR_SPANS * span));
                u.worst = u.worst.max(x.abs());
            }
        }
    }

    /// The errors against the record's references, when it has any.
    fn reference_errors(&self) -> Option<ReferenceErrors> {
        let (sums, ref_at, dims) = (&self.sums, &self.ref_at, &self.dims);
        let m = dims.n_outputs();
        ref_at.iter().any(Option::is_some).then(|| {
            let present = |c: usize| ref_at[c].is_some() && sums.n > 0;
            let n = sums.n as f64;
            ReferenceErrors {
                channels: score::channels(dims),
                units: score::units(dims),
                rows: (0..m).map(|c| if present(c) { sums.n } else { 0 }).collect(),
                rmse: (0..m).map(|c| if present(c) { (sums.ss_res[c] / n).sqrt() } else { f64::NAN }).collect(),
                bias: (0..m).map(|c| if present(c) { sums.sum_err[c] / n } else { f64::NAN }).collect(),
                coverage: (0..m).map(|c| if present(c) { sums.inside[c] as f64 / n } else { f64::NAN }).collect(),
            }
        })
    }
}

/// The band's clock (`absolute` or `unknown`), and the warning that the band's lead is unknown
/// when it is and it matters (the model's band grows with the lead).
fn lead_check(params: &HostParams, d: &Dataset, model: &Path, name: &str) -> (&'static str, Option<Warning>) {
    let clock = match (d.field_clock(), params.field.cal_end_unix_s) {
        (fbg_shared::StreamClock::StartUnix(_), Some(_)) => "absolute",
        _ => "unknown",
    };
    if clock == "absolute" || !params.resid_var_growth.iter().any(|&q| q > 0.0) {
        return (clock, None);
    }
    let why = if d.meta.t0_unix_s.is_none() {
        format!("{name} has no absolute start time (import it from an export with timestamps, or pass --start)")
    } else {
        format!("{} was calibrated on a record without absolute time", model.display())
    };
    let w = Warning::new(
        "lead_unknown",
        format!(
            "the band's lead time is unknown: {why}; every band is taken at the largest lead the calibration validated ({:.1} h) and flagged lead-unknown",
            params.field.lead_max_s / 3600.0
        ),
    )
    .with("lead_max_h", f64::from(params.field.lead_max_s) / 3600.0);
    (clock, Some(w))
}

/// Compensate the rows of `rows` with `engine` and write them to `w`, counting them in
/// `tally`. One thread reads and parses rows (in chunks, a few in flight), this one
/// compensates and writes them: the two halves of the work overlap, and memory stays a few
/// chunks whatever the record's length. Returns the reader when every row was read; a read
/// error is left in `failed` (and `None` returned).
fn pipe_rows(
    w: &mut impl Write,
    rows: RowReader,
    engine: &mut Engine,
    tally: &mut Tally,
    bar: &crate::progress::Bar,
    failed: &mut Option<TrainerError>,
    cancel: &AtomicBool,
) -> std::io::Result<Option<RowReader>> {
    let m = tally.dims.n_outputs();
    let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Vec<Row>, TrainerError>>(IN_FLIGHT);
    std::thread::scope(|scope| -> std::io::Result<Option<RowReader>> {
        let reading = scope.spawn(move || {
            let mut rows = rows;
            loop {
                if cancel.load(Ordering::Relaxed) {
                    let _ = tx.send(Err(TrainerError::Interrupted { what: "compensate".into() }));
                    return rows;
                }
                let mut chunk = Vec::with_capacity(CHUNK);
                let mut end = false;
                while chunk.len() < CHUNK {
                    match rows.next_row() {
                        Ok(Some(r)) => chunk.push(r),
                        Ok(None) => {
                            end = true;
                            break;
                        }
                        Err(e) => {
                            let _ = tx.send(Err(e));
                            return rows;
                        }
                    }
                }
                bar.set_position(rows.byte_position());
                // A closed channel: the writer stopped (an error it reports).
                if (!chunk.is_empty() && tx.send(Ok(chunk)).is_err()) || end {
                    return rows;
                }
            }
        });
        for chunk in rx {
            let chunk = match chunk {
                Ok(c) => c,
                Err(e) => {
                    *failed = Some(e);
                    return Ok(None);
                }
            };
            for row in chunk {
                let s = row.sample();
                let e = engine.step(&s);
                write!(w, "{}", row.t_s)?;
                for c in 0..m {
                    write!(w, ",{},{}", cell(e.values[c]), cell(e.band95[c]))?;
                }
                writeln!(w, ",{},{}", e.flags.0, e.flags)?;
                tally.add(&row, &s, &e);
            }
        }
        Ok(reading.join().ok())
    })
}

/// Read `data`, compensate it with the model in `model`, write `out` (atomically).
///
/// The rows are streamed: read, compensated and written one at a time, so memory does not grow
/// with the record. What is kept across rows: the compensator's state and a `Tally` (whose
/// unit check decides the median by counting; the median's value is read again from the file
/// only to word a refusal). A check that needs the whole record (the unit check, an empty
/// record) is made at the end, before the output is renamed into place: on any error nothing
/// is written.
///
/// ```
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use fbg_trainer::compensate::{self, FieldOptions, Precision};
/// use fbg_trainer::fit::{self, FeatureChoice, Origin};
/// use fbg_trainer::sim::{self, scenario::Preset};
///
/// let dir = tempfile::tempdir()?;
/// // A short record of the `temperature-1` preset, a quick fit on it, its blob.
/// let mut cfg = Preset::Temperature1.config();
/// cfg.clock.days = 1.0;
/// let record = sim::simulate(&cfg, 7).data;
/// let tr = fit::train(&record, &FeatureChoice::Paper.train_options(8)?, &Origin::default())?;
/// let (model, data, out) = (dir.path().join("m.fbgm"), dir.path().join("d.csv"), dir.path().join("c.csv"));
/// fbg_trainer::export::write_blob(&model, &tr.model_h)?;
/// record.write_csv(&data)?;
///
/// let s = compensate::run(&model, &data, &out, Precision::F64, FieldOptions::default(), false)?;
/// assert_eq!(s.rows, record.len());
/// assert!(s.reference_errors.is_some(), "the simulated record has its references");
/// # Ok(())
/// # }
/// ```
pub fn run(
    model: &Path,
    data: &Path,
    out: &Path,
    precision: Precision,
    field: FieldOptions,
    progress: bool,
) -> Result<Summary, TrainerError> {
    run_cancellable(model, data, out, precision, field, progress, &AtomicBool::new(false))
}

/// [`run`] that stops when `cancel` is set (Ctrl-C in Python): the rows are read in chunks
/// and the flag is looked at before each, so a run stops within one chunk; it then fails
/// with [`TrainerError::Interrupted`] and writes nothing (the output is renamed into place
/// only at the end).
pub fn run_cancellable(
    model: &Path,
    data: &Path,
    out: &Path,
    precision: Precision,
    field: FieldOptions,
    progress: bool,
    cancel: &AtomicBool,
) -> Result<Summary, TrainerError> {
    let t0 = Instant::now();
    let params = export::read_blob(model)?;
    let rows = RowReader::open(data)?;
    // The record's columns and metadata, without rows.
    let mut d = rows.header_dataset();
    let name = data.display().to_string();
    d.inputs_for(&params.dims, &name, "compensate")?;
    if field.start_unix_s.is_some() {
        d.meta.t0_unix_s = field.start_unix_s;
    }
    let mut warnings = Vec::new();
    let zero = check_zero(&params, &d, model, &name, &mut warnings)?;
    let (clock, lead) = lead_check(&params, &d, model, &name);
    warnings.extend(lead);
    let mut engine = engine_for(&params, precision, d.field_clock(), model)?;
    let mut tally = Tally::new(&params, &d);
    let columns = output_columns(&params);
    let bar = crate::progress::bar(progress, rows.file_len(), "compensate");
    // A data error met while writing: the write is abandoned (nothing renamed into place).
    let mut failed: Option<TrainerError> = None;
    let mut n_rows = 0;
    let written = write_atomically(out, |w| {
        write!(w, "t_s")?;
        for c in &columns {
            write!(w, ",{c},{c}_band95")?;
        }
        writeln!(w, ",flags,flag_names")?;
        let Some(rows) = pipe_rows(w, rows, &mut engine, &mut tally, &bar, &mut failed, cancel)? else {
            return Err(failed.as_ref().map_or_else(
                || std::io::Error::other("the reading thread failed"),
                |_| std::io::Error::other("abandoned"),
            ));
        };
        n_rows = rows.rows();
        let checked = rows.finish().and_then(|()| {
            if field.trust_units {
                Ok(())
            } else {
                check_units(&params, &tally.units, data, &name)
            }
        });
        checked.map_err(|e| {
            failed = Some(e);
            std::io::Error::other("abandoned")
        })
    });
    bar.finish_and_clear();
    if let Some(e) = failed {
        return Err(e);
    }
    written?;
    Ok(Summary {
        model: model.to_path_buf(),
        data: data.to_path_buf(),
        out: out.to_path_buf(),
        precision,
        rows: n_rows,
        gap_rows: tally.gap_rows,
        flagged_rows: tally.flagged_rows,
        flag_rows: tally.flag_rows,
        clock: clock.to_string(),
        zero,
        warnings,
        t_first_s: tally.t_first,
        t_last_s: tally.t_last,
        seconds: t0.elapsed().as_secs_f64(),
        reference_errors: tally.reference_errors(),
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
                        "the record's shifts are from λ_ref {r:.6} nm ({}{}) but {} was calibrated against {m:.6} nm: {dp:+.1} pm apart, more than the model's tolerance of {tol:.2} pm (a {}-pm zero error reads as a measurand change). Re-import the export with `--model {}` to take the model's zero",
                        source.name(),
                        d.meta.sidecar.as_ref().map_or(String::new(), |p| format!(", stated in {}", p.display())),
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
///
/// The median of `n` values (the sorted values' element `n / 2`) is beyond a bound exactly when
/// enough values are: at least `n - n / 2` far above, or `n / 2 + 1` far below; so `counts` (one
/// pass) decide, and the median's value is read again from `data` only to word the refusal.
fn check_units(params: &HostParams, counts: &[UnitCounts], data: &Path, name: &str) -> Result<(), TrainerError> {
    let n = params.dims.gratings();
    let mut tiny = Vec::new();
    for (g, u) in counts.iter().enumerate().take(n) {
        let (lo, hi) = (params.envelope_lo[g], params.envelope_hi[g]);
        let span = hi - lo;
        let col = grating_column(g + 1);
        if u.n == 0 || span.is_nan() || span <= 0.0 {
            continue;
        }
        let k = u.n / 2;
        if u.far_above >= u.n - k || u.far_below > k {
            let median = column_median(data, g)?;
            return Err(TrainerError::data(
                name,
                1,
                &col,
                format!(
                    "median shift {median:.6} pm lies far outside the model's calibration envelope {lo:.1} … {hi:.1} pm (more than {UNIT_FAR_SPANS} spans): the column is likely in another unit (fm? absolute nm?) or zeroed elsewhere; convert it to pm shifts from the model's λ_ref (pass --trust-units to compensate anyway)"
                ),
            ));
        }
        tiny.push((col, u.worst, span));
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

/// The median (the sorted finite values' element `n / 2`) of grating `g`'s column of `data`,
/// read again for a refusal's message.
fn column_median(data: &Path, g: usize) -> Result<f64, TrainerError> {
    let mut rows = RowReader::open(data)?;
    let mut v = Vec::new();
    while let Some(r) = rows.next_row()? {
        if r.dl_pm[g].is_finite() {
            v.push(r.dl_pm[g]);
        }
    }
    v.sort_by(f64::total_cmp);
    Ok(v.get(v.len() / 2).copied().unwrap_or(f64::NAN))
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
            "flagged rows: {} ({:.1} %): non-finite {} ({:.1} %), out of the calibration envelope {} ({:.1} %), weak RBF support {} ({:.1} %), implausible {} ({:.1} %); band lead {} ({} rows flagged lead-unknown)",
            self.flagged_rows,
            pct(self.flagged_rows),
            self.flag_rows[0],
            pct(self.flag_rows[0]),
            self.flag_rows[1],
            pct(self.flag_rows[1]),
            self.flag_rows[2],
            pct(self.flag_rows[2]),
            self.flag_rows[4],
            pct(self.flag_rows[4]),
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
