//! Host training and inference figures of BENCHMARKS.json.

use serde::{Deserialize, Serialize};

use fbg_report::{nan, Chosen};

use super::paper_channels;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Training {
    /// The outputs of the fitted models, in the order of each per-output list (files written
    /// before they were recorded: the `paper` layout).
    #[serde(default = "paper_channels")]
    pub channels: Vec<String>,
    pub fixed_config: FixedConfig,
    pub sizes: Vec<SizeRun>,
    pub growth_exponent: GrowthExponent,
}

/// The one configuration of the fixed fits.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FixedConfig {
    pub k: usize,
    pub sigma_mult: f64,
    pub alpha_rel: f64,
    pub dead_band_pm: f64,
    pub kmeans_seed: u64,
}

/// Least-squares slope of ln(time) against ln(n) over the sizes (NaN unless every time is
/// positive).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GrowthExponent {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub ours_select: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub ours_fixed_paper: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub peer_fixed_paper: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub notebook_fixed_paper: f64,
}

/// Every training figure at one dataset size.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SizeRun {
    pub n_samples: usize,
    pub n_cal: usize,
    pub repeats_per_process: usize,
    pub rounds: usize,
    /// `train` end to end (absent from files written before it was measured).
    #[serde(default)]
    pub train_end_to_end: Option<TrainEndToEnd>,
    /// The fixed fit with the memory terms (no peer).
    pub fixed_memory: FixedMemory,
    pub ours_select: OursSelect,
    pub fixed_paper: FixedPaper,
    pub fixed_default: FixedDefault,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TrainEndToEnd {
    pub command: String,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub wall_seconds: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds: f64,
    pub csv_bytes: u64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub csv_read_seconds: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub csv_read_mb_per_s: f64,
}

/// One timed fit command: every fit's time, their median and the hold-out RMSE of the last fit.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitRun {
    pub command: String,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub median: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_h: Vec<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FixedMemory {
    #[serde(flatten)]
    pub fit: FitRun,
    /// Our fit's median time per phase \[s\], as `bench-fit` reports it: `[name, seconds]`.
    #[serde(deserialize_with = "nan::read")]
    pub phase_seconds: Vec<(String, f64)>,
    /// The scikit-learn pipeline with the same features (the memory terms of the groups and
    /// ridge our cross-validation chose, the latch RBF inputs); absent without the peer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peer: Option<PeerMemory>,
    /// Peer / ours, per round (ours and the peer alternate), and their median (absent from
    /// runs before the peer had memory terms).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ratio_per_round: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read", skip_serializing_if = "nan::absent")]
    pub ratio_median: f64,
    /// The peer as a pipeline that computes its own inputs (its latch loop and memory terms,
    /// which it runs before its clock, added to its fit; ours computes them inside its fit) /
    /// ours, per round, and their median (absent from runs before it was reported).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub pipeline_ratio_per_round: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read", skip_serializing_if = "nan::absent")]
    pub pipeline_ratio_median: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PeerMemory {
    #[serde(flatten)]
    pub fit: FitRun,
    /// The peer's Python latch loop, before its clock starts.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub latch_seconds: f64,
    /// The peer's memory terms that depend on no fitted number, before its clock starts.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub feature_seconds: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OursSelect {
    #[serde(flatten)]
    pub fit: FitRun,
    pub chosen: Chosen,
    pub grid_points: usize,
}

/// The `paper` feature set, fixed hyper-parameters: ours against the notebook pipeline and the
/// pipeline with our k-means subsample, alternating for `rounds` rounds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FixedPaper {
    pub ours: OursFixed,
    /// `phase_seconds` of our fit in each round.
    #[serde(deserialize_with = "nan::read")]
    pub ours_phases_per_round: Vec<Vec<(String, f64)>>,
    /// scikit-learn with our k-means subsample (absent without the peer).
    pub peer: Option<PeerFixed>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub ratio_per_round: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub ratio_median: f64,
    /// scikit-learn as a notebook writes it (absent without the peer).
    pub notebook: Option<FitRun>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub notebook_ratio_per_round: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub notebook_ratio_median: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OursFixed {
    #[serde(flatten)]
    pub fit: FitRun,
    pub blob_bytes: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub read_seconds: f64,
    pub threads: usize,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PeerFixed {
    #[serde(flatten)]
    pub fit: FitRun,
    pub pickle_bytes: Option<u64>,
}

/// The default (hysteresis-aware) feature set, fixed hyper-parameters, ours and the peer once.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FixedDefault {
    pub ours: FitRun,
    pub peer: Option<PeerLatch>,
    /// Peer median / ours (NaN without the peer).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub ratio: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PeerLatch {
    #[serde(flatten)]
    pub fit: FitRun,
    /// The peer's Python latch loop, before its clock starts.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub latch_seconds: f64,
}

// ---------------------------------------------------------------------------------------------
// Host inference

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Inference {
    pub command: String,
    pub samples_per_iteration: f64,
    pub criterion_samples: usize,
    pub statistic: String,
    pub rows: Vec<InferenceRow>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct InferenceRow {
    pub precision: String,
    pub k: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub ns_per_step: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub samples_per_second: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub ci95_ns_per_step: [f64; 2],
}
