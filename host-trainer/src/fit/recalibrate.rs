//! Field recalibration (the paper's future-scope items (i) and (iv)): refit only what
//! a short batch can support — per output the offset and gain of the polynomial core, and the
//! residual weights W on the kept centres. How much of a full recalibration's gain that
//! recovers when the installation changes is a study: `crate::eval::studies::recalibration`.

use nalgebra::DMatrix;

use fbg_shared::layout::MAX_OUTPUTS;

use super::design::{design_matrix, run};
use super::host::HostParams;
use super::linalg;
use super::provenance::today_yyyymmdd;
use super::residual::residual_targets;
use crate::data::{Column, Dataset};
use crate::error::TrainerError;

/// Prior standard deviation of a core gain change (gauge-factor dispersion is ~3 %).
pub(crate) const GAIN_PRIOR_SIGMA: f64 = 0.05;
/// Weight of the old residual weights in samples per centre.
pub(crate) const PRIOR_SAMPLES_PER_CENTRE: f64 = 20.0;

/// What a recalibration changed, and the check on the batch that decided it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Recalibration {
    /// Batch samples used.
    pub n_batch: usize,
    /// Batch samples the candidate refits were fitted on (the batch's first 70 %) ...
    pub n_fit: usize,
    /// ... and judged on (its last 30 %): the check that keeps or reverts each output.
    pub n_check: usize,
    /// Per output: offset a and gain b applied to the polynomial core, y ≈ a + b·core(x)
    /// ((0, 1) for an output whose update was reverted).
    pub offset_gain: Vec<(f64, f64)>,
    /// What was refitted per output (`Keep` for an output whose update was reverted).
    pub core_update: Vec<CoreUpdate>,
    /// Whether the residual weights were updated (on the outputs the check kept).
    pub w_updated: bool,
    /// Per output: RMS error of the old model on the batch's last 30 % (NaN without reference).
    pub check_rmse_old: Vec<f64>,
    /// Per output: RMS error on the batch's last 30 % of the update fitted on its first 70 %
    /// (NaN without reference).
    pub check_rmse_update: Vec<f64>,
    /// Per output: what the check decided.
    pub verdict: Vec<Verdict>,
    /// In-sample RMS residual on the batch after the refit (NaN for an output without
    /// reference in the batch).
    pub batch_rmse: Vec<f64>,
}

/// What the batch's own check decided for an output. The check uses the batch only: the update
/// is fitted on its first 70 % and compared with the old model on its last 30 %.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The update predicted the batch's last 30 % better than the old model: kept, then
    /// refitted on the whole batch.
    Updated,
    /// The update did not predict the batch's last 30 % better: the old coefficients are kept.
    Reverted,
    /// The update did not predict the batch's last 30 % better, but was written because the
    /// caller asked for it (`--allow-worse`).
    WorseWritten,
    /// Nothing to update (no refit predicted the batch's last 30 % better): old coefficients.
    Unchanged,
    /// The batch has no reference for this output: old coefficients.
    NoReference,
}

impl Verdict {
    /// Whether the output's coefficients change.
    pub fn changes(self) -> bool {
        matches!(self, Verdict::Updated | Verdict::WorseWritten)
    }

    /// Human text for the CLI (the check's RMSE follows it).
    pub fn text(self) -> &'static str {
        match self {
            Verdict::Updated => "kept: better on the batch's last 30 %",
            Verdict::Reverted => "reverted, old coefficients kept: not better on the batch's last 30 %",
            Verdict::WorseWritten => "written because of --allow-worse although not better on the batch's last 30 %",
            Verdict::Unchanged => "old coefficients kept: no refit did better on the batch's last 30 %",
            Verdict::NoReference => "old coefficients kept: no reference in the batch",
        }
    }
}

/// Which refits a recalibration applied to an output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum CoreUpdate {
    /// The batch gave no evidence of a change: the old core is kept.
    Keep,
    /// Offset only.
    Offset,
    /// Offset and gain.
    OffsetGain,
    /// Γ refitted on what the core leaves, shrunk towards the old one (memory models only; B,
    /// the static calibration, is kept: a short batch moves the static response only through
    /// the offset and gain refits).
    Memory,
}

/// Refit offset/gain of the core and W of `old` on the batch rows `batch` of `d`, keeping an
/// output's update only where the batch's own check scores it better
/// ([`recalibrate_with`] without `allow_worse`).
pub fn recalibrate(
    old: &HostParams,
    d: &Dataset,
    batch: &[usize],
) -> Result<(HostParams, Recalibration), TrainerError> {
    recalibrate_with(old, d, batch, false)
}

/// Refit offset/gain of the core and W of `old` on the batch rows `batch` of `d`.
///
/// A short batch can hurt as easily as help (two hours barely move the temperature, and
/// errors are correlated over hours), so each refit must earn its place, and only the batch
/// decides: the candidates are fitted on the first 70 % of the batch and compared on the last
/// 30 % — per output: keep, offset, offset + gain (and Γ for a memory model); then W towards the
/// old weights or not. An output whose update (core and W together, fitted on the first 70 %)
/// does not predict the last 30 % better than the old model keeps the old coefficients (unless
/// `allow_worse`); the kept updates are then refitted on the whole batch. Model-P (no centres)
/// gets the core refit only. No row outside `batch` plays a part beyond feeding the model's
/// memory terms their history: a hold-out checked afterwards is an independent check, and can
/// come out worse.
pub fn recalibrate_with(
    old: &HostParams,
    d: &Dataset,
    batch: &[usize],
    allow_worse: bool,
) -> Result<(HostParams, Recalibration), TrainerError> {
    let batch: Vec<usize> = batch.iter().copied().filter(|&i| d.usable(i)).collect();
    if batch.len() < 20 {
        return Err(TrainerError::Dataset {
            message: format!("{} usable batch samples; a recalibration needs at least 20", batch.len()),
        });
    }
    let cut = batch.len() * 7 / 10;
    let (fit_part, val_part) = batch.split_at(cut);
    let check = Check { old, d, refs: d.references_of(&old.dims) };
    let old_check = check.mses(old, val_part)?;
    let mut choice = check.core_updates(fit_part, val_part, &old_check)?;
    let (candidate, w_updated) = check.candidate(fit_part, val_part, &choice)?;
    // The check, per output, on the last 30 % only: the candidate against the old model.
    let cand_check = check.mses(&candidate, val_part)?;
    let verdict: Vec<Verdict> = (0..old.dims.n_outputs())
        .map(|c| {
            if !check.has(c) {
                Verdict::NoReference
            } else if choice[c] == CoreUpdate::Keep && !w_updated {
                Verdict::Unchanged
            } else if cand_check[c] < old_check[c] {
                Verdict::Updated
            } else if allow_worse {
                Verdict::WorseWritten
            } else {
                Verdict::Reverted
            }
        })
        .collect();
    for (c, v) in verdict.iter().enumerate() {
        if !v.changes() {
            choice[c] = CoreUpdate::Keep;
        }
    }
    let w_updated = w_updated && verdict.iter().any(|v| v.changes());
    let Refit { model, offset_gain, batch_rmse } = check.refit(&batch, &choice, w_updated, &verdict)?;
    Ok((
        model,
        Recalibration {
            n_batch: batch.len(),
            n_fit: fit_part.len(),
            n_check: val_part.len(),
            offset_gain,
            core_update: choice,
            w_updated,
            check_rmse_old: old_check.iter().map(|m| m.sqrt()).collect(),
            check_rmse_update: cand_check.iter().map(|m| m.sqrt()).collect(),
            verdict,
            batch_rmse,
        },
    ))
}

/// A recalibrated model, each output's (offset, gain) and its in-sample RMS residual.
struct Refit {
    model: HostParams,
    offset_gain: Vec<(f64, f64)>,
    batch_rmse: Vec<f64>,
}

/// The old model and the batch's reference of each of its outputs (by measurand): what every
/// refit is scored against.
struct Check<'a> {
    old: &'a HostParams,
    d: &'a Dataset,
    refs: Vec<Column<'a>>,
}

impl Check<'_> {
    /// Whether output `c` was fitted and has a reference in the batch.
    fn has(&self, c: usize) -> bool {
        self.old.fitted[c] && self.refs[c].is_present()
    }

    /// Mean squared error of every output with a reference over `rows` (NaN for the others).
    fn mses(&self, p: &HostParams, rows: &[usize]) -> Result<Vec<f64>, TrainerError> {
        let e = run(p, self.d, rows)?;
        Ok((0..self.old.dims.n_outputs())
            .map(|c| {
                if !self.has(c) {
                    return f64::NAN;
                }
                let refs = &self.refs[c];
                rows.iter().zip(&e).map(|(&i, e)| (e.values[c] - refs[i]).powi(2)).sum::<f64>() / rows.len() as f64
            })
            .collect())
    }

    /// Per output, the core update fitted on `fit_part` that predicts `val_part` best (`Keep`
    /// unless one beats the old model's `old_check`).
    fn core_updates(
        &self,
        fit_part: &[usize],
        val_part: &[usize],
        old_check: &[f64],
    ) -> Result<Vec<CoreUpdate>, TrainerError> {
        let old = self.old;
        let mut choice = vec![CoreUpdate::Keep; old.dims.n_outputs()];
        for (c, chosen) in choice.iter_mut().enumerate() {
            if !self.has(c) {
                continue;
            }
            let mut best = (old_check[c], CoreUpdate::Keep);
            let cands: &[CoreUpdate] = if old.has_memory() {
                &[CoreUpdate::Offset, CoreUpdate::OffsetGain, CoreUpdate::Memory]
            } else {
                &[CoreUpdate::Offset, CoreUpdate::OffsetGain]
            };
            for &cand in cands {
                let mut p = old.clone();
                apply_core(&mut p, self.d, fit_part, c, cand)?;
                let m = self.mses(&p, val_part)?[c];
                if m < best.0 {
                    best = (m, cand);
                }
            }
            *chosen = best.1;
        }
        Ok(choice)
    }

    /// The candidate as fitted on `fit_part`: the `choice` of core updates, and W towards the
    /// old weights if that predicts `val_part` better than the core update alone (whether it
    /// did).
    fn candidate(
        &self,
        fit_part: &[usize],
        val_part: &[usize],
        choice: &[CoreUpdate],
    ) -> Result<(HostParams, bool), TrainerError> {
        let (old, d) = (self.old, self.d);
        let m_out = old.dims.n_outputs();
        let mut candidate = old.clone();
        for (c, &how) in choice.iter().enumerate() {
            apply_core(&mut candidate, d, fit_part, c, how)?;
        }
        if old.centres.is_empty() || !(0..m_out).any(|c| self.has(c)) {
            return Ok((candidate, false));
        }
        let mut trial = candidate.clone();
        update_w(&mut trial, old, d, fit_part)?;
        let (m_trial, m_core) = (self.mses(&trial, val_part)?, self.mses(&candidate, val_part)?);
        let better: Vec<f64> =
            (0..m_out).filter(|&c| self.has(c)).map(|c| m_trial[c] / m_core[c].max(f64::MIN_POSITIVE)).collect();
        if better.iter().sum::<f64>() < better.len() as f64 {
            return Ok((trial, true));
        }
        Ok((candidate, false))
    }

    /// The kept updates (`choice`, W if `w_updated` on the outputs whose `verdict` changes)
    /// refitted on the whole `batch`, with a band never narrower than before.
    fn refit(
        &self,
        batch: &[usize],
        choice: &[CoreUpdate],
        w_updated: bool,
        verdict: &[Verdict],
    ) -> Result<Refit, TrainerError> {
        let (old, d) = (self.old, self.d);
        let m_out = old.dims.n_outputs();
        let mut new = old.clone();
        let mut offset_gain = vec![(0.0, 1.0); m_out];
        for c in 0..m_out {
            offset_gain[c] = apply_core(&mut new, d, batch, c, choice[c])?;
        }
        if w_updated {
            update_w(&mut new, old, d, batch)?;
            for c in (0..m_out).filter(|&c| !verdict[c].changes()) {
                for (n, o) in new.centres.iter_mut().zip(old.centres.iter()) {
                    n.w[c] = o.w[c];
                }
            }
        }
        // Band: never narrower than before; widened if the batch residual says so (with a
        // degrees-of-freedom correction for the refitted numbers).
        let after = run(&new, d, batch)?;
        let p_eff = (2 + if w_updated { old.centres.len() } else { 0 }) as f64;
        let n = batch.len() as f64;
        let mut batch_rmse = vec![f64::NAN; m_out];
        for (c, rmse) in batch_rmse.iter_mut().enumerate() {
            if !self.has(c) {
                continue;
            }
            let refs = &self.refs[c];
            let m = batch.iter().zip(&after).map(|(&i, e)| (e.values[c] - refs[i]).powi(2)).sum::<f64>() / n;
            *rmse = m.sqrt();
            let corrected = if n > p_eff + 1.0 { m * n / (n - p_eff) } else { m * 2.0 };
            new.resid_var[c] = new.resid_var[c].max(corrected);
        }
        new.t_cal_end_s = batch.last().map(|&i| d.t_s[i]).unwrap_or(new.t_cal_end_s);
        new.provenance.n_cal = batch.len() as u32;
        new.provenance.date_yyyymmdd = today_yyyymmdd();
        new.validate().map_err(|e| TrainerError::fit(format!("recalibrated model is invalid: {e}")))?;
        Ok(Refit { model: new, offset_gain, batch_rmse })
    }
}

/// Refit output `c`'s core offset (and gain) on `rows` and fold it into `p.poly[c]`.
fn apply_core(
    p: &mut HostParams,
    d: &Dataset,
    rows: &[usize],
    c: usize,
    how: CoreUpdate,
) -> Result<(f64, f64), TrainerError> {
    if how == CoreUpdate::Keep {
        return Ok((0.0, 1.0));
    }
    if how == CoreUpdate::Memory {
        refit_memory(p, d, rows, c)?;
        return Ok((0.0, 1.0));
    }
    let mut core = p.clone();
    core.centres.clear();
    let est = run(&core, d, rows)?;
    let full = run(p, d, rows)?;
    let n = rows.len() as f64;
    // Regress the error of the full model on the core estimate: y − ŷ ≈ a + (b − 1)·core.
    let xs: Vec<f64> = est.iter().map(|e| e.values[c]).collect();
    let truth = d.reference_of(&p.dims, c);
    let es: Vec<f64> = rows.iter().zip(&full).map(|(&i, e)| truth[i] - e.values[c]).collect();
    let (mx, me) = (xs.iter().sum::<f64>() / n, es.iter().sum::<f64>() / n);
    let db = if how == CoreUpdate::OffsetGain {
        // Gain shrunk towards 1 (prior σ: gauge dispersion is a few %).
        let sxx: f64 = xs.iter().map(|x| (x - mx).powi(2)).sum();
        let sxe: f64 = xs.iter().zip(&es).map(|(x, e)| (x - mx) * (e - me)).sum();
        let s2 = p.resid_var[c].max(f64::MIN_POSITIVE);
        sxe / (sxx + s2 / (GAIN_PRIOR_SIGMA * GAIN_PRIOR_SIGMA))
    } else {
        0.0
    };
    let (a, b) = (me - db * mx, 1.0 + db);
    // The core is Bφ + Γm: the gain scales both.
    for v in p.poly[c].iter_mut().chain(p.gamma[c].iter_mut()) {
        *v *= b;
    }
    p.poly[c][0] += a;
    Ok((a, b))
}

/// Refit output `c`'s Γ row on `rows`, shrunk towards the old one: Δ solves
/// (XᵀX + κ·diag(XᵀX))Δ = Xᵀ(y − ŷ) over X = the memory terms the output uses, with κ making
/// the old calibration count as its own sample count of the batch's design (so a day's batch
/// moves a week's calibration by about a seventh of what it alone would say). B is not touched:
/// refitted jointly with the memory terms on a batch at one pace, it would trade static gain
/// for them (DESIGN §4, static fidelity).
fn refit_memory(p: &mut HostParams, d: &Dataset, rows: &[usize], c: usize) -> Result<(), TrainerError> {
    let m = super::memory_core::memory_terms(&p.memory, &p.dims, d, rows);
    let full = run(p, d, rows)?;
    let truth = d.reference_of(&p.dims, c);
    let mc: Vec<usize> = (0..p.dims.memory_len()).filter(|&k| p.gamma[c][k] != 0.0).collect();
    let q = mc.len();
    if q == 0 {
        return Ok(());
    }
    let mut xtx = DMatrix::<f64>::zeros(q, q);
    let mut xtr = DMatrix::<f64>::zeros(q, 1);
    let mut x = vec![0.0; q];
    for (r, (&i, e)) in rows.iter().zip(&full).enumerate() {
        for (j, &k) in mc.iter().enumerate() {
            x[j] = m.row(r)[k];
        }
        let res = truth[i] - e.values[c];
        for a in 0..q {
            for b in 0..q {
                xtx[(a, b)] += x[a] * x[b];
            }
            xtr[(a, 0)] += x[a] * res;
        }
    }
    let n = rows.len() as f64;
    let kappa = (p.provenance.n_cal.max(1) as f64) / n;
    let mut h = xtx.clone();
    for a in 0..q {
        h[(a, a)] += kappa * xtx[(a, a)].max(f64::MIN_POSITIVE);
    }
    let delta =
        h.cholesky().ok_or_else(|| TrainerError::fit("recalibration: the memory-term system is singular"))?.solve(&xtr);
    for (j, &k) in mc.iter().enumerate() {
        p.gamma[c][k] += delta[(j, 0)];
    }
    Ok(())
}

/// Ridge W towards the old weights on `rows`: W = W_old + (ΨᵀΨ + α'I)⁻¹Ψᵀ(R − ΨW_old), with
/// α' making the old calibration count like `PRIOR_SAMPLES_PER_CENTRE` samples per centre.
fn update_w(p: &mut HostParams, old: &HostParams, d: &Dataset, rows: &[usize]) -> Result<(), TrainerError> {
    let k = p.centres.len();
    let mut zero_w = p.clone();
    for ce in zero_w.centres.iter_mut() {
        ce.w = [0.0; MAX_OUTPUTS];
    }
    let (psi, est) = design_matrix(&zero_w, d, rows)?;
    let r = residual_targets(d, &p.dims, rows, &est);
    let w_old = DMatrix::from_fn(k, p.dims.n_outputs(), |j, o| old.centres[j].w[o]);
    let sys = linalg::RidgeSystem::new(&psi, &(&r - &psi * &w_old))?;
    let mean_diag = (0..k).map(|j| psi.column(j).norm_squared()).sum::<f64>() / k as f64;
    let alpha_prior = PRIOR_SAMPLES_PER_CENTRE * mean_diag / rows.len() as f64 * k as f64;
    let w = &w_old + sys.weights(alpha_prior);
    for (j, ce) in p.centres.iter_mut().enumerate() {
        ce.w = std::array::from_fn(|o| if o < w.ncols() && old.fitted[o] { w[(j, o)] } else { 0.0 });
    }
    Ok(())
}

impl CoreUpdate {
    /// Human text for the CLI.
    pub fn text(self) -> &'static str {
        match self {
            CoreUpdate::Keep => "core kept",
            CoreUpdate::Offset => "core offset refitted",
            CoreUpdate::OffsetGain => "core offset and gain refitted",
            CoreUpdate::Memory => "memory terms refitted (static calibration kept)",
        }
    }
}

/// The first `hours` of calibration samples of `d`.
pub fn first_hours(d: &Dataset, hours: f64) -> Vec<usize> {
    let cal = d.cal_indices();
    let t0 = cal.first().map(|&i| d.t_s[i]).unwrap_or(0.0);
    cal.into_iter().filter(|&i| d.t_s[i] - t0 < hours * 3600.0).collect()
}
