//! The schema of `<model stem>.metrics.json`: everything `evaluate` and `demo` measure about
//! one scenario and seed, as [`Metrics`] (`fbg_report::Metrics` with the trainer's selection and
//! configuration types, which only the trainer has). The studies fill it ([`super::studies`]),
//! the tables render it ([`super::tables`]), the report reads it back (`crate::report::load`).

use crate::fit::static_fidelity::StaticAudit;
use crate::fit::{self, Selection};

pub use fbg_report::{BudgetRow, DriftSweep, RecalStudy, StaticFidelity, Table2};

/// Everything measured about one scenario and seed.
pub type Metrics = fbg_report::Metrics<SelectionSummary, fit::Config>;

/// One ablation configuration (Table 3).
pub type AblationRow = fbg_report::AblationRow<fit::Config>;

/// Both models' static gains over the calibration batch and what Model-H's memory groups and
/// RBF residual add ([`StaticAudit`]).
pub fn static_fidelity(a: &StaticAudit) -> StaticFidelity {
    let mut contributions: Vec<(String, Vec<f64>)> =
        a.contributions.memory.iter().map(|(g, v)| (g.to_string(), v.clone())).collect();
    contributions.push(("rbf".into(), a.contributions.rbf.clone()));
    StaticFidelity { gain_p: a.model_p.gain.clone(), gain_h: a.model_h.gain.clone(), contributions }
}

/// The chosen hyper-parameters and the cross-validation figures behind them.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SelectionSummary {
    pub chosen: fit::Config,
    pub cv_rmse_p: Vec<f64>,
    pub cv_rmse_h: Vec<f64>,
    pub var_model_p: Vec<fit::VarModel>,
    pub var_model_h: Vec<fit::VarModel>,
    /// The drift's walk rate read from Model-P's validation errors \[pm²/s\] (before any
    /// stated floor; `None`: not read).
    pub drift_rate_pm2_per_s: Option<f64>,
    pub folds: Vec<(usize, usize)>,
    pub grid_points: usize,
    /// The best ten grid points.
    pub top: Vec<fit::select::CvRow>,
}

impl SelectionSummary {
    /// For models evaluated as given (no selection ran here): the chosen configuration, NaN
    /// cross-validation figures for `n_out` outputs, no grid.
    pub fn given(chosen: fit::Config, n_out: usize) -> Self {
        SelectionSummary {
            chosen,
            cv_rmse_p: vec![f64::NAN; n_out],
            cv_rmse_h: vec![f64::NAN; n_out],
            var_model_p: Default::default(),
            var_model_h: Default::default(),
            drift_rate_pm2_per_s: None,
            folds: vec![],
            grid_points: 0,
            top: vec![],
        }
    }

    pub fn from(s: &Selection) -> Self {
        SelectionSummary {
            chosen: s.chosen,
            cv_rmse_p: s.cv_rmse_p.clone(),
            cv_rmse_h: s.cv_rmse_h.clone(),
            var_model_p: s.var_model_p.clone(),
            var_model_h: s.var_model_h.clone(),
            drift_rate_pm2_per_s: s.drift_rate_pm2_per_s,
            folds: s.folds.clone(),
            grid_points: s.rows.len(),
            top: s.rows.iter().take(10).cloned().collect(),
        }
    }
}
