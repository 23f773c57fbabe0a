//! `fbg-trainer bench-fit --json` (DESIGN §8): timed fits for `cargo xtask bench`, each with the
//! accuracy it bought. The trainer's `benchmark` module writes it, the bench reads it.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::metrics::ParityReport;
use crate::nan;

/// What `bench-fit` measures; `C` is the chosen configuration (the trainer's `fit::Config`, or
/// [`Chosen`] for a reader).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitBench<C = Chosen> {
    /// `fixed` (one grid point: the CV still runs once, for the band) or `select` (the full
    /// hyper-parameter grid).
    pub mode: String,
    /// The model's outputs (`T`, `strain`, …): the per-output lists below follow it.
    pub channels: Vec<String>,
    /// Their units.
    pub units: Vec<String>,
    pub n_samples: usize,
    pub n_cal: usize,
    /// Worker threads of the pool the fits ran in.
    pub threads: usize,
    /// Seconds to read the CSV (not part of the fit).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub read_seconds: f64,
    /// Seconds of each fit, in run order.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds_median: f64,
    /// Median wall time of each phase of the fit \[s\], in order.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub phase_seconds: Vec<(String, f64)>,
    pub chosen: C,
    /// The memory groups each output uses, by name (empty without memory terms).
    #[serde(default)]
    pub memory_groups: Vec<Vec<String>>,
    /// Each output's ridge penalty λ per sample on its standardised memory terms.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub memory_lambda: Vec<f64>,
    pub grid_points: usize,
    pub model_p: HoldoutFigures,
    pub model_h: HoldoutFigures,
    /// Model-H in f32 (the device path) against f64 on the hold-out.
    pub parity: ParityReport,
}

/// Hold-out figures of one model.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct HoldoutFigures {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage: Vec<f64>,
    /// Size of the exported `.fbgm` blob \[B\].
    pub blob_bytes: usize,
}

/// The hyper-parameters a fit chose, as a reader sees the trainer's `fit::Config`: the keys it
/// reads, and the others kept as they came.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Chosen {
    pub k: usize,
    pub feature_set: String,
    #[serde(flatten)]
    pub rest: BTreeMap<String, serde_json::Value>,
}
