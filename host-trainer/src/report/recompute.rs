//! The hold-out estimates recomputed from the models and the data (the figures draw these,
//! and the checks compare them with metrics.json), Model-H's answer split into its parts, and
//! the re-simulation of data.meta.json.

use fbg_shared::layout::MAX_OUTPUTS;
use fbg_shared::Estimate;

use super::Inputs;
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::score::{evaluate_holdout, ModelEval};
use crate::fit::HostParams;
use crate::sim::{simulate, Simulation};

/// What the report computes afresh from its inputs.
pub(super) struct Recomputed {
    pub(super) ev_p: ModelEval,
    pub(super) est_p: Vec<Estimate<f64>>,
    pub(super) ev_h: ModelEval,
    pub(super) est_h: Vec<Estimate<f64>>,
    /// Model-H's parts at each usable hold-out row ([`contributions`]).
    pub(super) parts_h: Vec<[[f64; MAX_OUTPUTS]; 3]>,
    /// The re-simulated installation, unchecked; `None` without data.meta.json.
    pub(super) sim: Option<Simulation>,
}

impl Recomputed {
    /// Both models over the usable hold-out rows `hold`, the simulation beside them.
    pub(super) fn of(inp: &Inputs, hold: &[usize]) -> Result<Recomputed, TrainerError> {
        let d = &inp.data;
        let ((rp, rh), sim) = rayon::join(
            || rayon::join(|| evaluate_holdout(&inp.model_p, d), || evaluate_holdout(&inp.model_h, d)),
            || inp.meta.as_ref().map(|mm| simulate(&mm.scenario, mm.seed)),
        );
        let (ev_p, est_p) = rp?;
        let (ev_h, est_h) = rh?;
        let parts_h = contributions(&inp.model_h, d, hold, &est_h)?;
        Ok(Recomputed { ev_p, est_p, ev_h, est_h, parts_h, sim })
    }
}

/// Model-H's answer at each of `hold` split into [core Bφ, memory terms Γm, RBF Wψ] per
/// channel, each part from `fbg_shared` with the later parts removed (empty for a model with
/// neither memory nor centres).
pub(super) fn contributions(
    h: &HostParams,
    d: &Dataset,
    hold: &[usize],
    est_h: &[fbg_shared::Estimate<f64>],
) -> Result<Vec<[[f64; fbg_shared::layout::MAX_OUTPUTS]; 3]>, TrainerError> {
    if !h.has_memory() && h.centres.is_empty() {
        return Ok(Vec::new());
    }
    let mut no_rbf = h.clone();
    no_rbf.centres.clear();
    let mut core_only = no_rbf.clone();
    core_only.memory = fbg_shared::MemorySpec::off();
    core_only.gamma = [[0.0; fbg_shared::layout::MAX_MEMORY]; fbg_shared::layout::MAX_OUTPUTS];
    let (a, b) = rayon::join(|| crate::fit::run(&core_only, d, hold), || crate::fit::run(&no_rbf, d, hold));
    let (a, b) = (a?, b?);
    Ok(a.iter()
        .zip(&b)
        .zip(est_h)
        .map(|((c, m), f)| {
            [
                c.values,
                std::array::from_fn(|k| m.values[k] - c.values[k]),
                std::array::from_fn(|k| f.values[k] - m.values[k]),
            ]
        })
        .collect())
}
