//! Static fidelity and pace figures of BENCHMARKS.json (`train` + `evaluate --quick` per seed).

use serde::{Deserialize, Serialize};

use crate::nan;

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
    /// The glitch study of the native record's hold-out (absent in older metrics).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub glitch: Vec<GlitchRow>,
}

/// One case of the glitch study: one sample of one input replaced.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GlitchRow {
    /// The input column and the glitch (`T_amb_C`, `85`).
    pub input: String,
    pub value: String,
    /// Whether the glitch row carries a fault flag.
    pub flagged: bool,
    /// Later rows moved by more than their band.
    pub rows_beyond_band: usize,
}

impl GlitchRow {
    /// A thermometer glitch, or a non-finite one in any input: what the gate must catch (a
    /// grating's 85 or −127 pm may be a reading).
    pub fn must_flag(&self) -> bool {
        self.input == "T_amb_C" || self.value == "1e300" || self.value == "NaN"
    }
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
