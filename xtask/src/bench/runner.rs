//! Running the measured commands from the workspace root, and reading what they print.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context, Result};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::Value;

use super::report::{Chosen, Parity, Phase, Rmse};
use super::{PEER, TRAINER, VENV_PY};
use crate::cmd::run;
use crate::nan;

/// Runs commands from the workspace root; each answer comes with the command line as
/// BENCHMARKS.md quotes it.
pub struct Runner {
    pub root: PathBuf,
}

impl Runner {
    /// Run `program args` (program relative to the root), return its stdout parsed as JSON and
    /// the command line as it is quoted in BENCHMARKS.md.
    pub fn json(&self, program: &str, args: &[String], env: &[(&str, &str)]) -> Result<(Value, String)> {
        let line = command_line(program, args, env);
        eprintln!("bench: $ {line}");
        let exe = if program.contains('/') { self.root.join(program) } else { PathBuf::from(program) };
        let mut cmd = Command::new(exe);
        cmd.args(args).current_dir(&self.root).stdout(Stdio::piped()).stderr(Stdio::inherit());
        for (k, v) in env {
            cmd.env(k, v);
        }
        let out = cmd.output().with_context(|| format!("could not start `{line}`"))?;
        let v: Option<Value> = serde_json::from_slice(&out.stdout).ok();
        match v {
            Some(v) if out.status.success() || v.get("failed").is_some() => Ok((v, line)),
            _ => bail!("`{line}` failed ({}): {}", out.status, String::from_utf8_lossy(&out.stdout)),
        }
    }

    /// [`Runner::json`], read as `T`.
    pub fn typed<T: DeserializeOwned>(&self, program: &str, args: &[String]) -> Result<(T, String)> {
        let (v, line) = self.json(program, args, &[])?;
        let t = serde_json::from_value(v).with_context(|| format!("`{line}` printed JSON of another shape"))?;
        Ok((t, line))
    }

    /// `fbg-trainer args` (the release build), read as `T`.
    pub fn trainer<T: DeserializeOwned>(&self, args: &[&str]) -> Result<(T, String)> {
        self.typed(TRAINER, &strings(args))
    }

    /// The scikit-learn peer `bench/sklearn_peer.py args` in its venv, read as `T`.
    pub fn peer<T: DeserializeOwned>(&self, args: &[&str]) -> Result<(T, String)> {
        let mut a = vec![PEER.to_string()];
        a.extend(strings(args));
        self.typed(VENV_PY, &a)
    }
}

pub fn strings(a: &[&str]) -> Vec<String> {
    a.iter().map(|s| s.to_string()).collect()
}

fn command_line(program: &str, args: &[String], env: &[(&str, &str)]) -> String {
    let mut s: String = env.iter().map(|(k, v)| format!("{k}={v} ")).collect();
    s.push_str(program);
    for a in args {
        s.push(' ');
        s.push_str(a);
    }
    s
}

/// The peer's venv: created and filled by pip when missing. Its versions.
pub fn python_env(root: &Path, r: &Runner) -> Result<PeerVersions> {
    let py = root.join(VENV_PY);
    let importable = |py: &Path| {
        Command::new(py)
            .args(["-c", "import sklearn, numpy"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .map(|s| s.success())
            .unwrap_or(false)
    };
    if !py.exists() {
        run(Command::new("python3").args(["-m", "venv", "target/bench/venv"]).current_dir(root))
            .context("python3 -m venv")?;
    }
    if !importable(&py) {
        run(Command::new(root.join("target/bench/venv/bin/pip"))
            .args(["install", "--quiet", "scikit-learn", "numpy"])
            .current_dir(root))
        .context("pip install scikit-learn numpy")?;
    }
    Ok(r.peer(&["versions"])?.0)
}

/// Read a JSON file as `T`.
pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let text = fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not the JSON expected", path.display()))
}

// ---------------------------------------------------------------------------------------------
// What the commands print (only the keys the bench reads).

/// `fbg-trainer bench-fit --json` (`FitBench` of the trainer).
#[derive(Clone, Debug, Deserialize)]
pub struct FitBench {
    pub n_cal: usize,
    pub threads: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub read_seconds: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds_median: f64,
    pub phase_seconds: Vec<Phase>,
    pub chosen: Chosen,
    /// The memory groups of each output (empty without memory terms).
    #[serde(default)]
    pub memory_groups: Vec<Vec<String>>,
    /// Each output's ridge penalty per sample on its memory terms.
    #[serde(default)]
    pub memory_lambda: Vec<f64>,
    pub grid_points: usize,
    pub model_p: Holdout,
    pub model_h: Holdout,
    pub parity: Parity,
}

/// Hold-out figures of one model of `bench-fit`.
#[derive(Clone, Debug, Deserialize)]
pub struct Holdout {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: Rmse,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage: Rmse,
    pub blob_bytes: usize,
}

/// `fbg-trainer train --json`.
#[derive(Clone, Debug, Deserialize)]
pub struct TrainOut {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub train_seconds: f64,
}

/// `fbg-trainer fleet --json` (`FleetReport` of the trainer).
#[derive(Clone, Debug, Deserialize)]
pub struct FleetOut {
    pub trained: usize,
    pub skipped: usize,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub seconds: f64,
}

/// `<data>.meta.json` beside a simulated CSV.
#[derive(Clone, Debug, Deserialize)]
pub struct SimMeta {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub oracle_floor_holdout: Rmse,
}

/// `sklearn_peer.py versions`.
#[derive(Clone, Debug, Deserialize)]
pub struct PeerVersions {
    pub python: Option<String>,
    pub numpy: Option<String>,
    pub scikit_learn: Option<String>,
}

/// `sklearn_peer.py fit`.
#[derive(Clone, Debug, Deserialize)]
pub struct PeerFit {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub latch_seconds: f64,
    /// The memory terms that depend on no fitted number, computed before the clock.
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub feature_seconds: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds: Vec<f64>,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub fit_seconds_median: f64,
    pub model_p: PeerModel,
    pub model_h: PeerModel,
}

#[derive(Clone, Debug, Deserialize)]
pub struct PeerModel {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: Rmse,
    #[serde(default)]
    pub pickle_bytes: Option<u64>,
}

/// `sklearn_peer.py blackbox`.
#[derive(Clone, Debug, Deserialize)]
pub struct PeerBlackbox {
    pub peers: Vec<super::report::BlackboxPeer>,
}

/// `target/criterion/<bench>/new/estimates.json`.
#[derive(Clone, Debug, Deserialize)]
pub struct CriterionEstimates {
    pub median: CriterionEstimate,
}

#[derive(Clone, Debug, Deserialize)]
pub struct CriterionEstimate {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub point_estimate: f64,
    pub confidence_interval: CriterionInterval,
}

#[derive(Clone, Debug, Deserialize)]
pub struct CriterionInterval {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub lower_bound: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub upper_bound: f64,
}

/// `fbg-trainer evaluate --json` (`Metrics` of the trainer; only the keys the bench reads).
#[derive(Clone, Debug, Deserialize)]
pub struct EvalOut {
    pub seed: u64,
    pub channels: Vec<String>,
    pub table2: EvalTable2,
    #[serde(default)]
    pub static_fidelity: Option<super::report::StaticFidelity>,
    #[serde(default)]
    pub pace: Option<super::report::PaceStudy>,
}

#[derive(Clone, Debug, Deserialize)]
pub struct EvalTable2 {
    pub model_p: EvalModel,
    pub model_h: EvalModel,
}

#[derive(Clone, Debug, Deserialize)]
pub struct EvalModel {
    pub channels: Vec<EvalChannel>,
}

#[derive(Clone, Debug, Deserialize)]
pub struct EvalChannel {
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub rmse: f64,
    #[serde(default = "nan::missing", deserialize_with = "nan::read")]
    pub coverage: f64,
}
