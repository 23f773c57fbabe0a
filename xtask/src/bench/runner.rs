//! Running the measured commands from the workspace root, and reading what they print.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context, Result};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::Value;

use fbg_report::nan;

use super::{PEER, TRAINER, VENV_PY};
use crate::cmd::run;

/// Runs commands from the workspace root; each answer comes with the command line as
/// BENCHMARKS.md quotes it.
pub struct Runner {
    pub root: PathBuf,
}

impl Runner {
    /// Run `program args` (program relative to the root), return its stdout parsed as JSON and
    /// the command line as it is quoted in BENCHMARKS.md.
    pub fn json(&self, program: &str, args: &[impl AsRef<str>]) -> Result<(Value, String)> {
        let args: Vec<&str> = args.iter().map(AsRef::as_ref).collect();
        let line = format!("{program} {}", args.join(" "));
        eprintln!("bench: $ {line}");
        let exe = if program.contains('/') { self.root.join(program) } else { PathBuf::from(program) };
        let out = Command::new(exe)
            .args(&args)
            .current_dir(&self.root)
            .stderr(Stdio::inherit())
            .output()
            .with_context(|| format!("could not start `{line}`"))?;
        let v: Option<Value> = serde_json::from_slice(&out.stdout).ok();
        match v {
            Some(v) if out.status.success() || v.get("failed").is_some() => Ok((v, line)),
            _ => bail!("`{line}` failed ({}): {}", out.status, String::from_utf8_lossy(&out.stdout)),
        }
    }

    /// [`Runner::json`], read as `T`.
    pub fn typed<T: DeserializeOwned>(&self, program: &str, args: &[impl AsRef<str>]) -> Result<(T, String)> {
        let (v, line) = self.json(program, args)?;
        let t = serde_json::from_value(v).with_context(|| format!("`{line}` printed JSON of another shape"))?;
        Ok((t, line))
    }

    /// `fbg-trainer args` (the release build), read as `T`.
    pub fn trainer<T: DeserializeOwned>(&self, args: &[impl AsRef<str>]) -> Result<(T, String)> {
        self.typed(TRAINER, args)
    }

    /// `fbg-trainer simulate args`: the command line.
    pub fn simulate(&self, args: &[&str]) -> Result<String> {
        let args: Vec<&str> = ["simulate"].iter().chain(args).copied().collect();
        Ok(self.trainer::<Value>(&args)?.1)
    }

    /// The scikit-learn peer `bench/sklearn_peer.py args` in its venv, read as `T`.
    pub fn peer<T: DeserializeOwned>(&self, args: &[impl AsRef<str>]) -> Result<(T, String)> {
        let a: Vec<&str> = std::iter::once(PEER).chain(args.iter().map(AsRef::as_ref)).collect();
        self.typed(VENV_PY, &a)
    }
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

/// `cargo bench -p fbg-shared --bench <bench>` (shorter with `--quick`); the command line.
pub fn criterion(root: &Path, quick: bool, bench: &str) -> Result<String> {
    let mut args = vec!["bench", "--locked", "-p", "fbg-shared", "--bench", bench];
    if quick {
        args.extend(["--", "--warm-up-time", "1", "--measurement-time", "2"]);
    }
    run(crate::cmd::cargo().current_dir(root).args(&args))?;
    Ok(format!("cargo {}", args.join(" ")))
}

/// The median of criterion's benchmark `id` (`step_f32/16`) and its 95 % interval, per item of
/// a batch of `batch` \[ns\].
pub fn criterion_median(root: &Path, id: &str, batch: f64) -> Result<(f64, [f64; 2])> {
    let v: Value = read_json(&root.join(format!("target/criterion/{id}/new/estimates.json")))?;
    let m = &v["median"];
    let ns = |x: &Value| x.as_f64().unwrap_or(f64::NAN) / batch;
    let ci = &m["confidence_interval"];
    Ok((ns(&m["point_estimate"]), [ns(&ci["lower_bound"]), ns(&ci["upper_bound"])]))
}

// ---------------------------------------------------------------------------------------------
// What the commands print that no shared type describes (only the keys the bench reads); the
// trainer's reports are `fbg_report`'s.

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
    pub oracle_floor_holdout: Vec<f64>,
    /// The scenario the record was simulated from (what the bench reads of it).
    #[serde(default)]
    pub scenario: Option<SimScenario>,
}

/// The part of a simulated record's scenario the bench reads.
#[derive(Clone, Debug, Deserialize)]
pub struct SimScenario {
    pub drift: SimDrift,
}

/// The simulated interrogator's drift: its gain per channel.
#[derive(Clone, Debug, Deserialize)]
pub struct SimDrift {
    pub channel_gain: Vec<f64>,
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
    pub rmse: Vec<f64>,
    #[serde(default)]
    pub pickle_bytes: Option<u64>,
}
