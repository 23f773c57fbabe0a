//! `BENCHMARKS.json`, typed: what `cargo xtask bench` measured, as the markdown writer reads it.
//!
//! The key names are the file's contract (other tools read it): a field here is named as its key.
//! The file is written through `serde_json::Value`, whose maps are sorted, so the keys come out
//! in alphabetical order whatever the field order here. serde_json writes a NaN or an infinity
//! as `null`; every `f64` field reads `null`, or a key an older file lacks, back as NaN ([`nan`]),
//! which the tables print as "–". Objects that come whole from another tool keep the keys this
//! crate does not read in a `rest` map, so nothing is lost on the way through.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_json::Value;

pub use crate::device_bench::record::{DeviceRecord, StepRow};
use crate::nan;

/// Keys of an object that the markdown does not read, kept as they came.
pub type Rest = BTreeMap<String, Value>;

/// Three channels (T, ε, p).
pub type Rmse = [f64; 3];

/// The whole file.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Report {
    pub generated_by: String,
    pub quick: bool,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub wall_seconds: f64,
    pub machine: Machine,
    /// The `simulate` commands behind the datasets.
    pub datasets: Vec<String>,
    pub training: Training,
    pub inference_host: Inference,
    pub accuracy: Accuracy,
    pub fleet: Fleet,
    /// Peak RSS of `train`, `compensate`, `evaluate` on 10⁶ and 10⁷ rows (absent from files
    /// written before it was measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub memory: Option<super::memory::Memory>,
    pub device: Device,
    /// Static fidelity and the pace study of the `paper` preset: `train` + `evaluate --quick`
    /// per coverage seed (absent from files written before it was measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pace_paper: Option<PaceBench>,
    /// The `field` preset (other physics per effect) over the coverage seeds, `train` +
    /// `evaluate --quick` per seed (absent from files written before it was measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub field: Option<FieldBench>,
    /// The sharded fleet on a real Slurm (`cargo xtask slurm`, run on its own: it needs root);
    /// carried over from the previous file by `cargo xtask bench`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slurm: Option<serde_json::Value>,
}

impl Report {
    /// The device results, unless the device part failed.
    pub fn device_results(&self) -> Option<&DeviceResults> {
        match &self.device {
            Device::Measured(d) => Some(d),
            Device::Failed { .. } => None,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Machine

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Machine {
    pub cpu: String,
    pub cores: usize,
    pub memory: Option<String>,
    pub os: String,
    pub rustc: String,
    pub qemu: String,
    /// Versions of the scikit-learn peer's environment (absent when it was skipped).
    pub python: Option<String>,
    pub numpy: Option<String>,
    pub scikit_learn: Option<String>,
    pub peer_skipped_because: Option<String>,
    pub git: Git,
    pub loadavg_start: String,
    pub loadavg_end: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Git {
    pub commit: String,
    /// Files that differed from the commit while the bench ran.
    pub modified_files: Vec<String>,
}

// ---------------------------------------------------------------------------------------------
// Host training

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Training {
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
    pub rmse_p: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_h: Rmse,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FixedMemory {
    #[serde(flatten)]
    pub fit: FitRun,
    pub phase_seconds: Vec<Phase>,
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

/// One phase of our fit and its median time \[s\], as `bench-fit` reports it: `[name, seconds]`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Phase(pub String, #[serde(deserialize_with = "nan::read")] pub f64);

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct OursSelect {
    #[serde(flatten)]
    pub fit: FitRun,
    pub chosen: Chosen,
    pub grid_points: usize,
}

/// The hyper-parameters a fit chose (`fit::Config` of the trainer).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Chosen {
    pub k: usize,
    pub feature_set: String,
    #[serde(flatten)]
    pub rest: Rest,
}

/// The `paper` feature set, fixed hyper-parameters: ours against the notebook pipeline and the
/// pipeline with our k-means subsample, alternating for `rounds` rounds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FixedPaper {
    pub ours: OursFixed,
    /// `phase_seconds` of our fit in each round.
    pub ours_phases_per_round: Vec<Vec<Phase>>,
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

// ---------------------------------------------------------------------------------------------
// Accuracy

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

// ---------------------------------------------------------------------------------------------
// Static fidelity and pace (`train` + `evaluate --quick` per seed)

/// One seed through the user's commands: `train`, then `evaluate --quick` (hold-out figures,
/// static fidelity over the calibration batch, and the pace study). Per output of the models,
/// in the order of `channels`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EvalRun {
    pub seed: u64,
    pub channels: Vec<String>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_h: Vec<f64>,
    /// 95 % band coverage (fraction).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_h: Vec<f64>,
    /// Both models' static gains over the calibration batch (`metrics.json`'s `static_fidelity`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub static_fidelity: Option<StaticFidelity>,
    /// The pace study (`metrics.json`'s `pace`); not kept for every study.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pace: Option<PaceStudy>,
    pub train_command: String,
    pub evaluate_command: String,
}

impl EvalRun {
    /// Gain of Model-H over Model-P on output `c` [%].
    pub fn gain_pct(&self, c: usize) -> f64 {
        gain(&self.rmse_p, &self.rmse_h, c)
    }
}

/// `a ≤ b`, false when either is NaN (a missing figure never meets a target).
pub fn at_most(a: f64, b: f64) -> bool {
    a <= b
}

/// Gain of `h` over `p` on output `c` [%] (NaN when either is missing).
pub fn gain(p: &[f64], h: &[f64], c: usize) -> f64 {
    match (p.get(c), h.get(c)) {
        (Some(p), Some(h)) => 100.0 * (1.0 - h / p),
        _ => f64::NAN,
    }
}

/// `metrics.json`'s `static_fidelity`: per output, the slope of each model's settled reading
/// against the truth over the calibration batch, and the RMS of what Model-H's dynamic parts add.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StaticFidelity {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub gain_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub gain_h: Vec<f64>,
    /// (part, RMS per output).
    #[serde(default)]
    pub contributions: Vec<(String, Vec<Option<f64>>)>,
}

/// `metrics.json`'s `pace`: the installation at other paces and on a steps record.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PaceStudy {
    pub scenario: String,
    pub seed: u64,
    pub rows: Vec<PaceRow>,
}

impl PaceStudy {
    /// The steps record's row (the one with settled slopes).
    pub fn steps(&self) -> Option<&PaceRow> {
        self.rows.iter().find(|r| r.is_steps())
    }
}

/// One record of the pace study, both models, per output.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PaceRow {
    /// `×0.25`, `×4 (p_kPa)`, `steps`.
    pub label: String,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub factor: f64,
    /// The measurand paced alone, or none for all of them.
    #[serde(default)]
    pub only: Option<String>,
    pub samples: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_h: Vec<f64>,
    /// Settled slope against the truth (steps record only; empty otherwise).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub slope_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub slope_h: Vec<f64>,
    #[serde(default)]
    pub holds: usize,
}

impl PaceRow {
    pub fn is_steps(&self) -> bool {
        !self.slope_p.is_empty() || !self.slope_h.is_empty()
    }

    pub fn gain_pct(&self, c: usize) -> f64 {
        gain(&self.rmse_p, &self.rmse_h, c)
    }

    /// Model-H's RMSE at most Model-P's on every output (false when a figure is missing).
    pub fn h_le_p(&self) -> bool {
        !self.rmse_h.is_empty()
            && self.rmse_h.len() == self.rmse_p.len()
            && self.rmse_h.iter().zip(&self.rmse_p).all(|(h, p)| h <= p)
    }

    /// Model-H's band coverage at least `min` on every output.
    pub fn coverage_h_at_least(&self, min: f64) -> bool {
        !self.coverage_h.is_empty() && self.coverage_h.iter().all(|c| *c >= min)
    }

    /// |slope − 1| ≤ `tol` on every output, both models (false off the steps record).
    pub fn slopes_within(&self, tol: f64) -> bool {
        self.is_steps()
            && [&self.slope_p, &self.slope_h].iter().all(|v| !v.is_empty() && v.iter().all(|s| (s - 1.0).abs() <= tol))
    }
}

/// One record of the pace study over the seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PaceSummary {
    pub label: String,
    /// Seeds with this record.
    pub seeds: usize,
    /// Seeds on which Model-H's RMSE ≤ Model-P's on every channel.
    pub seeds_h_le_p: usize,
    /// Seeds on which Model-H's band coverage ≥ 90 % on every channel.
    pub seeds_coverage_h_90: usize,
    /// Per channel over the seeds: the mean and the smallest gain [%], the smallest Model-H
    /// band coverage (fraction).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_gain_pct: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub worst_gain_pct: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub min_coverage_h: Vec<f64>,
    /// Steps record only: per channel, the largest |slope − 1| over the seeds, each model, and
    /// the seeds on which every slope of both models is within 1 %.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub max_slope_dev_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub max_slope_dev_h: Vec<f64>,
    #[serde(default)]
    pub seeds_slopes_within_1pct: usize,
}

/// The pace study of one preset over the coverage seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PaceBench {
    pub preset: String,
    /// Every seed (seed 7 first), with its pace study.
    pub runs: Vec<EvalRun>,
    /// Per record, over the seeds.
    pub summary: Vec<PaceSummary>,
    /// Seeds on which every record meets both pace targets (Model-H ≤ Model-P and coverage ≥
    /// 90 % on every channel).
    pub seeds_pace_targets: usize,
}

/// The `field` preset over the coverage seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FieldBench {
    pub preset: String,
    /// Every seed (without its pace study, summarised in `pace_summary`).
    pub runs: Vec<EvalRun>,
    /// Per channel over the seeds: mean and smallest gain [%], seeds on which Model-H is worse
    /// than Model-P, mean band coverage of each model (fraction).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_gain_pct: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub min_gain_pct: Vec<f64>,
    pub seeds_h_worse: Vec<usize>,
    /// Seeds on which Model-H is worse than Model-P on some channel.
    pub seeds_h_worse_any: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_coverage_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_coverage_p: Vec<f64>,
    /// The pace study of every seed, per record over the seeds.
    #[serde(default)]
    pub pace_summary: Vec<PaceSummary>,
    #[serde(default)]
    pub seeds_pace_targets: usize,
}

// ---------------------------------------------------------------------------------------------
// Fleet

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Fleet {
    pub groups: usize,
    pub scenario: String,
    pub simulate_command: String,
    pub rounds: usize,
    pub runs: Vec<FleetRun>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub speedup_2_over_1_per_round: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub speedup_2_over_1_median: f64,
    pub resume: FleetResume,
}

/// One pool size: the fleet's wall time in each round.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FleetRun {
    pub jobs: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub seconds: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub median_seconds: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub groups_per_second: f64,
    pub command: String,
}

/// A rerun with nothing changed.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FleetResume {
    pub command: String,
    pub skipped: usize,
    pub trained: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub seconds: f64,
}

// ---------------------------------------------------------------------------------------------
// Device

/// The device part: its results, or why it failed.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Device {
    Failed { error: String },
    Measured(Box<DeviceResults>),
}

/// `target/bench/device.json` (written by `device_bench`, the same type) and what the bench
/// adds to it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DeviceResults {
    /// How the figures were obtained (added by the bench).
    #[serde(default)]
    pub command: String,
    /// True when `--no-device` reused an earlier run (added by the bench).
    #[serde(default)]
    pub reused_existing_results: bool,
    /// Added by the bench.
    #[serde(default)]
    pub arithmetic_lower_bound: Option<LowerBound>,
    /// The file as the device bench wrote it.
    #[serde(flatten)]
    pub record: DeviceRecord,
}

/// The arithmetic operations of one f32 step, counted from the code.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LowerBound {
    pub formula: String,
    pub per_k: Vec<LowerBoundAtK>,
    pub memory_full_bank: usize,
    pub source: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LowerBoundAtK {
    pub k: usize,
    pub operations: usize,
    pub operations_full_memory: usize,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn committed() -> Value {
        let path = crate::cmd::root().join("BENCHMARKS.json");
        serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
    }

    /// Drop the keys of `a` that are `null` where `b` lacks them (an older file lacks the keys
    /// a newer bench adds; read back, they are `null`).
    fn without_added_nulls(a: &mut Value, b: &Value) {
        match (a, b) {
            (Value::Object(a), Value::Object(b)) => {
                a.retain(|k, v| !v.is_null() || b.contains_key(k));
                for (k, v) in a.iter_mut() {
                    if let Some(w) = b.get(k) {
                        without_added_nulls(v, w);
                    }
                }
            }
            (Value::Array(a), Value::Array(b)) => {
                for (v, w) in a.iter_mut().zip(b) {
                    without_added_nulls(v, w);
                }
            }
            _ => {}
        }
    }

    /// The committed BENCHMARKS.json reads into [`Report`] and writes back with the same keys
    /// and values: the types name every key as the file does.
    #[test]
    fn committed_benchmarks_json_round_trips() {
        let v = committed();
        let r: Report = serde_json::from_value(v.clone()).unwrap();
        let mut back = serde_json::to_value(&r).unwrap();
        without_added_nulls(&mut back, &v);
        assert_eq!(back, v);
    }

    #[test]
    fn nan_reads_null_and_missing() {
        #[derive(Deserialize)]
        struct T {
            #[serde(default = "nan::missing", deserialize_with = "nan::read")]
            a: f64,
            #[serde(default = "nan::missing", deserialize_with = "nan::read")]
            b: [f64; 3],
            #[serde(default = "nan::missing", deserialize_with = "nan::read")]
            c: Vec<f64>,
        }
        let t: T = serde_json::from_str(r#"{"a": null, "b": [1.0, null]}"#).unwrap();
        assert!(t.a.is_nan() && t.b[0] == 1.0 && t.b[1].is_nan() && t.b[2].is_nan() && t.c.is_empty());
        let t: T = serde_json::from_str(r#"{"c": [2, null]}"#).unwrap();
        assert!(t.a.is_nan() && t.c[0] == 2.0 && t.c[1].is_nan());
    }
}
