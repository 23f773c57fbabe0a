//! `<model stem>.metrics.json` and `evaluate --json`: everything `evaluate` and `demo` measure
//! about one scenario and seed, as [`Metrics`]. The trainer's studies fill it (`eval::studies`),
//! its tables and its report read it; xtask's bench reads the hold-out figures, the static
//! fidelity and the pace study.
//!
//! Two parts carry the trainer's own model types (the chosen configuration, the band models,
//! the grid): they are type parameters, `S` the selection and `C` a configuration. A reader that
//! does not need them keeps the default, [`Skipped`], which reads anything and keeps nothing.

use serde::{Deserialize, Serialize};

use crate::nan;
use crate::pace::PaceStudy;
use crate::warning::Warning;

/// A part of the file read and dropped.
pub type Skipped = serde::de::IgnoredAny;

/// Everything measured about one scenario and seed.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Metrics<S = Skipped, C = Skipped> {
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
    /// then the evaluation's. `evaluate` prints them, the report opens with them (absent from
    /// metrics written before warnings were recorded).
    #[serde(default)]
    pub warnings: Vec<Warning>,
    /// The chosen hyper-parameters and the cross-validation figures behind them.
    pub selection: S,
    pub table2: Table2,
    pub drift_sweep: Option<DriftSweep>,
    pub ablation: Option<Vec<AblationRow<C>>>,
    pub error_budget: Option<Vec<BudgetRow>>,
    pub parity: Option<ParityReport>,
    /// Field recalibration after the installation changes (short batches vs a full refit).
    #[serde(default)]
    pub recalibration: Option<Vec<RecalStudy>>,
    /// Both models' static gains over the calibration batch (DESIGN §4, static fidelity).
    #[serde(default)]
    pub static_fidelity: Option<StaticFidelity>,
    /// The installation at other paces and on a steps record (simulated data only).
    #[serde(default)]
    pub pace: Option<PaceStudy>,
    /// Wall time of each stage \[s\] (informational; speed is measured by `cargo xtask bench`).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub timings_s: Vec<(String, f64)>,
}

/// Table 2: both models on the hold-out.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Table2 {
    pub model_p: ModelEval,
    pub model_h: ModelEval,
    /// Gain of Model-H over Model-P in % of Model-P's RMSE.
    #[serde(deserialize_with = "nan::read")]
    pub gain_pct: Vec<f64>,
    /// Oracle-floor RMSE per output, when the data come from the simulator.
    #[serde(deserialize_with = "nan::read")]
    pub oracle_floor: Option<Vec<f64>>,
    /// Model-H RMSE above the floor as a multiple of the floor.
    #[serde(deserialize_with = "nan::read")]
    pub h_over_floor: Option<Vec<f64>>,
}

/// A model's hold-out evaluation.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelEval {
    /// Per output of the model, in output order.
    pub channels: Vec<ChannelMetrics>,
    /// Samples with each flag raised (non-finite, out-of-envelope, weak support, implausible,
    /// fallback to Model-P); older files count three.
    #[serde(deserialize_with = "nan::padded")]
    pub flag_counts: [usize; 5],
    /// Fraction of samples with any flag.
    #[serde(deserialize_with = "nan::read")]
    pub flagged_fraction: f64,
}

/// Error statistics of one output.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ChannelMetrics {
    #[serde(deserialize_with = "nan::read")]
    pub rmse: f64,
    #[serde(deserialize_with = "nan::read")]
    pub mae: f64,
    #[serde(deserialize_with = "nan::read")]
    pub r2: f64,
    /// Mean error (estimate − truth).
    #[serde(deserialize_with = "nan::read")]
    pub bias: f64,
    #[serde(deserialize_with = "nan::read")]
    pub max_abs: f64,
    /// Fraction of samples whose truth lies inside the 95 % band.
    #[serde(deserialize_with = "nan::read")]
    pub coverage: f64,
    /// Mean half-width of the band.
    #[serde(deserialize_with = "nan::read")]
    pub mean_band: f64,
    /// Mean error on rising minus falling segments of the output's grating.
    #[serde(deserialize_with = "nan::read")]
    pub hysteresis_index: f64,
    pub n: usize,
}

impl ChannelMetrics {
    /// The metrics of an output the data have no reference for: NaN, none scored.
    pub const ABSENT: ChannelMetrics = ChannelMetrics {
        rmse: f64::NAN,
        mae: f64::NAN,
        r2: f64::NAN,
        bias: f64::NAN,
        max_abs: f64::NAN,
        coverage: f64::NAN,
        mean_band: f64::NAN,
        hysteresis_index: f64::NAN,
        n: 0,
    };
}

/// The drift sweep: hold-out RMSE against σ_d with both models refitted each time.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DriftSweep {
    #[serde(deserialize_with = "nan::read")]
    pub factors: Vec<f64>,
    /// σ_d [pm per step] of each point.
    #[serde(deserialize_with = "nan::read")]
    pub sigma_d_pm: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub rmse_p: Vec<Vec<f64>>,
    #[serde(deserialize_with = "nan::read")]
    pub rmse_h: Vec<Vec<f64>>,
    /// Least-squares slope of RMSE against σ_d [output unit per (pm/step)]: the
    /// drift-sensitivity index.
    #[serde(deserialize_with = "nan::read")]
    pub slope_p: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub slope_h: Vec<f64>,
    /// Intercepts of those lines.
    #[serde(deserialize_with = "nan::read")]
    pub intercept_p: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub intercept_h: Vec<f64>,
}

/// One ablation configuration (Table 3).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct AblationRow<C = Skipped> {
    pub name: String,
    pub note: String,
    pub channels: Vec<ChannelMetrics>,
    /// Hyper-parameters the variant chose (absent for the polynomial only).
    pub config: Option<C>,
}

/// One error-budget row: the scenario with one artefact switched off.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BudgetRow {
    /// Artefact switched off ("none" = full scenario, "all" = physics and nothing else).
    pub effect_off: String,
    #[serde(deserialize_with = "nan::read")]
    pub rmse_p: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub rmse_h: Vec<f64>,
    /// Per-sample oracle of that scenario.
    #[serde(deserialize_with = "nan::read")]
    pub oracle_floor: Vec<f64>,
    /// Why the models could not be refitted for this row (its RMSEs are then NaN): e.g. with
    /// noise off, gratings that respond only to temperature are exactly collinear.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub not_fitted: Option<String>,
}

/// Host/device parity on the hold-out: the exported f32 model through `fbg-shared` against the
/// trainer's f64 model, on the inputs a device receives.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ParityReport {
    pub samples: usize,
    /// max |f32 − f64| per output.
    #[serde(deserialize_with = "nan::read")]
    pub max_abs_diff: Vec<f64>,
    /// That, as a fraction of Model-H's hold-out RMSE (the target is ≤ 0.01).
    #[serde(deserialize_with = "nan::read")]
    pub max_diff_over_rmse: Vec<f64>,
    /// max relative difference of the 95 % band.
    #[serde(deserialize_with = "nan::read")]
    pub max_band_rel_diff: Vec<f64>,
    /// Samples whose flags differ between f32 and f64 (the target is 0).
    pub flag_mismatches: usize,
    /// max over the hold-out of sqrt((1 + h_exact)/(1 + h_device)) − 1: how much the kept
    /// eigen-directions understate the band.
    #[serde(deserialize_with = "nan::read")]
    pub leverage_band_gap: f64,
    /// Largest exact leverage h on the hold-out.
    #[serde(deserialize_with = "nan::read")]
    pub leverage_max: f64,
}

/// How much of a full recalibration's gain a short batch recovers when the installation changes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct RecalStudy {
    #[serde(deserialize_with = "nan::read")]
    pub batch_hours: f64,
    pub batch_samples: usize,
    /// Seed of the original installation and of the changed one (new gratings' dispersion, new
    /// drift, new environment).
    pub seed_old: u64,
    pub seed_new: u64,
    /// Hold-out RMSE on the new installation (per output) of: the old model as is, the old model
    /// recalibrated on the short batch, and a full recalibration (same hyper-parameters, the new
    /// installation's whole calibration batch). Model-H and Model-P.
    #[serde(deserialize_with = "nan::read")]
    pub h_old: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub h_short: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub h_full: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub p_old: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub p_short: Vec<f64>,
    #[serde(deserialize_with = "nan::read")]
    pub p_full: Vec<f64>,
    /// (old − short) / (old − full) for Model-H, per output.
    #[serde(deserialize_with = "nan::read")]
    pub recovered_fraction_h: Vec<f64>,
}

/// Per output, the slope of the truth on each model's settled reading over the calibration
/// batch, and the RMS of what Model-H's memory groups and RBF residual add.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StaticFidelity {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub gain_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub gain_h: Vec<f64>,
    /// (part, RMS per output): the memory groups Model-H uses, then `rbf`.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub contributions: Vec<(String, Vec<f64>)>,
}
