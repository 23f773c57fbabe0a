//! A model run over a record, in parallel stretches: estimates, the RBF design Ψ, and the
//! ridge system's sums ΨᵀΨ and ΨᵀR without Ψ ever being held whole.
//!
//! The direction latches make the compensator a stream: its answer at sample i depends on
//! every sample before. One cheap sequential pass (latches only) records the stream state at
//! the start of every stretch of [`STRETCH`] samples ([`Checkpoints`]); the stretches are then
//! compensated in parallel, each resuming from its checkpoint, and give exactly the answers of
//! one sequential pass. Stretch boundaries do not depend on the number of threads and partial
//! sums are added in stretch order, so every result is the same on any machine and pool size.
//!
//! All of it goes through `fbg_shared::PreparedModel<f64, _>` stepped over a
//! `fbg_shared::StreamState` (`step_with` for estimates, `core_and_activations` for the ridge
//! system), the code the device runs: the trainer never implements inference a second time.
//! One model serves every stretch; each stretch copies only a stream state.

use std::sync::{Arc, Mutex, OnceLock};

use nalgebra::DMatrix;
use rayon::prelude::*;

use fbg_shared::layout::{MAX_GRATINGS, MAX_OUTPUTS};
use fbg_shared::{Estimate, LatchBank, MemoryState, PreparedModel, StreamState};

use super::{HostParams, HOST_CAP};
use crate::data::{Column, Dataset};
use crate::error::TrainerError;

/// Samples per stretch (the unit of parallel work and of checkpointing).
pub const STRETCH: usize = 4096;

/// A host model in per-sample form (its stream states are kept apart).
type HostModel = PreparedModel<f64, HOST_CAP>;

/// A stream state of a host model.
type HostState = StreamState<f64>;

/// The stream state at the start of every stretch of a record and before chosen samples, for
/// one way of moving the latches (dead band and finiteness rule, see
/// [`fbg_shared::PreparedModel::same_stream`]).
pub struct Checkpoints {
    /// A model of the kind these states belong to (only its stream rule matters).
    rule: HostModel,
    /// Sample positions, ascending: every multiple of [`STRETCH`] below `end` and the extra
    /// samples asked for.
    pos: Vec<usize>,
    /// `latches[j]` and `memory[j·memory_len..][..memory_len]` are the state before sample
    /// `pos[j]`: the memory operators packed at the model's own grating count
    /// ([`MemoryState::pack`]), a fraction of a capacity-sized state, so that a fold resuming at
    /// every thinned row reads little.
    latches: Vec<LatchBank>,
    memory: Vec<f64>,
    /// Numbers per packed memory state (0: the model has no memory terms).
    memory_len: usize,
    /// What the gate remembered before sample `pos[j]` (the last sample let in, the pace).
    gates: Vec<fbg_shared::compensator::GateState<f64>>,
    /// Samples covered.
    end: usize,
}

impl Checkpoints {
    /// One sequential pass of `params`' stream state over samples `0..end`, keeping the state
    /// at every stretch start and before each of `extra` (sorted ascending): work later asked
    /// of exactly those samples resumes there instead of moving the latches again.
    pub fn new(params: &HostParams, d: &Dataset, end: usize, extra: &[usize]) -> Result<Self, TrainerError> {
        let rule = model(params)?;
        let mut state = HostState::new();
        let end = end.min(d.len());
        let gratings = params.dims.gratings();
        let memory_len = if rule.has_memory() { MemoryState::<f64>::packed_len(gratings) } else { 0 };
        let mut pos = Vec::with_capacity(end.div_ceil(STRETCH) + extra.len());
        let mut latches = Vec::with_capacity(pos.capacity());
        let mut memory = Vec::with_capacity(pos.capacity() * memory_len);
        let mut gates = Vec::with_capacity(pos.capacity());
        let mut x = extra.iter().copied().filter(|&i| i < end).peekable();
        for i in 0..end {
            let wanted = x.peek() == Some(&i);
            if wanted {
                x.next();
            }
            if i % STRETCH == 0 || wanted {
                pos.push(i);
                latches.push(state.latches());
                gates.push(state.gate_state());
                if memory_len > 0 {
                    let at = memory.len();
                    memory.resize(at + memory_len, 0.0);
                    state.memory().pack(gratings, &mut memory[at..]).map_err(|e| TrainerError::fit(e.to_string()))?;
                }
            }
            rule.advance(&mut state, &d.sample(i));
        }
        Ok(Checkpoints { rule, pos, latches, memory, memory_len, gates, end })
    }

    /// Put `state` (of `model`, of the same stream rule) where the stream was before sample
    /// `pos[j]`.
    fn resume(&self, model: &HostModel, state: &mut HostState, j: usize) -> Result<(), TrainerError> {
        let at = j * self.memory_len;
        model
            .resume_packed(state, self.latches[j], &self.memory[at..at + self.memory_len])
            .map_err(|e| TrainerError::fit(e.to_string()))?;
        state.resume_gate(self.gates[j]);
        Ok(())
    }

    /// Whether these checkpoints serve `model` up to sample `end`.
    fn serves(&self, model: &HostModel, end: usize) -> bool {
        self.rule.same_stream(model) && end <= self.end
    }
}

/// Checkpoints shared between the tasks of one fit: computed once per stream rule, on first
/// use, and reused by every task that needs the same rule (concurrent users of one rule wait
/// for the first to finish, users of other rules do not).
pub struct CheckpointCache {
    end: usize,
    extra: Vec<usize>,
    /// One slot per stream rule, found by [`fbg_shared::PreparedModel::same_stream`].
    slots: Mutex<Vec<(HostModel, Arc<Slot>)>>,
}

/// One stream rule's checkpoints, computed at most once (the error as text: shared by waiters).
type Slot = OnceLock<Result<Arc<Checkpoints>, String>>;

impl CheckpointCache {
    /// A cache of checkpoints over samples `0..end`, with states before each of `extra`.
    pub fn new(end: usize, extra: Vec<usize>) -> Self {
        CheckpointCache { end, extra, slots: Mutex::default() }
    }

    /// Checkpoints for `params` over samples `0..end` of `d`.
    pub fn get(&self, params: &HostParams, d: &Dataset) -> Result<Arc<Checkpoints>, TrainerError> {
        let rule = model(params)?;
        let slot = {
            let mut slots = self.slots.lock().map_err(|_| TrainerError::fit("checkpoint cache poisoned"))?;
            match slots.iter().find(|(r, _)| r.same_stream(&rule)) {
                Some((_, slot)) => slot.clone(),
                None => {
                    let slot = Arc::new(Slot::new());
                    slots.push((rule, slot.clone()));
                    slot
                }
            }
        };
        slot.get_or_init(|| Checkpoints::new(params, d, self.end, &self.extra).map(Arc::new).map_err(|e| e.to_string()))
            .clone()
            .map_err(TrainerError::fit)
    }
}

fn model(params: &HostParams) -> Result<HostModel, TrainerError> {
    HostModel::new(params).map_err(|e| TrainerError::fit(e.to_string()))
}

/// What each wanted row is run for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// `PreparedModel::step`: the whole estimate (values with the residual, band, flags) and ψ.
    Estimates,
    /// `PreparedModel::core_and_activations`: the polynomial core's values and ψ, all a ridge
    /// system needs (about half the work of a step).
    Design,
}

/// One stretch's share of the wanted rows, compensated.
pub struct StretchOut<'a> {
    /// The rows (sample indices, ascending).
    pub rows: &'a [usize],
    /// ψ of each row, row-major (`rows.len() × K`); empty when the model has no centres
    /// (zeros for a row the model refuses as non-finite).
    pub psi: &'a [f64],
    /// The estimate at each row ([`Pass::Estimates`]; empty otherwise).
    pub est: &'a [Estimate<f64>],
    /// The values at each row: the estimate's ([`Pass::Estimates`]) or the polynomial core's
    /// ([`Pass::Design`]); NaN for a non-finite row.
    pub values: &'a [[f64; MAX_OUTPUTS]],
    /// The direction-latch values after each row (0 beyond the model's gratings).
    pub latches: &'a [[f64; MAX_GRATINGS]],
}

/// Per-worker buffers of [`map_stretches`].
#[derive(Default)]
struct Buffers {
    psi: Vec<f64>,
    est: Vec<Estimate<f64>>,
    values: Vec<[f64; MAX_OUTPUTS]>,
    latches: Vec<[f64; MAX_GRATINGS]>,
}

/// Run `params` over the record and hand each stretch's wanted rows (sorted ascending) to
/// `f`, in parallel; the results come back in stretch order. `ck` must come from a model with
/// the same stream rule (else the checkpoints are computed here).
pub fn map_stretches<T: Send>(
    params: &HostParams,
    d: &Dataset,
    rows: &[usize],
    ck: Option<&Checkpoints>,
    pass: Pass,
    f: impl Fn(StretchOut<'_>) -> T + Sync + Send,
) -> Result<Vec<T>, TrainerError> {
    map_stretches_on(params, d, rows, ck, pass, d.calibration_clock(params), f)
}

/// [`map_stretches`] with the band's lead on `clock` (the record's own calibration clock
/// there).
fn map_stretches_on<T: Send>(
    params: &HostParams,
    d: &Dataset,
    rows: &[usize],
    ck: Option<&Checkpoints>,
    pass: Pass,
    clock: fbg_shared::StreamClock,
    f: impl Fn(StretchOut<'_>) -> T + Sync + Send,
) -> Result<Vec<T>, TrainerError> {
    debug_assert!(rows.windows(2).all(|w| w[0] < w[1]), "rows must be sorted and distinct");
    let model = model(params)?;
    let mut start = HostState::new();
    model.set_clock(&mut start, clock);
    let end = rows.last().map(|&i| i + 1).unwrap_or(0);
    let own;
    let ck = match ck {
        Some(c) if c.serves(&model, end) => c,
        _ => {
            own = Checkpoints::new(params, d, end, &[])?;
            &own
        }
    };
    // The wanted rows of each stretch that has any.
    let mut jobs: Vec<&[usize]> = Vec::new();
    let mut rest = rows;
    while let Some(&first) = rest.first() {
        let n = rest.partition_point(|&i| i < (first / STRETCH + 1) * STRETCH);
        jobs.push(&rest[..n]);
        rest = &rest[n..];
    }
    let k = params.centres.len();
    jobs.par_iter()
        // Buffers reused across the stretches a worker takes (a fresh megabyte per stretch
        // would cost more in page faults than the arithmetic).
        .map_init(Buffers::default, |b, &want| {
            let mut c = start;
            b.psi.clear();
            b.psi.resize(want.len() * k, 0.0);
            b.est.clear();
            b.values.clear();
            b.latches.clear();
            // Position of `c`'s stream: the next sample it expects (None: not yet placed), and
            // the checkpoint index to look from (checkpoints only move forward).
            let mut cur: Option<usize> = None;
            let mut j = ck.pos.partition_point(|&p| p <= want[0]).saturating_sub(1);
            for (w, &i) in want.iter().enumerate() {
                while ck.pos.get(j + 1).is_some_and(|&p| p <= i) {
                    j += 1;
                }
                let p = ck.pos[j];
                if cur.is_none_or(|c| p > c) {
                    ck.resume(&model, &mut c, j)?;
                    cur = Some(p);
                }
                // Only the stream state matters for samples nobody asked about.
                for s in cur.unwrap_or(p)..i {
                    model.advance(&mut c, &d.sample(s));
                }
                let row = &mut b.psi[w * k..(w + 1) * k];
                match pass {
                    Pass::Estimates => {
                        let e = model.step_with(&mut c, &d.sample(i), |j, v| row[j] = v);
                        b.values.push(e.values);
                        b.est.push(e);
                    }
                    Pass::Design => {
                        let v =
                            model.core_and_activations(&mut c, &d.sample(i), row).unwrap_or([f64::NAN; MAX_OUTPUTS]);
                        b.values.push(v);
                    }
                }
                b.latches.push(c.latch_values());
                cur = Some(i + 1);
            }
            Ok(f(StretchOut { rows: want, psi: &b.psi, est: &b.est, values: &b.values, latches: &b.latches }))
        })
        .collect()
}

/// What a set of rows gives a model whatever its RBF layer: the polynomial core's values and
/// the direction latches after each row (the centres, σ and weights play no part in them),
/// kept so that several RBF layers on one stream ([`Rows::Cached`]) pay for the stream (the
/// memory bank, the core) once and for each layer only its activations
/// ([`fbg_shared::PreparedModel::activations`]).
pub struct CoreStream {
    /// A model of the stream rule these rows were run with.
    rule: HostModel,
    rows: Vec<usize>,
    values: Vec<[f64; MAX_OUTPUTS]>,
    latches: Vec<[f64; MAX_GRATINGS]>,
}

impl CoreStream {
    /// Run `params`' core and stream over `rows` (sorted ascending), without its centres.
    pub fn new(
        params: &HostParams,
        d: &Dataset,
        rows: &[usize],
        ck: Option<&Checkpoints>,
    ) -> Result<Self, TrainerError> {
        let mut core = params.clone();
        core.centres.clear();
        let rule = model(&core)?;
        let parts = map_stretches(&core, d, rows, ck, Pass::Design, |o| (o.values.to_vec(), o.latches.to_vec()))?;
        let (mut values, mut latches) = (Vec::with_capacity(rows.len()), Vec::with_capacity(rows.len()));
        for (v, l) in parts {
            values.extend(v);
            latches.extend(l);
        }
        Ok(CoreStream { rule, rows: rows.to_vec(), values, latches })
    }

    /// Whether this stream is `params`' (same stream rule: [`fbg_shared::PreparedModel::same_stream`]).
    pub fn serves(&self, params: &HostParams) -> Result<bool, TrainerError> {
        Ok(self.rule.same_stream(&model(params)?))
    }
}

/// The rows a ridge system or design matrix is built over: run live through the model
/// (with checkpoints when at hand), or taken from a [`CoreStream`] of the same
/// stream rule (a stream of another rule is run live, giving the same numbers slower).
#[derive(Clone, Copy)]
pub enum Rows<'a> {
    Live(&'a [usize], Option<&'a Checkpoints>),
    Cached(&'a CoreStream),
}

impl Rows<'_> {
    /// The rows, sorted ascending.
    pub fn rows(&self) -> &[usize] {
        match self {
            Rows::Live(rows, _) => rows,
            Rows::Cached(cs) => &cs.rows,
        }
    }
}

/// [`map_stretches`] with [`Pass::Design`] over `src`: the same stretches, ψ, values and
/// latches either way.
pub fn map_rows<T: Send>(
    params: &HostParams,
    d: &Dataset,
    src: Rows<'_>,
    f: impl Fn(StretchOut<'_>) -> T + Sync + Send,
) -> Result<Vec<T>, TrainerError> {
    let cs = match src {
        Rows::Live(rows, ck) => return map_stretches(params, d, rows, ck, Pass::Design, f),
        Rows::Cached(cs) => cs,
    };
    let model = model(params)?;
    if !cs.rule.same_stream(&model) {
        return map_stretches(params, d, &cs.rows, None, Pass::Design, f);
    }
    // The stretches of `map_stretches`, as index ranges into the stream's rows.
    let mut jobs: Vec<std::ops::Range<usize>> = Vec::new();
    let mut at = 0;
    while let Some(&first) = cs.rows.get(at) {
        let n = cs.rows[at..].partition_point(|&i| i < (first / STRETCH + 1) * STRETCH);
        jobs.push(at..at + n);
        at += n;
    }
    let k = params.centres.len();
    jobs.par_iter()
        .map_init(Vec::new, |psi: &mut Vec<f64>, r| {
            psi.clear();
            psi.resize(r.len() * k, 0.0);
            if k > 0 {
                for ((row, &i), latch) in psi.chunks_exact_mut(k).zip(&cs.rows[r.clone()]).zip(&cs.latches[r.clone()]) {
                    model.activations(&d.sample(i), latch, row);
                }
            }
            f(StretchOut {
                rows: &cs.rows[r.clone()],
                psi,
                est: &[],
                values: &cs.values[r.clone()],
                latches: &cs.latches[r.clone()],
            })
        })
        .map(Ok)
        .collect()
}

/// Estimates of `params` at `want` (sorted ascending), the compensator having seen every
/// sample from the first.
pub fn run(params: &HostParams, d: &Dataset, want: &[usize]) -> Result<Vec<Estimate<f64>>, TrainerError> {
    run_with(params, d, want, None)
}

/// [`run`] with the band's lead on `clock` (a field record's: [`Dataset::field_clock`]).
pub fn run_on_clock(
    params: &HostParams,
    d: &Dataset,
    want: &[usize],
    clock: fbg_shared::StreamClock,
) -> Result<Vec<Estimate<f64>>, TrainerError> {
    let parts = map_stretches_on(params, d, want, None, Pass::Estimates, clock, |o| o.est.to_vec())?;
    Ok(parts.concat())
}

/// [`run`] with checkpoints at hand.
pub fn run_with(
    params: &HostParams,
    d: &Dataset,
    want: &[usize],
    ck: Option<&Checkpoints>,
) -> Result<Vec<Estimate<f64>>, TrainerError> {
    let parts = map_stretches(params, d, want, ck, Pass::Estimates, |o| o.est.to_vec())?;
    Ok(parts.concat())
}

/// The RBF activations at `rows` (sorted ascending) as a `rows.len() × K` matrix, plus the
/// polynomial core's values there (the model's RBF weights play no part).
pub fn design_matrix(
    params: &HostParams,
    d: &Dataset,
    rows: &[usize],
) -> Result<(DMatrix<f64>, Vec<[f64; MAX_OUTPUTS]>), TrainerError> {
    design_matrix_with(params, d, rows, None)
}

/// [`design_matrix`] with checkpoints at hand.
pub fn design_matrix_with(
    params: &HostParams,
    d: &Dataset,
    rows: &[usize],
    ck: Option<&Checkpoints>,
) -> Result<(DMatrix<f64>, Vec<[f64; MAX_OUTPUTS]>), TrainerError> {
    design_rows(params, d, Rows::Live(rows, ck))
}

/// [`design_matrix`] over `src`.
pub fn design_rows(
    params: &HostParams,
    d: &Dataset,
    src: Rows<'_>,
) -> Result<(DMatrix<f64>, Vec<[f64; MAX_OUTPUTS]>), TrainerError> {
    let k = params.centres.len();
    let rows = src.rows();
    let parts = map_rows(params, d, src, |o| (o.psi.to_vec(), o.values.to_vec()))?;
    let mut psi = DMatrix::zeros(rows.len(), k);
    let mut values = Vec::with_capacity(rows.len());
    let mut r0 = 0;
    for (p, v) in parts {
        for (r, row) in p.chunks_exact(k.max(1)).enumerate().take(v.len()) {
            for (j, &x) in row.iter().enumerate() {
                psi[(r0 + r, j)] = x;
            }
        }
        r0 += v.len();
        values.extend(v);
    }
    Ok((psi, values))
}

/// The sums of the ridge system of paper Eq. 7 over a set of rows, accumulated stretch by
/// stretch: G = ΨᵀΨ, ΨᵀR with R = reference − the polynomial core's values (the model's RBF
/// weights play no part), and max_j ψ_j per row.
pub struct Gram {
    /// ΨᵀΨ (K × K, symmetric).
    pub g: DMatrix<f64>,
    /// ΨᵀR (K × outputs).
    pub psi_r: DMatrix<f64>,
    /// Rows summed.
    pub n: usize,
    /// max_j ψ_j of each row, in row order.
    pub max_psi: Vec<f64>,
}

/// Residual target of output `c` at sample `i` given the core's values and the outputs'
/// references ([`Dataset::references_of`]): reference − value, 0 for an output without
/// reference (so that its residual weights stay 0).
#[inline]
pub fn residual(refs: &[Column<'_>], i: usize, c: usize, values: &[f64; MAX_OUTPUTS]) -> f64 {
    match refs.get(c) {
        Some(r) if r.is_present() => r[i] - values[c],
        _ => 0.0,
    }
}

/// [`Gram`] of `params` over `rows` (sorted ascending).
pub fn gram(params: &HostParams, d: &Dataset, rows: &[usize], ck: Option<&Checkpoints>) -> Result<Gram, TrainerError> {
    gram_rows(params, d, Rows::Live(rows, ck))
}

/// [`Gram`] of `params` over `src`.
pub fn gram_rows(params: &HostParams, d: &Dataset, src: Rows<'_>) -> Result<Gram, TrainerError> {
    let k = params.centres.len();
    let m = params.dims.n_outputs();
    let refs = d.references_of(&params.dims);
    let rows = src.rows();
    let parts = map_rows(params, d, src, |o| {
        let mut g = vec![0.0; k * k];
        let mut pr = vec![0.0; k * m];
        let r: Vec<[f64; MAX_OUTPUTS]> = o
            .rows
            .iter()
            .zip(o.values)
            .map(|(&i, v)| std::array::from_fn(|c| if c < m { residual(&refs, i, c, v) } else { 0.0 }))
            .collect();
        if k > 0 {
            add_outer_products(&mut g, &mut pr, o.psi, &r, k, m);
        }
        let mx: Vec<f64> = if k == 0 {
            vec![0.0; o.rows.len()]
        } else {
            o.psi.chunks_exact(k).map(|p| p.iter().copied().fold(0.0, f64::max)).collect()
        };
        (g, pr, mx)
    })?;
    let mut g = DMatrix::zeros(k, k);
    let mut psi_r = DMatrix::zeros(k, m);
    let mut max_psi = Vec::with_capacity(rows.len());
    for (pg, pr, mx) in parts {
        for a in 0..k {
            for b in a..k {
                g[(a, b)] += pg[a * k + b];
            }
            for c in 0..m {
                psi_r[(a, c)] += pr[a * m + c];
            }
        }
        max_psi.extend(mx);
    }
    for a in 0..k {
        for b in 0..a {
            g[(a, b)] = g[(b, a)];
        }
    }
    Ok(Gram { g, psi_r, n: rows.len(), max_psi })
}

/// G += Σ_r ψ_r ψ_rᵀ (upper triangle, row-major K × K) and PR += Σ_r ψ_r r_rᵀ over the rows of
/// `psi` (row-major, K per row), four rows at a time: each pass over G then carries four
/// products per element, and the inner loop over b is a contiguous, vectorisable update.
fn add_outer_products(g: &mut [f64], pr: &mut [f64], psi: &[f64], r: &[[f64; MAX_OUTPUTS]], k: usize, m: usize) {
    let mut quads = psi.chunks_exact(4 * k);
    let mut rq = r.chunks_exact(4);
    for (q, rr) in (&mut quads).zip(&mut rq) {
        let (p0, rest) = q.split_at(k);
        let (p1, rest) = rest.split_at(k);
        let (p2, p3) = rest.split_at(k);
        for a in 0..k {
            let (a0, a1, a2, a3) = (p0[a], p1[a], p2[a], p3[a]);
            let row = &mut g[a * k + a..(a + 1) * k];
            for ((((gv, &b0), &b1), &b2), &b3) in row.iter_mut().zip(&p0[a..]).zip(&p1[a..]).zip(&p2[a..]).zip(&p3[a..])
            {
                *gv += a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3;
            }
            for c in 0..m {
                pr[a * m + c] += a0 * rr[0][c] + a1 * rr[1][c] + a2 * rr[2][c] + a3 * rr[3][c];
            }
        }
    }
    for (p, rr) in quads.remainder().chunks_exact(k).zip(rq.remainder()) {
        for a in 0..k {
            let pa = p[a];
            for (gv, &pb) in g[a * k + a..(a + 1) * k].iter_mut().zip(&p[a..]) {
                *gv += pa * pb;
            }
            for c in 0..m {
                pr[a * m + c] += pa * rr[c];
            }
        }
    }
}
