//! The schema of `<model stem>.metrics.json`: everything `evaluate` and `demo` measure about
//! one scenario and seed, as [`Metrics`]. The studies fill it ([`super::studies`]), the tables
//! render it ([`super::tables`]), the report reads it back (`crate::report::load`).

use crate::eval::parity::ParityReport;
use crate::eval::score::{ChannelMetrics, ModelEval};
use crate::fit::{self, Selection};

/// Table 2: both models on the hold-out.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Table2 {
    pub model_p: ModelEval,
    pub model_h: ModelEval,
    /// Gain of Model-H over Model-P in % of Model-P's RMSE.
    pub gain_pct: Vec<f64>,
    /// Oracle-floor RMSE per output, when the data come from the simulator.
    pub oracle_floor: Option<Vec<f64>>,
    /// Model-H RMSE above the floor as a multiple of the floor.
    pub h_over_floor: Option<Vec<f64>>,
}

/// The drift sweep: hold-out RMSE against σ_d with both models refitted each time.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DriftSweep {
    pub factors: Vec<f64>,
    /// σ_d [pm per step] of each point.
    pub sigma_d_pm: Vec<f64>,
    pub rmse_p: Vec<Vec<f64>>,
    pub rmse_h: Vec<Vec<f64>>,
    /// Least-squares slope of RMSE against σ_d [output unit per (pm/step)]: the
    /// drift-sensitivity index.
    pub slope_p: Vec<f64>,
    pub slope_h: Vec<f64>,
    /// Intercepts of those lines.
    pub intercept_p: Vec<f64>,
    pub intercept_h: Vec<f64>,
}

/// One ablation configuration (Table 3).
#[derive(Clone, Debug, serde::Serialize)]
pub struct AblationRow {
    pub name: String,
    pub note: String,
    pub channels: Vec<ChannelMetrics>,
    /// Hyper-parameters the variant chose (absent for the polynomial only).
    pub config: Option<fit::Config>,
}

/// One error-budget row: the scenario with one artefact switched off.
#[derive(Clone, Debug, serde::Serialize)]
pub struct BudgetRow {
    /// Artefact switched off ("none" = full scenario, "all" = physics and nothing else).
    pub effect_off: String,
    pub rmse_p: Vec<f64>,
    pub rmse_h: Vec<f64>,
    /// Per-sample oracle of that scenario.
    pub oracle_floor: Vec<f64>,
    /// Why the models could not be refitted for this row (its RMSEs are then NaN): e.g. with
    /// noise off, gratings that respond only to temperature are exactly collinear.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub not_fitted: Option<String>,
}

/// Everything measured about one scenario and seed.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Metrics {
    pub trainer_version: String,
    pub scenario: String,
    pub seed: u64,
    pub samples: usize,
    pub cal_samples: usize,
    pub holdout_samples: usize,
    /// Short names of the model's outputs (`T`, `strain`, `strain2`, `p`), in output order:
    /// every per-output list below follows it.
    pub channels: Vec<String>,
    /// Their units.
    pub units: Vec<String>,
    /// Everything worth a warning, as data: `train`'s (from the model's `coefficients.json`),
    /// then the evaluation's ([`crate::eval::warnings`]). `evaluate` prints them, the report
    /// opens with them.
    pub warnings: Vec<crate::warning::Warning>,
    pub selection: SelectionSummary,
    pub table2: Table2,
    pub drift_sweep: Option<DriftSweep>,
    pub ablation: Option<Vec<AblationRow>>,
    pub error_budget: Option<Vec<BudgetRow>>,
    pub parity: Option<ParityReport>,
    /// Field recalibration after the installation changes (short batches vs a full refit).
    pub recalibration: Option<Vec<RecalStudy>>,
    /// Both models' static gains over the calibration batch (DESIGN §4, static fidelity).
    pub static_fidelity: Option<StaticFidelity>,
    /// The installation at other paces and on a steps record (simulated data only).
    pub pace: Option<crate::eval::pace::PaceStudy>,
    /// Wall time of each stage \[s\] (informational; speed is measured by `cargo xtask bench`).
    pub timings_s: Vec<(String, f64)>,
}

/// Per output, the slope of the truth on each model's settled reading over the
/// calibration batch, and the RMS of what Model-H's memory groups and RBF residual add
/// ([`crate::fit::static_fidelity::StaticAudit`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StaticFidelity {
    #[serde(deserialize_with = "crate::eval::pace::nullable")]
    pub gain_p: Vec<f64>,
    #[serde(deserialize_with = "crate::eval::pace::nullable")]
    pub gain_h: Vec<f64>,
    /// (part, RMS per output): the memory groups Model-H uses, then `rbf`.
    pub contributions: Vec<(String, Vec<f64>)>,
}

impl StaticFidelity {
    pub fn of(a: &crate::fit::static_fidelity::StaticAudit) -> Self {
        let mut contributions: Vec<(String, Vec<f64>)> =
            a.contributions.memory.iter().map(|(g, v)| (g.to_string(), v.clone())).collect();
        contributions.push(("rbf".into(), a.contributions.rbf.clone()));
        StaticFidelity { gain_p: a.model_p.gain.clone(), gain_h: a.model_h.gain.clone(), contributions }
    }
}

/// The chosen hyper-parameters and the cross-validation figures behind them.
#[derive(Clone, Debug, serde::Serialize)]
pub struct SelectionSummary {
    pub chosen: fit::Config,
    pub cv_rmse_p: Vec<f64>,
    pub cv_rmse_h: Vec<f64>,
    pub var_model_p: Vec<fit::VarModel>,
    pub var_model_h: Vec<fit::VarModel>,
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
            folds: s.folds.clone(),
            grid_points: s.rows.len(),
            top: s.rows.iter().take(10).cloned().collect(),
        }
    }
}

/// How much of a full recalibration's gain a short batch recovers when the installation changes.
#[derive(Clone, Debug, serde::Serialize)]
pub struct RecalStudy {
    pub batch_hours: f64,
    pub batch_samples: usize,
    /// Seed of the original installation and of the changed one (new gratings' dispersion, new
    /// drift, new environment).
    pub seed_old: u64,
    pub seed_new: u64,
    /// Hold-out RMSE on the new installation (per output) of: the old model as is, the old model
    /// recalibrated on the short batch, and a full recalibration (same hyper-parameters, the new
    /// installation's whole calibration batch). Model-H and Model-P.
    pub h_old: Vec<f64>,
    pub h_short: Vec<f64>,
    pub h_full: Vec<f64>,
    pub p_old: Vec<f64>,
    pub p_short: Vec<f64>,
    pub p_full: Vec<f64>,
    /// (old − short) / (old − full) for Model-H, per output.
    pub recovered_fraction_h: Vec<f64>,
}
