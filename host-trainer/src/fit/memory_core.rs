//! The core with memory: ŷ_core = Bφ(g) + Γm, with B the static calibration and Γ fitted on
//! what it leaves (DESIGN §4, static fidelity).
//!
//! The memory terms m come from `fbg_shared::MemoryBank`, the code the device runs, moved over
//! every accepted sample from the first. B is Model-P's polynomial core, fitted without memory
//! terms; Γ is then fitted on Model-P's residual by least squares with a ridge penalty λ on the
//! standardised terms (so λ is unit free). The order matters: fitted jointly with B, the
//! level-free terms (a high-pass Δλ − EMA_τ with τ of hours passes most of a 12-hour cycle)
//! stand in for part of the static gain — they reject slow drift by also rejecting the slow
//! part of the measurand — and the model reads low at any pace but the calibration week's.
//! Fitted on the residual, every memory term settles to 0 once the inputs are constant, and the
//! reading is Model-P's static calibration there.
//!
//! Which terms each output may use is restricted by physics before cross-validation sees it
//! (the menu below): only level-free terms (high-passes, stop terms, the drift observer) are
//! offered, because absolute levels extrapolate into a later hold-out in a way that
//! cross-validation inside one calibration batch does not catch; and the drift observer is
//! offered to temperature outputs only, and exists only with the ambient input (a drift common
//! to every grating looks like a temperature change to each of them). Within that menu, blocked time-series
//! cross-validation chooses per output which groups to use and λ, from closed-form validation
//! errors (Gram matrices of the training and validation rows), so the whole menu costs one
//! pass of the bank per fold.

use nalgebra::{DMatrix, DVector};

use fbg_shared::layout::{Dims, Quantity, MAX_MEMORY, MAX_OUTPUTS, MAX_POLY};
use fbg_shared::{MemoryBank, MemoryGroup, MemorySpec};

use super::poly_core::PolyCore;
use crate::data::Dataset;
use crate::error::TrainerError;

/// The memory menu cross-validation chooses from.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MemoryOptions {
    /// Every operator that may be used (the observer's row is set from the stage-1 inverse of
    /// each fit). All slots 0: no memory terms (the `paper` and `latch` variants).
    pub menu: MemorySpec<f64>,
    /// Groups offered to cross-validation.
    pub groups: Vec<MemoryGroup>,
    /// Ridge penalties λ per sample on the standardised memory terms.
    pub lambdas: Vec<f64>,
    /// Only folds whose training set holds at least this fraction of the calibration rows
    /// score the memory menu (at least the last fold always does). Forward-chaining folds that
    /// train on a third of the batch cannot determine the 4-hour high-passes or the drift
    /// observer and so systematically under-rate them against a final fit on the whole batch.
    pub min_train_fraction: f64,
}

impl MemoryOptions {
    /// No memory terms.
    pub fn off() -> Self {
        MemoryOptions { menu: MemorySpec::off(), groups: Vec::new(), lambdas: vec![0.0], min_train_fraction: 0.75 }
    }

    /// The physics-restricted default menu: ambient high-passes at 5 min … 1 h (the
    /// thermometer's own lag), stop terms at r = 2, 4, 8 pm (the play operator's hidden
    /// position; `train` raises them above each record's noise, `fit::trust::noise_floored`), and the drift observer (thermometer lag 20 min, smoothing 40 min) for
    /// temperature.
    ///
    /// Grating high-passes (τ = 5 min … 4 h) stay on the menu's list of operators but are not
    /// offered: fitted on a calibration batch that runs at one pace, their coefficients cannot
    /// tell a lag of the gratings from the measurand's own cycle, and cross-validation inside
    /// that batch rewards using them as a band-pass tuned to the cycle (they reject slow drift
    /// by rejecting the slow part of the measurand too). The model then reads wrong at any
    /// other pace (DESIGN §4, static fidelity). A study offers them by adding
    /// [`MemoryGroup::GratingHighPass`] to `groups`.
    pub fn default_menu() -> Self {
        let min = 60.0;
        let menu = MemorySpec {
            grating_tau_s: [5.0 * min, 15.0 * min, 30.0 * min, 60.0 * min, 120.0 * min, 240.0 * min],
            ambient_tau_s: [5.0 * min, 15.0 * min, 30.0 * min, 60.0 * min],
            play_half_width_pm: [2.0, 4.0, 8.0],
            observer_lag_s: 20.0 * min,
            observer_smooth_s: 40.0 * min,
            observer_row: [0.0; fbg_shared::layout::MAX_STAGE1],
        };
        MemoryOptions {
            menu,
            groups: MemoryGroup::ALL.iter().copied().filter(|&g| g != MemoryGroup::GratingHighPass).collect(),
            lambdas: vec![1e-7, 1e-6, 1e-5, 1e-4, 1e-3],
            min_train_fraction: 0.75,
        }
    }

    /// Whether any memory term is on the menu.
    pub fn enabled(&self) -> bool {
        !self.groups.is_empty() && self.menu.any()
    }

    /// The same menu without `group` (Table 3's "memory group removed" rows).
    pub fn without(&self, group: MemoryGroup) -> Self {
        MemoryOptions { groups: self.groups.iter().copied().filter(|&g| g != group).collect(), ..self.clone() }
    }
}

/// What each output uses: a set of groups and its ridge penalty.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct MemoryChoice {
    /// Per output, a bit per [`MemoryGroup::ALL`] entry (0 beyond the model's outputs).
    pub groups: [u8; MAX_OUTPUTS],
    /// Per output, λ per sample on the standardised memory terms.
    pub lambda: [f64; MAX_OUTPUTS],
}

/// The bit of `g` in a [`MemoryChoice`] group mask (its place in [`MemoryGroup::ALL`]).
fn bit(g: MemoryGroup) -> u8 {
    1 << MemoryGroup::ALL.iter().position(|&x| x == g).unwrap_or(0)
}

impl MemoryChoice {
    /// No memory terms on any output.
    pub fn none() -> Self {
        MemoryChoice::default()
    }

    /// Whether output `o` uses `g`.
    pub fn uses(&self, o: usize, g: MemoryGroup) -> bool {
        self.groups.get(o).is_some_and(|&b| b & bit(g) != 0)
    }

    /// Whether any output uses any memory term.
    pub fn any(&self) -> bool {
        self.groups.iter().any(|&g| g != 0)
    }

    /// The groups output `o` uses, by name (for reports).
    pub fn names(&self, o: usize) -> Vec<&'static str> {
        MemoryGroup::ALL.iter().filter(|&&g| self.uses(o, g)).map(|g| g.name()).collect()
    }

    /// The spec that computes exactly the terms some output uses (others 0), with the
    /// observer's row from `core`'s stage 1.
    pub(crate) fn spec(&self, menu: &MemorySpec<f64>, core: &PolyCore) -> MemorySpec<f64> {
        let any = |g| (0..core.dims.n_outputs()).any(|o| self.uses(o, g));
        let mut s = MemorySpec::off();
        if any(MemoryGroup::GratingHighPass) {
            s.grating_tau_s = menu.grating_tau_s;
        }
        if any(MemoryGroup::AmbientHighPass) {
            s.ambient_tau_s = menu.ambient_tau_s;
        }
        if any(MemoryGroup::Stop) {
            s.play_half_width_pm = menu.play_half_width_pm;
        }
        if let Some(t) = core.dims.position(Quantity::Temperature).filter(|_| core.dims.has_observer()) {
            if any(MemoryGroup::DriftObserver) && menu.observer_lag_s > 0.0 {
                s.observer_lag_s = menu.observer_lag_s;
                s.observer_smooth_s = menu.observer_smooth_s;
                s.observer_row = core.stage1[t];
            }
        }
        s
    }
}

/// The full menu's spec with the observer row from `core` (every term the menu allows).
fn menu_spec(opts: &MemoryOptions, core: &PolyCore) -> MemorySpec<f64> {
    let mut all = MemoryChoice::none();
    for o in 0..core.dims.n_outputs() {
        for &g in &opts.groups {
            if offered(&core.dims, o, g) {
                all.groups[o] |= bit(g);
            }
        }
    }
    all.spec(&opts.menu, core)
}

/// Physics restriction: the ambient high-passes and the drift observer are offered to
/// temperature outputs only (the observer only when the model has it: ambient input and a
/// temperature output). The high-passes correct the thermometer's lag, which matters where the
/// thermometer carries the output: the temperature. For strain and pressure the gratings cancel
/// the temperature at once, and a high-pass of T_amb is there only a measure of how fast the
/// temperature moves — a rate, which cross-validation at one pace rewards as a proxy for the
/// gratings' hysteresis and which is wrong at any other pace (DESIGN §4, static fidelity).
fn offered(dims: &Dims, o: usize, g: MemoryGroup) -> bool {
    let temperature = dims.outputs().get(o).is_some_and(|x| x.quantity == Quantity::Temperature);
    match g {
        MemoryGroup::DriftObserver => dims.has_observer() && temperature,
        MemoryGroup::AmbientHighPass => temperature,
        _ => true,
    }
}

/// Whether group `g` can have a term for some output of `dims`: the ambient high-passes need
/// the ambient input (and a temperature output), the drift observer the ambient input and a
/// temperature output (reports leave the others out: Table 3 removes only groups that exist).
pub(crate) fn applies(dims: &Dims, g: MemoryGroup) -> bool {
    (g != MemoryGroup::AmbientHighPass || dims.ambient()) && (0..dims.n_outputs()).any(|o| offered(dims, o, g))
}

/// The memory vectors of a set of rows, [`Dims::memory_len`] values per row.
pub struct MemoryTerms {
    len: usize,
    values: Vec<f64>,
}

impl MemoryTerms {
    /// The memory vector of the `r`-th row.
    pub fn row(&self, r: usize) -> &[f64] {
        &self.values[r * self.len..(r + 1) * self.len]
    }
    /// Number of rows.
    pub(crate) fn rows(&self) -> usize {
        self.values.len().checked_div(self.len).unwrap_or(0)
    }
}

/// The memory vector at each of `rows` (sorted ascending), the bank having seen every sample
/// the compensator would accept (finite Δλ, T_amb with ambient, and t) from the first.
pub fn memory_terms(spec: &MemorySpec<f64>, dims: &Dims, d: &Dataset, rows: &[usize]) -> MemoryTerms {
    let all: Vec<usize> = (0..dims.memory_len()).collect();
    memory_terms_of(spec, dims, d, rows, &all)
}

/// [`memory_terms`] keeping only the terms `keep` (indices into the memory vector, in that
/// order): a row holds `keep.len()` numbers, so a fit that uses a few terms over millions of
/// rows holds only those.
pub(crate) fn memory_terms_of(
    spec: &MemorySpec<f64>,
    dims: &Dims,
    d: &Dataset,
    rows: &[usize],
    keep: &[usize],
) -> MemoryTerms {
    let len = keep.len();
    let mut values = Vec::with_capacity(rows.len() * len);
    walk_bank(spec, dims, d, rows, |_, m, _| values.extend(keep.iter().map(|&k| m.map_or(f64::NAN, |m| m[k]))));
    MemoryTerms { len, values }
}

/// Run `spec`'s bank over the samples of `d` up to the last of `rows` (sorted ascending) as the
/// compensator runs it — every sample it accepts (finite Δλ, T_amb with ambient, and t: a model
/// with memory terms reads time) from the first — and hand `at(bank, m, t_s)` each of `rows`,
/// with its memory vector `m` (`None` for a sample the compensator refuses).
pub(crate) fn walk_bank(
    spec: &MemorySpec<f64>,
    dims: &Dims,
    d: &Dataset,
    rows: &[usize],
    mut at: impl FnMut(&MemoryBank<f64>, Option<&[f64; MAX_MEMORY]>, f64),
) {
    let mut bank = MemoryBank::<f64>::new(spec, dims);
    let end = rows.last().map(|&i| i + 1).unwrap_or(0);
    let mut want = rows.iter().peekable();
    for i in 0..end {
        let s = d.sample(i);
        let ok =
            s.dl().iter().all(|v| v.is_finite()) && (!dims.ambient() || s.t_amb_c.is_finite()) && s.t_s.is_finite();
        let m: Option<[f64; MAX_MEMORY]> = ok.then(|| bank.update(&s.dl_pm, s.t_amb_c, s.t_s));
        if want.peek() == Some(&&i) {
            want.next();
            at(&bank, m.as_ref(), s.t_s);
        }
    }
}

/// The memory terms output `o` may use from the groups in `groups` that `spec` computes.
fn columns(dims: &Dims, spec: &MemorySpec<f64>, o: usize, groups: &[MemoryGroup]) -> Vec<usize> {
    (0..dims.memory_len())
        .filter(|&k| {
            spec.term(dims, k)
                .is_some_and(|t| t.parameter > 0.0 && groups.contains(&t.group) && offered(dims, o, t.group))
        })
        .collect()
}

/// The core's values B·φ of every output, given φ at a sample (its memory terms left out).
fn static_values(core: &PolyCore, ph: &[f64; MAX_POLY]) -> [f64; MAX_OUTPUTS] {
    std::array::from_fn(|o| core.poly[o].iter().zip(ph).map(|(b, f)| b * f).sum())
}

/// Fit Γ for `choice` on `rows`, on what the static calibration `core` (B, no memory terms)
/// leaves: the returned core has `core`'s B unchanged, the memory spec of the choice and every
/// output's Γ row from a ridge least squares on its residual. Outputs without reference keep
/// zeros.
///
/// One tall-skinny QR of [m | r_1 … r_M] over the union of every output's memory columns serves
/// all outputs: for output o with columns S, ‖r_o − m_S γ‖² = ‖(Qᵀr)_o − R_S γ‖² + const, so its
/// problem is the small one [R_S; penalty rows] γ ≈ [(Qᵀr)_o; 0], solved by QR and SVD.
pub(crate) fn fit(
    d: &Dataset,
    rows: &[usize],
    core: &PolyCore,
    menu: &MemorySpec<f64>,
    choice: &MemoryChoice,
) -> Result<PolyCore, TrainerError> {
    let mut out = core.clone();
    out.gamma = [[0.0; MAX_MEMORY]; MAX_OUTPUTS];
    if !choice.any() {
        return Ok(out);
    }
    let spec = choice.spec(menu, core);
    let dims = core.dims;
    let n_out = dims.n_outputs();
    let n = rows.len();
    // Per output: its memory columns (indices into the memory vector).
    let cols: Vec<Vec<usize>> = (0..n_out)
        .map(|o| {
            let groups: Vec<MemoryGroup> = MemoryGroup::ALL.iter().copied().filter(|&g| choice.uses(o, g)).collect();
            columns(&dims, &spec, o, &groups)
        })
        .collect();
    let mem_u: Vec<usize> = (0..dims.memory_len()).filter(|k| cols.iter().any(|mc| mc.contains(k))).collect();
    let p = mem_u.len();
    if n < p + 1 {
        return Err(TrainerError::fit(format!("Model-H memory terms: {n} samples for {p} unknowns")));
    }
    // Only the union's terms are kept (row r's `c`-th number is term `mem_u[c]`).
    let m = memory_terms_of(&spec, &dims, d, rows, &mem_u);
    let refs = d.references_of(&dims);
    let r_aug = super::linalg::triangular_rows(n, p + n_out, |r, buf| {
        let i = rows[r];
        let values = static_values(core, &core.phi_at(d, i));
        buf[..p].copy_from_slice(m.row(r));
        for o in 0..n_out {
            buf[p + o] = super::design::residual(&refs, i, o, &values);
        }
    });
    // Standard deviation of each memory column over the rows: the ridge acts on the
    // standardised terms.
    // Two passes in row order (the terms are stored row by row), each summing every column in
    // the same order as a pass per column would.
    let mut mean = vec![0.0; mem_u.len()];
    for r in 0..m.rows() {
        let row = m.row(r);
        for (acc, &v) in mean.iter_mut().zip(row) {
            *acc += v;
        }
    }
    mean.iter_mut().for_each(|v| *v /= n as f64);
    let mut var = vec![0.0; mem_u.len()];
    for r in 0..m.rows() {
        let row = m.row(r);
        for ((acc, &v), &mu) in var.iter_mut().zip(row).zip(&mean) {
            *acc += (v - mu).powi(2);
        }
    }
    let sd: Vec<f64> = var
        .iter()
        .map(|&v| {
            let var = v / n as f64;
            if var > 0.0 {
                var.sqrt()
            } else {
                1.0
            }
        })
        .collect();
    let q = r_aug.nrows();
    for (o, mc) in cols.iter().enumerate() {
        if mc.is_empty() {
            continue;
        }
        // Positions of this output's columns in the union.
        let at: Vec<usize> = mc.iter().map(|k| mem_u.iter().position(|x| x == k).unwrap_or(0)).collect();
        let pen = (choice.lambda[o] * n as f64).sqrt();
        let x = DMatrix::from_fn(q + mc.len(), mc.len(), |r, c| {
            if r < q {
                r_aug[(r, at[c])]
            } else if c == r - q {
                pen * sd[at[c]]
            } else {
                0.0
            }
        });
        let y = DMatrix::from_fn(q + mc.len(), 1, |r, _| if r < q { r_aug[(r, p + o)] } else { 0.0 });
        let gamma = super::linalg::lstsq(x, y, "Model-H memory terms")?;
        for (c, &k) in mc.iter().enumerate() {
            out.gamma[o][k] = gamma[(c, 0)];
        }
    }
    out.memory = spec;
    Ok(out)
}

/// Rows per block of the memory cross-validation's Gram sums.
const GRAM_BLOCK: usize = 512;

/// Sufficient statistics of one part of a fold (its training or its validation rows) over the
/// full-menu memory terms X = m and the static calibration's residual r = y − Bφ: XᵀX, and per
/// output Xᵀr and rᵀr.
struct Gram {
    xtx: DMatrix<f64>,
    /// Σ x per column (for the columns' variances).
    sum: DVector<f64>,
    xty: Vec<DVector<f64>>,
    yty: Vec<f64>,
    n: usize,
}

/// One fold's [`Gram`]s and the full-menu spec its memory terms come from.
struct FoldStats {
    spec: MemorySpec<f64>,
    train: Gram,
    val: Gram,
}

/// One fold for the memory cross-validation: its training core and rows.
pub(crate) struct FoldInput<'a> {
    pub core: &'a PolyCore,
    pub train: &'a [usize],
    pub val: &'a [usize],
}

/// One evaluated menu point (for the audit).
#[derive(Clone, Debug, serde::Serialize)]
pub struct MemoryCvRow {
    pub output: usize,
    pub groups: Vec<&'static str>,
    pub lambda: f64,
    /// Pooled validation RMSE of the core with these memory terms.
    pub cv_rmse: f64,
}

/// The layout of the full-menu design: every memory slot ([`Dims::memory_len`]); the targets
/// are the residuals of the fold's static calibration.
fn fold_stats(d: &Dataset, f: &FoldInput<'_>, opts: &MemoryOptions) -> FoldStats {
    let dims = f.core.dims;
    let n_out = dims.n_outputs();
    let p_all = dims.memory_len();
    let spec = menu_spec(opts, f.core);
    let mut rows: Vec<usize> = f.train.iter().chain(f.val.iter()).copied().collect();
    rows.sort_unstable();
    rows.dedup();
    let m = memory_terms(&spec, &dims, d, &rows);
    let pos = |i: usize| rows.binary_search(&i).unwrap_or(0);
    let refs = d.references_of(&dims);
    // Sums over blocks of rows as matrix products (XᵀX and Xᵀy of each block added in block
    // order): the same sums as row by row, at matrix-product speed.
    let gram = |set: &[usize]| {
        let mut xtx = DMatrix::<f64>::zeros(p_all, p_all);
        let mut xty = DMatrix::<f64>::zeros(p_all, n_out);
        let mut yty = vec![0.0; n_out];
        let mut sum = DVector::<f64>::zeros(p_all);
        for block in set.chunks(GRAM_BLOCK) {
            let mut x = DMatrix::<f64>::zeros(p_all, block.len());
            let mut y = DMatrix::<f64>::zeros(n_out, block.len());
            for (r, &i) in block.iter().enumerate() {
                let mut col = x.column_mut(r);
                for (o, &v) in col.iter_mut().zip(m.row(pos(i))) {
                    *o = v;
                }
                let values = static_values(f.core, &f.core.phi_at(d, i));
                for o in 0..n_out {
                    let v = super::design::residual(&refs, i, o, &values);
                    y[(o, r)] = v;
                    yty[o] += v * v;
                }
            }
            // x holds Xᵀ (one row per column), so XᵀX = x·xᵀ and Xᵀy = x·yᵀ.
            xtx.gemm(1.0, &x, &x.transpose(), 1.0);
            xty.gemm(1.0, &x, &y.transpose(), 1.0);
            sum += x.column_sum();
        }
        let xty = (0..n_out).map(|o| xty.column(o).into_owned()).collect();
        Gram { xtx, sum, xty, yty, n: set.len() }
    };
    FoldStats { train: gram(f.train), val: gram(f.val), spec }
}

/// Validation SSE of output `o` with memory columns `cols` (indices into the full menu) and
/// penalty `lambda` on them.
fn val_sse(st: &FoldStats, o: usize, cols: &[usize], lambda: f64) -> Option<f64> {
    let (a, b) = (&st.train.xtx, &st.train.xty[o]);
    let (av, bv, yy) = (&st.val.xtx, &st.val.xty[o], st.val.yty[o]);
    let n = st.train.n as f64;
    let p = cols.len();
    if p == 0 {
        return Some(yy);
    }
    let mut h = DMatrix::<f64>::zeros(p, p);
    let mut g = DVector::<f64>::zeros(p);
    for (r, &i) in cols.iter().enumerate() {
        for (c, &j) in cols.iter().enumerate() {
            h[(r, c)] = a[(i, j)];
        }
        g[r] = b[i];
        // Penalty on the standardised term: λ·n·var(column).
        let mean = st.train.sum[i] / n;
        let var = (a[(i, i)] / n - mean * mean).max(0.0);
        h[(r, r)] += lambda * n * if var > 0.0 { var } else { 1.0 };
    }
    // A tiny relative jitter keeps an exactly collinear menu solvable; it is far below λ.
    let jitter = 1e-12 * (0..p).map(|r| h[(r, r)]).fold(0.0, f64::max);
    for r in 0..p {
        h[(r, r)] += jitter;
    }
    let beta = h.cholesky()?.solve(&g);
    let mut sse = yy;
    for (r, &i) in cols.iter().enumerate() {
        sse -= 2.0 * beta[r] * bv[i];
        for (c, &j) in cols.iter().enumerate() {
            sse += beta[r] * av[(i, j)] * beta[c];
        }
    }
    Some(sse.max(0.0))
}

/// Choose, per output, the memory groups and λ with the lowest pooled validation error over
/// the folds (ties: fewer groups, then larger λ). The hold-out is never seen: the folds are
/// inside the calibration batch.
pub(crate) fn select(
    d: &Dataset,
    folds: &[FoldInput<'_>],
    opts: &MemoryOptions,
) -> Result<(MemoryChoice, Vec<MemoryCvRow>), TrainerError> {
    if !opts.enabled() || folds.is_empty() {
        return Ok((MemoryChoice::none(), Vec::new()));
    }
    let stats: Vec<FoldStats> = super::par::par_map(folds, |f| fold_stats(d, f, opts));
    let n_val: usize = stats.iter().map(|s| s.val.n).sum();
    let offered_groups: Vec<MemoryGroup> =
        MemoryGroup::ALL.iter().copied().filter(|g| opts.groups.contains(g)).collect();
    let mut choice = MemoryChoice::none();
    let mut rows = Vec::new();
    let dims = folds[0].core.dims;
    for o in 0..dims.n_outputs() {
        let mine: Vec<MemoryGroup> = offered_groups.iter().copied().filter(|&g| offered(&dims, o, g)).collect();
        // (sse, number of groups, -λ, mask, λ)
        let mut best: Option<(f64, u32, f64, u8, f64)> = None;
        for mask in 0u8..(1 << mine.len()) {
            let groups: Vec<MemoryGroup> =
                mine.iter().enumerate().filter(|(b, _)| mask & (1 << b) != 0).map(|(_, &g)| g).collect();
            let group_mask = groups.iter().fold(0u8, |a, &g| a | bit(g));
            // Each fold's columns (indices into its full design) for these groups.
            let fold_cols: Vec<Vec<usize>> =
                stats.iter().zip(folds).map(|(st, _)| columns(&dims, &st.spec, o, &groups)).collect();
            let lambdas: &[f64] = if groups.is_empty() { &[0.0] } else { &opts.lambdas };
            for &lambda in lambdas {
                let sse: f64 = stats
                    .iter()
                    .zip(&fold_cols)
                    .map(|(st, cols)| val_sse(st, o, cols, lambda).unwrap_or(f64::INFINITY))
                    .sum();
                let rmse = (sse / n_val.max(1) as f64).sqrt();
                rows.push(MemoryCvRow {
                    output: o,
                    groups: groups.iter().map(|g| g.name()).collect(),
                    lambda,
                    cv_rmse: rmse,
                });
                let cand = (sse, groups.len() as u32, -lambda, group_mask, lambda);
                let better = match &best {
                    None => true,
                    Some(b) => (cand.0, cand.1, cand.2).partial_cmp(&(b.0, b.1, b.2)) == Some(std::cmp::Ordering::Less),
                };
                if better && sse.is_finite() {
                    best = Some(cand);
                }
            }
        }
        if let Some((_, _, _, mask, lambda)) = best {
            choice.groups[o] = mask;
            choice.lambda[o] = lambda;
        }
    }
    Ok((choice, rows))
}
