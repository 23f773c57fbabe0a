//! The Python package's part of the bench: `bench/python_peer.py` in the package's
//! venv (`cargo xtask python` makes it) times `predict` on 10⁶ rows against the scikit-learn
//! peer's pipeline and the CLI's `compensate`, and `fit` against `bench-fit --fixed`; its JSON
//! goes into BENCHMARKS.json as `python`, with the command that produced it.

use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};
use serde_json::Value;

use super::verdict::met;
use crate::cmd::{describe, step, write_atomic};

/// The script, relative to the workspace root.
const SCRIPT: &str = "bench/python_peer.py";
/// Targets: `predict` at least this many times faster than the scikit-learn pipeline (DESIGN
/// §8: the stateless parts batched, the memory operators one scan) …
pub const TARGET_SPEEDUP_VS_SKLEARN: f64 = 3.0;
/// … and at most this many times the CLI's `compensate`; `fit` at most this many times
/// `bench-fit --fixed`.
pub const TARGET_RATIO_TO_CLI: f64 = 1.5;
pub const TARGET_FIT_RATIO: f64 = 1.2;

/// Run the script; `None` (with a message) where there is no Python.
pub fn part(root: &Path) -> Result<Option<Value>> {
    let Some((py, trainer)) = crate::python::prepare(root)? else { return Ok(None) };
    let mut cmd = Command::new(&py);
    cmd.current_dir(root).arg(SCRIPT).arg("--trainer").arg(&trainer).args(["--workdir", "target/bench/python"]);
    eprintln!("xtask: $ {}", describe(&cmd));
    let out = cmd.output().with_context(|| format!("could not start `{}`", describe(&cmd)))?;
    if !out.status.success() {
        bail!("`{}` failed with {}: {}", describe(&cmd), out.status, String::from_utf8_lossy(&out.stderr));
    }
    let mut v: Value = serde_json::from_slice(&out.stdout).context("bench/python_peer.py printed no JSON")?;
    if let Some(o) = v.as_object_mut() {
        o.insert(
            "command".into(),
            Value::String(format!(
                "target/python/venv/bin/python {SCRIPT} --trainer target/release/fbg-trainer --workdir target/bench/python (cargo xtask python --bench)"
            )),
        );
    }
    write_atomic(&root.join("target/bench/python.json"), serde_json::to_string_pretty(&v)?.as_bytes())?;
    Ok(Some(v))
}

/// `cargo xtask python --bench`: this part alone, put into BENCHMARKS.json and BENCHMARKS.md.
pub fn run_alone(root: &Path) -> Result<()> {
    step("bench: the Python package against the scikit-learn peer and the CLI");
    let Some(v) = part(root)? else { return Ok(()) };
    println!("{}", serde_json::to_string_pretty(&v)?);
    super::update(root, |r| {
        r.python = Some(v);
        Ok(())
    })?;
    eprintln!("bench: put the Python figures into BENCHMARKS.json and BENCHMARKS.md");
    Ok(())
}

fn num(v: &Value, path: &[&str]) -> f64 {
    path.iter().try_fold(v, |v, k| v.get(k)).and_then(Value::as_f64).unwrap_or(f64::NAN)
}

/// The BENCHMARKS.md section.
pub fn markdown(s: &mut String, v: &Value) {
    let speedup = num(v, &["speedup_vs_sklearn"]);
    let to_cli = num(v, &["ratio_to_cli_compensate"]);
    let fit = num(v, &["fit_ratio_to_cli"]);
    let same = v.get("same_as_cli").and_then(Value::as_bool).unwrap_or(false);
    out!(s, "## Python package (`fbg_compensation`)\n");
    out!(
        s,
        "`predict` of a Model-H (the `paper` feature set, K = 32, fixed) over {} rows of the `paper` preset from a pandas DataFrame in memory (the device's compensator in f64 through `fbg-shared`'s batch path: the stream state one scan in order, the RBF pass over several rows at once and over the cores, bit for bit its step; band and flags included), against the scikit-learn pipeline of `bench/sklearn_peer.py` on the same inputs (no band) and the CLI's `compensate` on the record's CSV (a process: read, compensate, write); `fit` on its {} calibration rows against `bench-fit --fixed` with the same configuration. Medians of {} runs, alternated. Results equal to the CLI's bit for bit: {}.\n",
        v.get("rows").and_then(Value::as_u64).unwrap_or(0),
        v.get("cal_rows").and_then(Value::as_u64).unwrap_or(0),
        v.get("repeats").and_then(Value::as_u64).unwrap_or(0),
        if same { "yes" } else { "**no**" }
    );
    out!(s, "| what | ours | peer | ratio | target |");
    out!(s, "|---|---:|---:|---:|---|");
    out!(
        s,
        "| `predict` vs scikit-learn pipeline | {:.3} s | {:.3} s | {:.1}× faster | ≥ {TARGET_SPEEDUP_VS_SKLEARN}× faster: {} |",
        num(v, &["predict_seconds", "ours"]),
        num(v, &["predict_seconds", "sklearn_peer"]),
        speedup,
        met(speedup >= TARGET_SPEEDUP_VS_SKLEARN)
    );
    out!(
        s,
        "| `predict` vs `fbg-trainer compensate` | {:.3} s | {:.3} s | {:.2}× | ≤ {TARGET_RATIO_TO_CLI}×: {} |",
        num(v, &["predict_seconds", "ours"]),
        num(v, &["predict_seconds", "cli_compensate"]),
        to_cli,
        met(to_cli <= TARGET_RATIO_TO_CLI)
    );
    out!(
        s,
        "| `fit` vs `bench-fit --fixed` | {:.3} s | {:.3} s | {:.2}× | ≤ {TARGET_FIT_RATIO}×: {} |",
        num(v, &["fit_seconds", "ours"]),
        num(v, &["fit_seconds", "cli_bench_fit_fixed"]),
        fit,
        met(fit <= TARGET_FIT_RATIO)
    );
    if let Some(l) = v.get("load_average").and_then(Value::as_array).filter(|l| l.len() == 3) {
        let l: Vec<String> = l.iter().map(|x| format!("{:.1}", x.as_f64().unwrap_or(f64::NAN))).collect();
        out!(
            s,
            "\nLoad average when the run ended (1, 5, 15 min): {} (other work on the machine slows both sides, not necessarily alike).",
            l.join(" / ")
        );
    }
    let cmd = |k: &str| v.get("commands").and_then(|c| c.get(k)).and_then(Value::as_str).unwrap_or("").to_string();
    out!(
        s,
        "\nCommand: `{}`; inside it `{}` and `{}`.\n",
        v.get("command").and_then(Value::as_str).unwrap_or("cargo xtask python --bench"),
        cmd("bench_fit"),
        cmd("compensate")
    );
}
