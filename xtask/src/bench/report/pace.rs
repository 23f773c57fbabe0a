//! Static fidelity and pace figures of BENCHMARKS.json (`train` + `evaluate --quick` per seed).

use fbg_report::{nan, PaceStudy, StaticFidelity};
use serde::{Deserialize, Serialize};

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
        fbg_report::gain_pct(&self.rmse_p, &self.rmse_h, c)
    }
}

/// `a ≤ b`, false when either is NaN (a missing figure never meets a target).
pub fn at_most(a: f64, b: f64) -> bool {
    a <= b
}

/// One record of the pace study over the seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PaceSummary {
    pub label: String,
    /// Seeds with this record.
    pub seeds: usize,
    /// Seeds on which Model-H's RMSE is within the record's ratio of Model-P's on every
    /// channel (`fbg_report::PaceRow::h_within_p`; the name is older than the ratio).
    pub seeds_h_le_p: usize,
    /// Seeds on which Model-H's band coverage ≥ `PACE_MIN_COVERAGE` (85 %) on every channel
    /// (the name is the JSON's, from when the bound was 90 %).
    pub seeds_coverage_h_90: usize,
    /// Per channel over the seeds: the mean and the smallest gain [%], the smallest and the
    /// mean Model-H band coverage (fraction).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_gain_pct: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub worst_gain_pct: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub min_coverage_h: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub mean_coverage_h: Vec<f64>,
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
