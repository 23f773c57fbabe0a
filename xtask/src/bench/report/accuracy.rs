//! Accuracy figures of BENCHMARKS.json: presets, peers, band coverage, gains.

use serde::{Deserialize, Serialize};

use super::{Chosen, Rest, Rmse};
use crate::nan;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Accuracy {
    pub presets: Vec<PresetRun>,
    pub coverage_paper: Coverage,
    pub gain_paper: Gain,
    /// Model-H against each gradient-boosting hybrid over the coverage seeds (absent from files
    /// written before it was measured, and when the Python peer is unavailable).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gb_hybrids_paper: Vec<HybridComparison>,
}

/// Model-H against one gradient-boosting hybrid (`sklearn_peer.py hybrids`) over the coverage
/// seeds of the `paper` preset.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct HybridComparison {
    pub inputs: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_inputs: Option<u64>,
    /// Seeds compared (those with a hybrid result).
    pub seeds: usize,
    /// Mean hold-out RMSE over those seeds, Model-H and the hybrid.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_rmse_h: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_rmse_peer: Rmse,
    /// Seeds on which Model-H's RMSE is below the hybrid's, per channel.
    pub seeds_ahead: [usize; 3],
}

/// Our models, the black-box peers and the oracle on one preset (seed 7).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PresetRun {
    pub preset: String,
    pub seed: u64,
    pub data: String,
    pub model_p: ModelRun,
    pub model_h_default: ModelHDefault,
    pub model_h_paper: ModelHPaper,
    pub oracle_floor: OracleFloor,
    /// The scikit-learn black boxes (absent without the peer).
    pub blackbox: Option<Blackbox>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelRun {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: Rmse,
    pub bytes: usize,
    pub command: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelHDefault {
    #[serde(flatten)]
    pub run: ModelRun,
    pub chosen: Chosen,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage: Rmse,
    pub parity: Parity,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelHPaper {
    #[serde(flatten)]
    pub run: ModelRun,
    pub chosen: Chosen,
}

/// Model-H in f32 (the device path) against f64 on the hold-out (`ParityReport` of the trainer).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Parity {
    pub samples: usize,
    pub flag_mismatches: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub max_diff_over_rmse: Rmse,
    #[serde(flatten)]
    pub rest: Rest,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OracleFloor {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: Rmse,
    /// Where the figures come from (the `.meta.json` of the dataset).
    pub source: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Blackbox {
    pub command: String,
    pub peers: Vec<BlackboxPeer>,
}

/// One black-box model of `bench/sklearn_peer.py blackbox`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BlackboxPeer {
    pub model: String,
    pub inputs: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub n_inputs: Option<u64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: Rmse,
    pub pickle_bytes: u64,
    #[serde(flatten)]
    pub rest: Rest,
}

impl BlackboxPeer {
    /// A Model-P + gradient-boosting-residual hybrid (`sklearn_peer.py`'s `gb_hybrids`).
    pub fn is_gb_hybrid(&self) -> bool {
        self.model.contains("HistGradientBoosting residual")
    }
}

/// Band coverage of Model-H over the coverage seeds of the `paper` preset.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Coverage {
    pub per_seed: Vec<SeedRun>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_h: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub median_h: Rmse,
    /// Seeds whose coverage is within 95 ± 2 %, per channel.
    pub seeds_within_95_pm_2: [usize; 3],
    /// The reference band on the lead time alone (absent from files written before it).
    #[serde(default)]
    pub ensemble_band: Option<EnsembleBand>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SeedRun {
    pub seed: u64,
    pub k: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_h: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_p: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_h: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_p: Rmse,
    pub command: String,
    /// The gradient-boosting hybrids on this seed (empty without the Python peer).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gb_hybrids: Vec<BlackboxPeer>,
}

impl SeedRun {
    /// Gain of Model-H over Model-P on channel `c` [%].
    pub fn gain_pct(&self, c: usize) -> f64 {
        100.0 * (1.0 - self.rmse_h[c] / self.rmse_p[c])
    }
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EnsembleBand {
    pub bin_seconds: f64,
    pub channels: Vec<EnsembleChannel>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EnsembleChannel {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub per_seed: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean: f64,
    pub seeds_within_95_pm_2: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub min: f64,
}

/// Gain of Model-H over Model-P [%] over the coverage seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Gain {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub per_seed: Vec<Rmse>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_pct: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub min_pct: Rmse,
    pub seeds_all_channels_25: usize,
}
