//! `BENCHMARKS.json`, typed: what `cargo xtask bench` measured, as the markdown writer reads it.
//!
//! The key names are the file's contract (other tools read it): a field here is named as its key.
//! The file is written through `serde_json::Value`, whose maps are sorted, so the keys come out
//! in alphabetical order whatever the field order here. serde_json writes a NaN or an infinity
//! as `null`; every `f64` field reads `null`, or a key an older file lacks, back as NaN
//! ([`fbg_report::nan`]), which the tables print as "–". Per-output lists follow the
//! `channels` of their part. Objects that come whole from another tool keep the keys this
//! crate does not read in a `rest` map, so nothing is lost on the way through.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use serde_json::Value;

pub use crate::device_bench::record::{DeviceRecord, StepRow};
use fbg_report::nan;

mod accuracy;
mod pace;
mod training;

pub use accuracy::*;
pub use pace::*;
pub use training::*;

/// Keys of an object that the markdown does not read, kept as they came.
pub type Rest = BTreeMap<String, Value>;

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
    /// The hold-out band coverage of `array-8` and `strain-pair` over the coverage seeds
    /// (absent from files written before it was measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub installations: Option<Vec<super::installations::InstallationCoverage>>,
    /// Peak detection in spectra: throughput, accuracy table, the spectrum chain
    /// (absent from files written before it was measured).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spectrum: Option<super::spectrum::SpectrumBench>,
    /// The sharded fleet on a real Slurm (`cargo xtask slurm`, run on its own: it needs root);
    /// carried over from the previous file by `cargo xtask bench`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slurm: Option<serde_json::Value>,
    /// The Python package against the scikit-learn peer and the CLI (`bench/python_peer.py`;
    /// absent from files written before it was measured, or where Python is absent).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub python: Option<serde_json::Value>,
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

    /// Drop the keys of `a` that `b` lacks (an older file lacks the keys a newer bench adds).
    fn without_added_keys(a: &mut Value, b: &Value) {
        match (a, b) {
            (Value::Object(a), Value::Object(b)) => {
                a.retain(|k, _| b.contains_key(k));
                for (k, v) in a.iter_mut() {
                    without_added_keys(v, &b[k]);
                }
            }
            (Value::Array(a), Value::Array(b)) => {
                for (v, w) in a.iter_mut().zip(b) {
                    without_added_keys(v, w);
                }
            }
            _ => {}
        }
    }

    /// The committed BENCHMARKS.json reads into [`Report`] and writes back with the same keys
    /// and values: the types name every key as the file does.
    #[test]
    fn committed_benchmarks_json_round_trips() {
        let v: Value = super::super::runner::read_json(&crate::cmd::root().join("BENCHMARKS.json")).unwrap();
        let r: Report = serde_json::from_value(v.clone()).unwrap();
        let mut back = serde_json::to_value(&r).unwrap();
        without_added_keys(&mut back, &v);
        assert_eq!(back, v);
    }
}
