//! `metrics.json`'s `pace` (DESIGN §4 static fidelity, §5): the calibration's installation at
//! other paces and through a steps record, scored with the models calibrated at its own pace,
//! and the glitch study of the native record. The trainer's `eval::pace` and `eval::glitch`
//! fill it; BENCHMARKS.json keeps one per seed.

use serde::{Deserialize, Serialize};

use crate::nan;

/// The whole study.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaceStudy {
    pub scenario: String,
    pub seed: u64,
    /// Every paced record, then the steps record, the rest record, the long-hold record and the
    /// plateau record.
    pub rows: Vec<PaceRow>,
    /// Single-sample glitches in each input of the native record's hold-out (absent from
    /// metrics written before the glitch study).
    #[serde(default)]
    pub glitch: Vec<GlitchRow>,
}

impl PaceStudy {
    /// The steps record's row (the one with settled slopes).
    pub fn steps(&self) -> Option<&PaceRow> {
        self.rows.iter().find(|r| r.is_steps())
    }
}

/// The labels of the records of a structure at rest or holding.
pub const REST_LABELS: [&str; 3] = ["rest", "long-hold", "plateaus"];

/// Largest Model-H / Model-P RMSE ratio on a paced or steps record (the pace target).
pub const PACED_RMSE_RATIO_MAX: f64 = 1.01;

/// Largest Model-H / Model-P RMSE ratio on a rest, long-hold or plateau record.
pub const REST_RMSE_RATIO_MAX: f64 = 1.05;

/// One record of the study: both models' hold-out figures, per output of the models.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaceRow {
    /// What the record is: `×0.25`, `×4 (p_kPa)`, `steps`.
    pub label: String,
    /// Pace factor (1 for the steps record).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub factor: f64,
    /// The measurand paced alone (column name), or `None` for all of them.
    #[serde(default)]
    pub only: Option<String>,
    /// Hold-out samples scored.
    pub samples: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse_h: Vec<f64>,
    /// 95 % band coverage (fraction).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage_h: Vec<f64>,
    /// Settled slope against the truth (steps record only; empty otherwise).
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub slope_p: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub slope_h: Vec<f64>,
    /// Holds behind each slope (steps record only).
    #[serde(default)]
    pub holds: usize,
}

impl PaceRow {
    /// The steps record (it has settled slopes).
    pub fn is_steps(&self) -> bool {
        !self.slope_p.is_empty() || !self.slope_h.is_empty()
    }

    /// Gain of Model-H over Model-P on output `c` [%].
    pub fn gain_pct(&self, c: usize) -> f64 {
        gain_pct(&self.rmse_p, &self.rmse_h, c)
    }

    /// Records of a structure at rest or holding: `rest`, `long-hold`, `plateaus`.
    pub fn is_rest(&self) -> bool {
        REST_LABELS.contains(&self.label.as_str())
    }

    /// The largest Model-H / Model-P RMSE ratio the record's target allows:
    /// [`REST_RMSE_RATIO_MAX`] on the rest records, [`PACED_RMSE_RATIO_MAX`] on the others.
    pub fn rmse_ratio_max(&self) -> f64 {
        if self.is_rest() {
            REST_RMSE_RATIO_MAX
        } else {
            PACED_RMSE_RATIO_MAX
        }
    }

    /// Model-H's RMSE within [`PaceRow::rmse_ratio_max`] × Model-P's on output `c` (false when
    /// a figure is missing).
    pub fn h_within_p_on(&self, c: usize) -> bool {
        match (self.rmse_h.get(c), self.rmse_p.get(c)) {
            (Some(&h), Some(&p)) => h <= self.rmse_ratio_max() * p,
            _ => false,
        }
    }

    /// Model-H's RMSE within [`PaceRow::rmse_ratio_max`] × Model-P's on every output (false
    /// when a figure is missing).
    pub fn h_within_p(&self) -> bool {
        !self.rmse_h.is_empty()
            && self.rmse_h.len() == self.rmse_p.len()
            && (0..self.rmse_p.len()).all(|c| self.h_within_p_on(c))
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

/// Gain of `h` over `p` on output `c` [%] (NaN when either is missing).
pub fn gain_pct(p: &[f64], h: &[f64], c: usize) -> f64 {
    match (p.get(c), h.get(c)) {
        (Some(p), Some(h)) => 100.0 * (1.0 - h / p),
        _ => f64::NAN,
    }
}

/// One glitch case: one sample of one input of the hold-out replaced (DESIGN §4, the second
/// rule (a)). The time, the later rows and the worst ratio are absent where a reader kept only
/// the flag and the count (BENCHMARKS.json before it kept the whole row).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GlitchRow {
    /// The input column (`dl1_pm`, `T_amb_C`).
    pub input: String,
    /// The glitch value, as text (`85`, `NaN`).
    pub value: String,
    /// Time of the glitch row \[s\].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub t_s: Option<f64>,
    /// Whether the glitch row's estimate carries a fault flag.
    pub flagged: bool,
    /// Hold-out rows after the glitch row.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub later_rows: Option<usize>,
    /// Of those, rows where some output differs from the clean record's by more than the
    /// clean row's band.
    pub rows_beyond_band: usize,
    /// Largest |glitched − clean| / band over the later rows and outputs (0: no trace; `null`,
    /// read as `None`, when a band was 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub worst_ratio: Option<f64>,
}

impl GlitchRow {
    /// A thermometer glitch, or a non-finite one in any input: what the gate must catch (a
    /// grating's 85 or −127 pm may be a reading).
    pub fn must_flag(&self) -> bool {
        self.input == "T_amb_C" || self.value == "1e300" || self.value == "NaN"
    }
}
