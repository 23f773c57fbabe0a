//! `evaluate --quick` on a record without a simulation sidecar, streamed: Table 2 and the
//! static audit in O(1) memory whatever the record's length, the same numbers as
//! [`crate::eval::studies::evaluate_models`] to the bit.
//!
//! Two passes over the rows. The first steps Model-P and Model-H from the first row as
//! [`crate::fit::run`] does (the hold-out rows `score` counts are stepped, every other row only
//! advances the stream) and adds each counted row's errors to running sums, in the order and
//! with the float operations of [`score::score`]; it also runs every grating's direction latch
//! and keeps, per output and grating, the sums of the errors on rising and on falling segments,
//! so the hysteresis index of whichever grating turns out dominant needs no row kept. R² needs
//! the mean of the truth before Σ(t − mean)², and the dominant grating of a layout other than
//! the paper's the means before its correlations: the second pass sums those. The static audit
//! reads only the record's prefix that holds its calibration rows.

use std::path::Path;
use std::time::Instant;

use fbg_shared::layout::Dims;
use fbg_shared::{DirectionLatch, Estimate, Flags, PreparedModel, StreamState};

use crate::data::{Dataset, Measurand, Row, RowReader, Split, MAX_GRATINGS, MAX_MEASURANDS};
use crate::error::TrainerError;
use crate::eval::metrics::{static_fidelity, Metrics, SelectionSummary, Table2};
use crate::eval::score::{self, ChannelMetrics, ModelEval, HYSTERESIS_INDEX_DEAD_BAND_PM};
use crate::fit::static_fidelity::{StaticAudit, AUDIT_MAX_ROWS};
use crate::fit::{HostParams, HOST_CAP};

/// The flags counted per model, as [`score::score`] counts them.
const BITS: [Flags; 5] =
    [Flags::NON_FINITE, Flags::OUT_OF_ENVELOPE, Flags::WEAK_SUPPORT, Flags::IMPLAUSIBLE, Flags::FALLBACK];

/// Sums of the errors of one output on the rows where a grating's latch reads rising or falling.
#[derive(Clone, Copy)]
struct Segments {
    rising: f64,
    n_rising: usize,
    falling: f64,
    n_falling: usize,
}

impl Default for Segments {
    fn default() -> Self {
        Segments { rising: -0.0, n_rising: 0, falling: -0.0, n_falling: 0 }
    }
}

/// One output's running sums (`score`'s, Σ starting where `Iterator::sum` does).
#[derive(Clone)]
struct OutputSums {
    /// Where the output's reference is in a row (canonical order), when the record has it.
    reference: Option<usize>,
    ss_res: f64,
    sum_abs: f64,
    sum_err: f64,
    max_abs: f64,
    inside: usize,
    band: f64,
    segments: [Segments; MAX_GRATINGS],
}

/// A model stepped over the record with its running sums.
struct ModelRun {
    dims: Dims,
    model: Box<PreparedModel<f64, HOST_CAP>>,
    /// The model's stream over the record.
    state: StreamState<f64>,
    outputs: Vec<OutputSums>,
    flag_counts: [usize; 5],
    flagged: usize,
    n: usize,
}

impl ModelRun {
    fn new(params: &HostParams, header: &Dataset) -> Result<ModelRun, TrainerError> {
        let model = Box::new(PreparedModel::new(params).map_err(|e| TrainerError::fit(e.to_string()))?);
        let mut state = StreamState::new();
        model.set_clock(&mut state, header.calibration_clock(params));
        let outputs = params
            .dims
            .outputs()
            .iter()
            .map(|&o| OutputSums {
                reference: header.refs.iter().position(|r| r.measurand == Measurand::of_output(o)),
                ss_res: -0.0,
                sum_abs: -0.0,
                sum_err: -0.0,
                max_abs: 0.0,
                inside: 0,
                band: -0.0,
                segments: [Segments::default(); MAX_GRATINGS],
            })
            .collect();
        Ok(ModelRun { dims: params.dims, model, state, outputs, flag_counts: [0; 5], flagged: 0, n: 0 })
    }

    /// Add a counted row's estimate; `dirs`: every grating's latch at this row.
    fn add(&mut self, e: &Estimate<f64>, row: &Row, dirs: &[f64]) {
        self.n += 1;
        for (c, o) in self.outputs.iter_mut().enumerate() {
            let Some(k) = o.reference else { continue };
            let err = e.values[c] - row.refs[k];
            o.ss_res += err * err;
            o.sum_abs += err.abs();
            o.sum_err += err;
            o.max_abs = o.max_abs.max(err.abs());
            o.inside += usize::from(err.abs() <= e.band95[c]);
            if e.band95[c].is_finite() {
                o.band += e.band95[c];
            }
            for (s, &d) in o.segments.iter_mut().zip(dirs) {
                if d == 1.0 {
                    s.rising += err;
                    s.n_rising += 1;
                } else if d == -1.0 {
                    s.falling += err;
                    s.n_falling += 1;
                }
            }
        }
        for (n, &b) in self.flag_counts.iter_mut().zip(&BITS) {
            *n += usize::from(e.flags.contains(b));
        }
        self.flagged += usize::from(!e.flags.is_ok());
    }

    /// The model's evaluation, given the record-wide sums of the second pass.
    fn eval(&self, shared: &Shared, n_gratings: usize) -> ModelEval {
        let n = self.n as f64;
        let channels = self
            .outputs
            .iter()
            .enumerate()
            .map(|(c, o)| {
                let Some(k) = o.reference else {
                    return ChannelMetrics::ABSENT;
                };
                let ss_tot = shared.ss_tot[k];
                let g = if self.dims == Dims::PAPER {
                    score::PAPER_GRATING_OF_OUTPUT[c]
                } else {
                    score::most_correlated(n_gratings, |g| {
                        let [sxy, sxx, syy] = shared.cross[k][g];
                        score::correlation(sxy, sxx, syy)
                    })
                };
                let seg = o.segments[g];
                let mean = |sum: f64, count: usize| if count == 0 { 0.0 } else { sum / count as f64 };
                ChannelMetrics {
                    rmse: (o.ss_res / n).sqrt(),
                    mae: o.sum_abs / n,
                    r2: if ss_tot > 0.0 { 1.0 - o.ss_res / ss_tot } else { f64::NAN },
                    bias: o.sum_err / n,
                    max_abs: o.max_abs,
                    coverage: o.inside as f64 / n,
                    mean_band: o.band / n,
                    hysteresis_index: mean(seg.rising, seg.n_rising) - mean(seg.falling, seg.n_falling),
                    n: self.n,
                }
            })
            .collect();
        ModelEval {
            channels,
            flag_counts: self.flag_counts,
            flagged_fraction: self.flagged as f64 / self.n.max(1) as f64,
        }
    }
}

/// Record-wide sums over the counted rows, per reference column `k` and grating `g`.
struct Shared {
    /// Σ(t − mean t)².
    ss_tot: [f64; MAX_MEASURANDS],
    /// Σ dx·dy, Σ dx², Σ dy² of grating `g`'s shift and reference `k` about their means.
    cross: [[[f64; 3]; MAX_GRATINGS]; MAX_MEASURANDS],
}

/// Rows read per chunk handed from the reading thread to the one that uses them.
const CHUNK: usize = 4096;
/// Chunks read ahead at most (the memory of the pipeline).
const IN_FLIGHT: usize = 4;

/// Hand every row of `rows` to `f` in order. One thread reads and parses the rows (in chunks,
/// a few in flight) while this one uses them, as `compensate` does: the two halves overlap and
/// memory stays a few chunks. `rows` comes back for [`RowReader::finish`]; progress is
/// `offset` + the bytes read.
fn for_each_row(
    rows: RowReader,
    bar: &crate::progress::Bar,
    offset: u64,
    mut f: impl FnMut(&Row),
) -> Result<RowReader, TrainerError> {
    let (tx, rx) = std::sync::mpsc::sync_channel::<Result<Vec<Row>, TrainerError>>(IN_FLIGHT);
    std::thread::scope(|scope| {
        let reading = scope.spawn(move || {
            let mut rows = rows;
            loop {
                let mut chunk = Vec::with_capacity(CHUNK);
                while chunk.len() < CHUNK {
                    match rows.next_row() {
                        Ok(Some(r)) => chunk.push(r),
                        Ok(None) => break,
                        Err(e) => {
                            let _ = tx.send(Err(e));
                            return rows;
                        }
                    }
                }
                bar.set_position(offset + rows.byte_position());
                let end = chunk.len() < CHUNK;
                // A closed channel: the user stopped on an error it reports.
                if (!chunk.is_empty() && tx.send(Ok(chunk)).is_err()) || end {
                    return rows;
                }
            }
        });
        let mut failed = None;
        for chunk in rx {
            match chunk {
                Ok(c) => c.iter().for_each(&mut f),
                Err(e) => {
                    failed = Some(e);
                    break;
                }
            }
        }
        let rows = reading.join().map_err(|_| TrainerError::Dataset { message: "the reading thread failed".into() })?;
        failed.map_or(Ok(rows), Err)
    })
}

/// Whether row `row` is one `score` counts: a hold-out row with finite inputs and references.
fn counted(row: &Row, n_refs: usize, ambient: bool) -> bool {
    row.split == Split::Holdout && row.usable(n_refs, ambient)
}

/// The second pass over the record at `data`: the sums about the means of the counted rows
/// (`shape`: references, ambient input, gratings).
fn second_pass(
    data: &Path,
    bar: &crate::progress::Bar,
    (n_refs, ambient, n_g): (usize, bool, usize),
    mean_ref: &[f64; MAX_MEASURANDS],
    mean_dl: &[f64; MAX_GRATINGS],
) -> Result<Shared, TrainerError> {
    let mut shared = Shared { ss_tot: [-0.0; MAX_MEASURANDS], cross: [[[0.0; 3]; MAX_GRATINGS]; MAX_MEASURANDS] };
    let rows = RowReader::open(data)?;
    let offset = rows.file_len();
    for_each_row(rows, bar, offset, |row| {
        if !counted(row, n_refs, ambient) {
            return;
        }
        let refs = row.refs.iter().zip(mean_ref).zip(shared.ss_tot.iter_mut().zip(&mut shared.cross));
        for ((&t, &my), (ss_tot, cross)) in refs.take(n_refs) {
            *ss_tot += (t - my).powi(2);
            for ((&x, &mx), sums) in row.dl_pm.iter().zip(mean_dl).zip(cross.iter_mut()).take(n_g) {
                let (dx, dy) = (x - mx, t - my);
                sums[0] += dx * dy;
                sums[1] += dx * dx;
                sums[2] += dy * dy;
            }
        }
    })?;
    Ok(shared)
}

/// `evaluate --quick` of the baseline `p` and the model `h` on the record at `data` (which has
/// no simulation sidecar: no oracle floor, no pace study), streamed. The evaluation's warnings
/// are in; `train`'s are the caller's to merge, as for
/// [`crate::eval::studies::evaluate_models`].
pub fn evaluate_quick(p: &HostParams, h: &HostParams, data: &Path, progress: bool) -> Result<Metrics, TrainerError> {
    let mut timings = Vec::new();
    let t = Instant::now();
    let rows = RowReader::open(data)?;
    let header = rows.header_dataset();
    for params in [p, h] {
        header.inputs_for(&params.dims, "the dataset", "evaluate")?;
    }
    let (n_refs, ambient, n_g) = (header.refs.len(), header.t_amb_c.is_some(), header.n_gratings());
    let bar = crate::progress::bar(progress, 2 * rows.file_len(), "evaluate");
    bar.set_message("hold-out (Table 2)");
    let mut models = [ModelRun::new(p, &header)?, ModelRun::new(h, &header)?];
    let db = fbg_shared::ticks(HYSTERESIS_INDEX_DEAD_BAND_PM);
    let mut latches = [DirectionLatch::new(); MAX_GRATINGS];
    let mut dirs = [0.0f64; MAX_GRATINGS];
    let (mut cal_samples, mut holdout_samples, mut cal_usable, mut n) = (0usize, 0usize, 0usize, 0usize);
    let mut sum_ref = [-0.0f64; MAX_MEASURANDS];
    let mut sum_dl = [-0.0f64; MAX_GRATINGS];
    let rows = for_each_row(rows, &bar, 0, |row| {
        for ((d, l), &v) in dirs.iter_mut().zip(&mut latches).zip(&row.dl_pm).take(n_g) {
            *d = l.update(v, db);
        }
        match row.split {
            Split::Cal => {
                cal_samples += 1;
                cal_usable += usize::from(row.usable(n_refs, ambient));
            }
            Split::Holdout => holdout_samples += 1,
        }
        let s = row.sample();
        if counted(row, n_refs, ambient) {
            n += 1;
            for (a, &v) in sum_ref.iter_mut().zip(&row.refs).take(n_refs) {
                *a += v;
            }
            for (a, &v) in sum_dl.iter_mut().zip(&row.dl_pm).take(n_g) {
                *a += v;
            }
            for m in &mut models {
                let e = m.model.step(&mut m.state, &s);
                m.add(&e, row, &dirs[..n_g]);
            }
        } else {
            for m in &mut models {
                m.model.advance(&mut m.state, &s);
            }
        }
    })?;
    rows.finish()?;
    let samples = rows.rows();
    if n == 0 {
        return Err(TrainerError::Dataset { message: "no hold-out samples (split column has no `holdout`)".into() });
    }
    // The second pass: the sums about the means.
    let nf = n as f64;
    let mean_ref = sum_ref.map(|s| s / nf);
    let mean_dl = sum_dl.map(|s| s / nf);
    let shared = second_pass(data, &bar, (n_refs, ambient, n_g), &mean_ref, &mean_dl)?;
    bar.finish_and_clear();
    let [ep, eh] = [models[0].eval(&shared, n_g), models[1].eval(&shared, n_g)];
    let m = eh.channels.len();
    let gain = (0..m).map(|c| score::gain_pct(ep.channels[c].rmse, eh.channels[c].rmse)).collect();
    let t2 = Table2 { model_p: ep, model_h: eh, gain_pct: gain, oracle_floor: None, h_over_floor: None };
    timings.push(("evaluate".to_string(), t.elapsed().as_secs_f64()));
    // The audit runs over the first AUDIT_MAX_ROWS usable calibration rows: only the prefix
    // that holds them is read.
    let audit = if cal_usable == 0 {
        None
    } else {
        let want = cal_usable.min(AUDIT_MAX_ROWS);
        let mut seen = 0;
        let d = Dataset::read_csv_prefix(data, |r| {
            seen += usize::from(r.split == Split::Cal && r.usable(n_refs, ambient));
            seen == want
        })?;
        let cal: Vec<usize> = d.cal_indices().into_iter().filter(|&i| d.usable(i)).collect();
        Some(StaticAudit::of(p, h, &d, &cal)?)
    };
    let n_out = h.dims.n_outputs();
    let mut metrics = Metrics {
        trainer_version: env!("CARGO_PKG_VERSION").to_string(),
        scenario: h.provenance.scenario.to_string(),
        seed: h.provenance.seed,
        samples,
        cal_samples,
        holdout_samples,
        channels: score::channels(&h.dims),
        units: score::units(&h.dims),
        warnings: Vec::new(),
        selection: SelectionSummary::given(crate::eval::studies::config_of(h), n_out),
        table2: t2,
        drift_sweep: None,
        ablation: None,
        error_budget: None,
        parity: None,
        recalibration: None,
        static_fidelity: audit.as_ref().map(static_fidelity),
        pace: None,
        timings_s: timings,
    };
    metrics.warnings = crate::eval::warnings::evaluation(&metrics, &h.dims);
    Ok(metrics)
}
