//! Accuracy figures of BENCHMARKS.json: presets, peers, band coverage, gains.

use serde::{Deserialize, Serialize};

use fbg_report::{nan, Chosen, ParityReport};

use super::Rest;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Accuracy {
    /// The outputs of every model of the part, in the order of each per-output list (files
    /// written before they were recorded: the `paper` layout).
    #[serde(default = "paper_channels")]
    pub channels: Vec<String>,
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
    pub mean_rmse_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_rmse_peer: Vec<f64>,
    /// Seeds on which Model-H's RMSE is below the hybrid's, per channel.
    pub seeds_ahead: Vec<usize>,
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
    pub rmse: Vec<f64>,
    pub bytes: usize,
    pub command: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelHDefault {
    #[serde(flatten)]
    pub run: ModelRun,
    pub chosen: Chosen,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage: Vec<f64>,
    pub parity: ParityReport,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelHPaper {
    #[serde(flatten)]
    pub run: ModelRun,
    pub chosen: Chosen,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OracleFloor {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: Vec<f64>,
    /// Where the figures come from (the `.meta.json` of the dataset).
    pub source: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Blackbox {
    pub command: String,
    pub peers: Vec<BlackboxPeer>,
}

/// What `sklearn_peer.py blackbox` (and `hybrids`) prints.
#[derive(Clone, Debug, Deserialize)]
pub struct PeerBlackbox {
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
    pub rmse: Vec<f64>,
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
    pub mean_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub median_h: Vec<f64>,
    /// Seeds whose coverage is within 95 ± 2 %, per channel.
    pub seeds_within_95_pm_2: Vec<usize>,
    /// The reference band on the lead time alone (absent from files written before it).
    #[serde(default)]
    pub ensemble_band: Option<EnsembleBand>,
    /// Both models' coverage and error by day since calibration, the seeds pooled (absent
    /// from files written before it).
    #[serde(default)]
    pub by_day: Option<Vec<DayChannel>>,
}

/// One output's hold-out, the seeds pooled, per whole day since the end of calibration.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DayChannel {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_p: Vec<f64>,
    /// Model-H's mean squared error over Model-P's.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mse_ratio: Vec<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SeedRun {
    pub seed: u64,
    pub k: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_p: Vec<f64>,
    pub command: String,
    /// The gradient-boosting hybrids on this seed (empty without the Python peer).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub gb_hybrids: Vec<BlackboxPeer>,
}

impl SeedRun {
    /// Gain of Model-H over Model-P on channel `c` [%].
    pub fn gain_pct(&self, c: usize) -> f64 {
        fbg_report::gain_pct(&self.rmse_p, &self.rmse_h, c)
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
    pub per_seed: Vec<Vec<f64>>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_pct: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub min_pct: Vec<f64>,
    pub seeds_all_channels_25: usize,
}

/// The outputs of the `paper` preset's models: the layout of every file written before the
/// bench recorded them.
pub fn paper_channels() -> Vec<String> {
    ["T", "strain", "p"].map(String::from).to_vec()
}
