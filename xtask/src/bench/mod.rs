//! `cargo xtask bench`: every figure of DESIGN §8 and issue 7, written to `BENCHMARKS.md` and its
//! twin `BENCHMARKS.json` at the top of the workspace.
//!
//! xtask itself runs in the dev profile, so nothing is timed in this process: it builds the
//! release trainer and times its `bench-fit` command (each fit timed alone inside the process,
//! the CSV read outside the clock), runs the scikit-learn peer (`bench/sklearn_peer.py`, in a
//! venv under `target/bench/venv`) the same way, the criterion bench of `fbg-shared`, the
//! `fleet` command, and the device bench (`device_bench::run`, QEMU). Every figure is a median
//! of repeated runs, and every ratio compares runs taken side by side, alternating, in the same
//! invocation. The exact command behind each figure is recorded next to it.
//!
//! `cargo xtask bench [--quick] [--no-device]`: `--quick` takes one round of one repeat (for
//! trying the task out, not for publishing); `--no-device` reuses `target/bench/device.json`
//! instead of running QEMU; `--markdown-only` renders BENCHMARKS.md again from BENCHMARKS.json
//! and measures nothing.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, Context, Result};
use serde_json::{json, Value};

use fbg_shared::layout::{N_ENVELOPE, N_GRATINGS, N_MEMORY, N_OUTPUTS, N_POLY, N_STAGE1, VAR_RANK, Z_DIMS};
use fbg_shared::{MemoryGroup, MemorySpec};

use crate::{cargo, device_bench, run, step};

/// Sizes of the fit-time scaling study and their sample interval over the 14 days of the
/// `paper` clock.
const SIZES: [(usize, f64); 3] = [(10_000, 120.96), (100_000, 12.096), (1_000_000, 1.2096)];
/// Seeds of the band-coverage study (`paper` preset).
const COVERAGE_SEEDS: [u64; 20] = [7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26];
/// Groups of the fleet study.
const FLEET_GROUPS: usize = 16;
/// Samples per criterion iteration (`shared/benches/step.rs`).
const STEP_BATCH: f64 = 1024.0;
const TRAINER: &str = "target/release/fbg-trainer";
const PEER: &str = "bench/sklearn_peer.py";
const VENV_PY: &str = "target/bench/venv/bin/python";

struct Opts {
    quick: bool,
    no_device: bool,
}

/// Runs commands from the workspace root and remembers what it ran.
struct Runner {
    root: PathBuf,
}

impl Runner {
    /// Run `program args` (program relative to the root), return its stdout parsed as JSON and
    /// the command line as it is quoted in BENCHMARKS.md.
    fn json(&self, program: &str, args: &[String], env: &[(&str, &str)]) -> Result<(Value, String)> {
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

    fn trainer(&self, args: &[&str]) -> Result<(Value, String)> {
        self.json(TRAINER, &strings(args), &[])
    }

    fn peer(&self, args: &[&str]) -> Result<(Value, String)> {
        let mut a = vec![PEER.to_string()];
        a.extend(strings(args));
        self.json(VENV_PY, &a, &[])
    }
}

fn strings(a: &[&str]) -> Vec<String> {
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

/// `cargo xtask bench`.
pub fn run_bench(root: &Path, args: &[String]) -> Result<()> {
    if args.iter().any(|a| a == "--markdown-only") {
        if let Some(a) = args.iter().find(|a| *a != "--markdown-only") {
            bail!("cargo xtask bench --markdown-only takes no other option (got `{a}`)");
        }
        return markdown_only(root);
    }
    let opts = Opts { quick: args.iter().any(|a| a == "--quick"), no_device: args.iter().any(|a| a == "--no-device") };
    if let Some(a) = args.iter().find(|a| *a != "--quick" && *a != "--no-device") {
        bail!("cargo xtask bench: unknown option `{a}` (--quick, --no-device, --markdown-only)");
    }
    let r = Runner { root: root.to_path_buf() };
    let bench_dir = root.join("target/bench");
    let data_dir = bench_dir.join("data");
    fs::create_dir_all(&data_dir)?;
    let t0 = std::time::Instant::now();
    let load_start = loadavg();

    step("bench: device (QEMU)");
    let device = device_part(root, &opts);

    step("bench: release build of the trainer");
    run(cargo().current_dir(root).args(["build", "--release", "--locked", "-p", "fbg-trainer"]))?;

    step("bench: scikit-learn peer environment");
    let peer_env = python_env(root, &r);
    if let Err(e) = &peer_env {
        eprintln!("bench: scikit-learn peer skipped: {e:#}");
    }
    let peer_ok = peer_env.is_ok();

    step("bench: datasets");
    let mut data_cmds = Vec::new();
    for (n, dt) in SIZES {
        let toml = data_dir.join(format!("n{n}.toml"));
        fs::write(&toml, format!("# {n} samples over the 14 days of the paper clock\n[clock]\ndt_s = {dt}\n"))?;
        let (_, c) = r.json(
            TRAINER,
            &strings(&["simulate", "--config", &rel(&toml, root), "--seed", "7", "--json", "--out", &data(n)]),
            &[],
        )?;
        data_cmds.push(c);
    }
    for preset in ["paper", "harsh"] {
        let seeds: &[u64] = if preset == "paper" { &COVERAGE_SEEDS } else { &[7] };
        for &seed in seeds {
            let (_, c) = r.trainer(&[
                "simulate",
                "--preset",
                preset,
                "--seed",
                &seed.to_string(),
                "--json",
                "--out",
                &preset_csv(preset, seed),
            ])?;
            data_cmds.push(c);
        }
    }

    step("bench: host inference throughput (criterion)");
    let inference = inference_part(root, &opts)?;

    step("bench: host training, ours and the scikit-learn peer");
    let training = training_part(root, &r, &opts, peer_ok)?;

    step("bench: accuracy peers and band coverage");
    let accuracy = accuracy_part(root, &r, peer_ok)?;

    step("bench: fleet scaling");
    let fleet = fleet_part(root, &r, &opts)?;

    let load_end = loadavg();
    let machine = machine(root, peer_env.as_ref().ok(), peer_env.as_ref().err(), load_start, load_end);
    let report = json!({
        "generated_by": "cargo xtask bench",
        "quick": opts.quick,
        "wall_seconds": t0.elapsed().as_secs_f64(),
        "machine": machine,
        "datasets": data_cmds,
        "training": training,
        "inference_host": inference,
        "accuracy": accuracy,
        "fleet": fleet,
        "device": match &device { Ok(v) => v.clone(), Err(e) => json!({"error": format!("{e:#}")}) },
    });
    let md = markdown(&report);
    crate::fixtures::write_atomic(&root.join("BENCHMARKS.json"), serde_json::to_string_pretty(&report)?.as_bytes())?;
    crate::fixtures::write_atomic(&root.join("BENCHMARKS.md"), md.as_bytes())?;
    eprintln!("bench: wrote BENCHMARKS.md and BENCHMARKS.json in {:.0} s", t0.elapsed().as_secs_f64());
    device.map(|_| ())
}

/// `cargo xtask bench --markdown-only`: BENCHMARKS.md again from BENCHMARKS.json, measuring
/// nothing (after a change to the markdown writer).
fn markdown_only(root: &Path) -> Result<()> {
    let path = root.join("BENCHMARKS.json");
    let text = fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let report: Value = serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    crate::fixtures::write_atomic(&root.join("BENCHMARKS.md"), markdown(&report).as_bytes())?;
    eprintln!("bench: wrote BENCHMARKS.md from BENCHMARKS.json");
    Ok(())
}

fn data(n: usize) -> String {
    format!("target/bench/data/n{n}.csv")
}

fn preset_csv(preset: &str, seed: u64) -> String {
    format!("target/bench/data/{preset}-s{seed}.csv")
}

/// Model-H's per-sample hold-out errors and bands of one coverage run (`bench-fit --holdout-errors`).
fn holdout_errors_csv(preset: &str, seed: u64) -> String {
    format!("target/bench/holdout/{preset}-s{seed}.csv")
}

/// Width of the lead-time bins of the ensemble band [s].
const ENSEMBLE_BIN_S: f64 = 7200.0;

/// The reference for per-seed band coverage: a band that depends on the lead time alone, set to
/// the 95 % quantile of |error| over *all* seeds' hold-outs in each 2-hour lead bin (it reads the
/// hold-outs, so no model can have it). Its per-seed coverage shows how much of the seed-to-seed
/// spread comes from the hold-out week itself (one drift path per seed) rather than from the
/// band a model estimated from its own calibration batch.
fn ensemble_band_coverage(files: &[PathBuf]) -> Result<Value> {
    // Per seed: (lead from the first hold-out sample [s], |error| per channel).
    let mut runs: Vec<Vec<(f64, [f64; N_OUTPUTS])>> = Vec::new();
    for f in files {
        let text = fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
        let mut rows = Vec::new();
        for (n, line) in text.lines().enumerate().skip(1) {
            let v: Vec<f64> = line
                .split(',')
                .map(str::parse)
                .collect::<Result<_, _>>()
                .with_context(|| format!("{}:{}: not a number", f.display(), n + 1))?;
            if v.len() < 1 + N_OUTPUTS {
                bail!("{}:{}: expected {} columns, found {}", f.display(), n + 1, 1 + 2 * N_OUTPUTS, v.len());
            }
            rows.push((v[0], std::array::from_fn(|c| v[1 + c].abs())));
        }
        let t0 = rows.first().map(|r| r.0).unwrap_or(0.0);
        runs.push(rows.into_iter().map(|(t, e)| (t - t0, e)).collect());
    }
    let bin = |lead: f64| (lead / ENSEMBLE_BIN_S).max(0.0) as usize;
    let n_bins = runs.iter().flatten().map(|r| bin(r.0) + 1).max().unwrap_or(0);
    let mut per_channel = Vec::new();
    for c in 0..N_OUTPUTS {
        let mut pooled: Vec<Vec<f64>> = vec![Vec::new(); n_bins];
        for r in runs.iter().flatten() {
            pooled[bin(r.0)].push(r.1[c]);
        }
        let q95: Vec<f64> = pooled
            .iter_mut()
            .map(|v| {
                v.sort_by(f64::total_cmp);
                v.get(((v.len() as f64) * 0.95) as usize).or(v.last()).copied().unwrap_or(f64::INFINITY)
            })
            .collect();
        let cov: Vec<f64> = runs
            .iter()
            .map(|run| run.iter().filter(|r| r.1[c] <= q95[bin(r.0)]).count() as f64 / run.len().max(1) as f64)
            .collect();
        let mean = cov.iter().sum::<f64>() / cov.len().max(1) as f64;
        let within = cov.iter().filter(|v| (*v - 0.95).abs() <= 0.02).count();
        let min = cov.iter().copied().fold(f64::INFINITY, f64::min);
        per_channel.push(json!({"per_seed": cov, "mean": mean, "seeds_within_95_pm_2": within, "min": min}));
    }
    Ok(json!({"bin_seconds": ENSEMBLE_BIN_S, "channels": per_channel}))
}

fn rel(p: &Path, root: &Path) -> String {
    p.strip_prefix(root).unwrap_or(p).display().to_string()
}

fn loadavg() -> String {
    fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

// ---------------------------------------------------------------------------------------------
// Machine

fn first_line(cmd: &str, args: &[&str]) -> String {
    Command::new(cmd)
        .args(args)
        .output()
        .ok()
        .map(|o| {
            String::from_utf8_lossy(if o.stdout.is_empty() { &o.stderr } else { &o.stdout })
                .lines()
                .next()
                .unwrap_or("")
                .trim()
                .to_string()
        })
        .unwrap_or_else(|| "unknown".into())
}

fn machine(
    root: &Path,
    peer: Option<&Value>,
    peer_err: Option<&anyhow::Error>,
    load_start: String,
    load_end: String,
) -> Value {
    let cpu = fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    let os = fs::read_to_string("/etc/os-release")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("PRETTY_NAME="))
                .map(|l| l.trim_start_matches("PRETTY_NAME=").trim_matches('"').to_string())
        })
        .unwrap_or_else(|| std::env::consts::OS.into());
    let rustc = Command::new("rustc")
        .arg("--version")
        .current_dir(root)
        .output()
        .ok()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    json!({
        "cpu": cpu,
        "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        "memory": fs::read_to_string("/proc/meminfo").ok().and_then(|s| s.lines().next().map(|l| l.split_whitespace().nth(1).and_then(|k| k.parse::<f64>().ok()).map(|k| format!("{:.1} GiB", k / 1048576.0)).unwrap_or_default())),
        "os": format!("{os}, kernel {}", first_line("uname", &["-r"])),
        "rustc": rustc,
        "qemu": first_line("qemu-system-arm", &["--version"]),
        "python": peer.and_then(|p| p.get("python")).cloned(),
        "numpy": peer.and_then(|p| p.get("numpy")).cloned(),
        "scikit_learn": peer.and_then(|p| p.get("scikit_learn")).cloned(),
        "peer_skipped_because": peer_err.map(|e| format!("{e:#}")),
        "git": git_state(root),
        "loadavg_start": load_start,
        "loadavg_end": load_end,
    })
}

/// The commit benchmarked, and the files that differed from it (others may be editing the
/// same tree: the device part builds the firmware as it is on disk).
fn git_state(root: &Path) -> Value {
    // Only trailing whitespace goes: a porcelain line starts with its status columns.
    let out = |args: &[&str]| {
        Command::new("git")
            .args(args)
            .current_dir(root)
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim_end().to_string())
            .unwrap_or_default()
    };
    let dirty: Vec<String> = out(&["status", "--porcelain", "--untracked-files=no"])
        .lines()
        .map(|l| l.get(3..).unwrap_or(l).to_string())
        .collect();
    json!({"commit": out(&["rev-parse", "--short", "HEAD"]), "modified_files": dirty})
}

/// The peer's venv: created and filled by pip when missing.
fn python_env(root: &Path, r: &Runner) -> Result<Value> {
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

// ---------------------------------------------------------------------------------------------
// Statistics

fn median(xs: &[f64]) -> f64 {
    let mut v: Vec<f64> = xs.iter().copied().filter(|x| x.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Least-squares slope of ln y against ln x.
fn log_slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let sxy: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = lx.iter().map(|a| (a - mx).powi(2)).sum();
    sxy / sxx
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array().map(|a| a.iter().filter_map(Value::as_f64).collect()).unwrap_or_default()
}

fn num(v: &Value, path: &[&str]) -> f64 {
    let mut c = v;
    for p in path {
        c = match p.parse::<usize>() {
            Ok(i) => &c[i],
            Err(_) => &c[*p],
        };
    }
    c.as_f64().unwrap_or(f64::NAN)
}

// ---------------------------------------------------------------------------------------------
// Parts

fn device_part(root: &Path, opts: &Opts) -> Result<Value> {
    let path = root.join("target/bench/device.json");
    if opts.no_device {
        eprintln!("bench: --no-device: reusing {}", path.display());
    } else {
        device_bench::run(root)?;
    }
    let text = fs::read_to_string(&path).with_context(|| format!("{}: no device results", path.display()))?;
    let mut v: Value = serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    v["reused_existing_results"] = json!(opts.no_device);
    v["command"] = json!(if opts.no_device {
        "(earlier) cargo xtask bench"
    } else {
        "cargo xtask bench (device part: xtask/src/device_bench.rs)"
    });
    let full = memory_ops(&MemorySpec::<f32>::off(), true);
    v["arithmetic_lower_bound"] = json!({
        "formula": format!("{} K + {} without memory terms; + {} with the full memory bank ({} terms), + M_ops in general", step_ops(1, 0) - step_ops(0, 0), step_ops(0, 0), full, N_MEMORY),
        "per_k": ([16, 32, 64].map(|k| json!({"k": k, "operations": step_ops(k, 0), "operations_full_memory": step_ops(k, full)}))),
        "memory_full_bank": full,
        "source": "shared/src/lib.rs, `Cost of one step`; memory bank: xtask/src/bench.rs, `memory_ops`",
    });
    Ok(v)
}

/// Arithmetic operations of the memory bank and of Γm in one f32 `Compensator::step` on a
/// sample whose Δt equals the previous one (smoothing factors cached), counted from the code
/// (`shared/src/memory/bank.rs`, `Compensator::add_memory`; a multiply-add counts as one), for
/// the terms `spec` uses (every slot when `full`): Δt and the cache test 2; per high-pass of a
/// grating or of T_amb 3 (x − s, the multiply-add s + α(x − s), x − s'); per stop term 5
/// (x − r, x + r, 2 compares, x − p); the drift observer 9 (T_g: 4 multiply-adds over
/// [Δλ1..3, T_amb, 1]; lag 2; − T_amb 1; smoothing 2); Γm one multiply-add per output and
/// used term. 0 without memory terms. A step with a new Δt adds one smoothing factor per used
/// low-pass (a degree-5 series, or `exp` and a subtraction).
pub fn memory_ops(spec: &MemorySpec<f32>, full: bool) -> usize {
    let mut ops = 0;
    let mut used = 0;
    for k in 0..N_MEMORY {
        let Some(t) = spec.term(k) else { continue };
        if !(full || t.parameter > 0.0) {
            continue;
        }
        used += 1;
        ops += match t.group {
            MemoryGroup::GratingHighPass | MemoryGroup::AmbientHighPass => 3,
            MemoryGroup::Stop => 5,
            MemoryGroup::DriftObserver => 9,
        };
    }
    if used == 0 {
        return 0;
    }
    2 + ops + N_OUTPUTS * used
}

/// Arithmetic operations of one f32 `Compensator::step` with `k` centres and `memory` operations
/// of the memory bank ([`memory_ops`]), counted from the current code (the table in the
/// `fbg-shared` crate docs): a multiply-add counts as one.
pub fn step_ops(k: usize, memory: usize) -> usize {
    let exp_neg = 14; // compare, 9 multiply-adds, subtract, negate, 2 exponent-field ops
                      // Distance over the inputs the default (hysteresis-aware) set uses: all but time.
    let per_centre = (1 + Z_DIMS - 1) + exp_neg + (N_OUTPUTS + VAR_RANK + 1);
    let fixed = (N_GRATINGS + 2) // finiteness
        + N_GRATINGS * 10 // direction latches
        + 2 * N_ENVELOPE // envelope
        + N_OUTPUTS * (N_STAGE1 - 1) // stage 1
        + 6 + N_OUTPUTS * N_POLY // φ and B
        + 2 * Z_DIMS // z and ‖z‖²
        + 4 + 1 + VAR_RANK // weak support from ‖ψ‖² (2 compares, 2 products), leverage
        + N_OUTPUTS + 2 + 5 * N_OUTPUTS; // finiteness of y, lead time, bands
    fixed + per_centre * k + memory
}

/// [`step_ops`] of a model blob (its centres and memory terms).
pub fn step_ops_of(blob_bytes: &[u8]) -> Result<usize> {
    let p = crate::fixtures::decode(blob_bytes)?;
    Ok(step_ops(p.centres.len(), memory_ops(&p.memory, false)))
}

fn inference_part(root: &Path, opts: &Opts) -> Result<Value> {
    let mut args = vec!["bench", "--locked", "-p", "fbg-shared", "--bench", "step"];
    if opts.quick {
        args.extend(["--", "--warm-up-time", "1", "--measurement-time", "2"]);
    }
    run(cargo().current_dir(root).args(&args))?;
    let mut rows = Vec::new();
    for prec in ["f32", "f64"] {
        for k in [16, 32, 64] {
            let p = root.join(format!("target/criterion/step_{prec}/{k}/new/estimates.json"));
            let v: Value = serde_json::from_str(&fs::read_to_string(&p).with_context(|| format!("{}", p.display()))?)?;
            let ns_iter = num(&v, &["median", "point_estimate"]);
            let ns_step = ns_iter / STEP_BATCH;
            rows.push(json!({"precision": prec, "k": k, "ns_per_step": ns_step, "samples_per_second": 1e9 / ns_step,
                             "ci95_ns_per_step": [num(&v, &["median", "confidence_interval", "lower_bound"]) / STEP_BATCH,
                                                  num(&v, &["median", "confidence_interval", "upper_bound"]) / STEP_BATCH]}));
        }
    }
    Ok(
        json!({"command": format!("cargo {}", args.join(" ")), "samples_per_iteration": STEP_BATCH, "criterion_samples": 100,
              "statistic": "criterion median of 100 samples (each many iterations of 1024 steps)", "rows": rows}),
    )
}

fn training_part(root: &Path, r: &Runner, opts: &Opts, peer_ok: bool) -> Result<Value> {
    let rounds = if opts.quick { 1 } else { 3 };
    let mut sizes = Vec::new();
    for (n, _) in SIZES {
        let reps = if opts.quick {
            1
        } else if n >= 1_000_000 {
            3
        } else {
            5
        };
        let reps_s = reps.to_string();
        let csv = data(n);
        let fixed = |fs: &str| {
            strings(&["bench-fit", "--data", &csv, "--fixed", "--feature-set", fs, "--repeats", &reps_s, "--json"])
        };
        let peer = |fs: &str| strings(&[PEER, "fit", "--data", &csv, "--features", fs, "--repeats", &reps_s]);
        let notebook =
            strings(&[PEER, "fit", "--data", &csv, "--features", "paper", "--kmeans", "all", "--repeats", &reps_s]);
        // Like with like: the paper feature set (pure scikit-learn on the peer's side), fixed
        // hyper-parameters on both sides, alternating ours / the notebook pipeline / the
        // pipeline with our k-means subsample in each round.
        let mut ours_p = Vec::new();
        let mut ours_phases: Vec<Value> = Vec::new();
        let mut peer_p = Vec::new();
        let mut nb_p = Vec::new();
        let mut ratios = Vec::new();
        let mut nb_ratios = Vec::new();
        let (mut cmd_ours, mut cmd_peer, mut cmd_nb) = (String::new(), String::new(), String::new());
        let (mut last_ours, mut last_peer, mut last_nb) = (Value::Null, Value::Null, Value::Null);
        for _ in 0..rounds {
            let (o, c) = r.json(TRAINER, &fixed("paper"), &[])?;
            cmd_ours = c;
            let mo = num(&o, &["fit_seconds_median"]);
            ours_p.extend(f64s(&o["fit_seconds"]));
            ours_phases.push(o["phase_seconds"].clone());
            last_ours = o;
            if peer_ok {
                let (p, c) = r.json(VENV_PY, &notebook, &[])?;
                cmd_nb = c;
                nb_ratios.push(num(&p, &["fit_seconds_median"]) / mo);
                nb_p.extend(f64s(&p["fit_seconds"]));
                last_nb = p;
                let (p, c) = r.json(VENV_PY, &peer("paper"), &[])?;
                cmd_peer = c;
                ratios.push(num(&p, &["fit_seconds_median"]) / mo);
                peer_p.extend(f64s(&p["fit_seconds"]));
                last_peer = p;
            }
        }
        // The default (hysteresis-aware) features: the peer computes the same latches with a
        // Python loop before its clock starts.
        let (oh, cmd_oh) = r.json(TRAINER, &fixed("hysteresis-aware"), &[])?;
        let (ph, cmd_ph) =
            if peer_ok { r.json(VENV_PY, &peer("hysteresis-aware"), &[])? } else { (Value::Null, String::new()) };
        let (sel, cmd_sel) = r.trainer(&["bench-fit", "--data", &csv, "--select", "--repeats", &reps_s, "--json"])?;
        // The default model's own terms: memory terms (cross-validated menu) fitted with the core.
        // The scikit-learn peer has no memory terms, so this is timed without a peer.
        let mut with_memory = fixed("hysteresis-aware");
        with_memory.push("--memory".into());
        let (om, cmd_om) = r.json(TRAINER, &with_memory, &[])?;
        // What a user waits for: `train` end to end (read the CSV, select, fit, write the blobs
        // and the coefficients), wall clock, once per size.
        let train_dir = root.join("target/bench/train");
        fs::create_dir_all(&train_dir)?;
        let model = rel(&train_dir.join(format!("n{n}.fbgm")), root);
        let t = std::time::Instant::now();
        let (tj, cmd_train) = r.trainer(&["train", "--data", &csv, "--out", &model, "--json"])?;
        let train_wall = t.elapsed().as_secs_f64();
        let csv_bytes = fs::metadata(root.join(&csv)).map(|m| m.len()).unwrap_or(0);
        let read_s = num(&last_ours, &["read_seconds"]);
        sizes.push(json!({
            "train_end_to_end": {"command": cmd_train, "wall_seconds": train_wall, "fit_seconds": tj["train_seconds"],
                                 "csv_bytes": csv_bytes, "csv_read_seconds": read_s,
                                 "csv_read_mb_per_s": csv_bytes as f64 / 1e6 / read_s},
            "fixed_memory": {"command": cmd_om, "fit_seconds": om["fit_seconds"], "median": om["fit_seconds_median"],
                             "rmse_p": om["model_p"]["rmse"], "rmse_h": om["model_h"]["rmse"], "phase_seconds": om["phase_seconds"]},
            "n_samples": n,
            "n_cal": last_ours["n_cal"],
            "repeats_per_process": reps,
            "rounds": rounds,
            "ours_select": {"command": cmd_sel, "fit_seconds": sel["fit_seconds"], "median": sel["fit_seconds_median"],
                            "chosen": sel["chosen"], "grid_points": sel["grid_points"], "rmse_h": sel["model_h"]["rmse"], "rmse_p": sel["model_p"]["rmse"]},
            "fixed_paper": {
                "ours": {"command": cmd_ours, "fit_seconds": ours_p, "median": median(&ours_p),
                         "rmse_p": last_ours["model_p"]["rmse"], "rmse_h": last_ours["model_h"]["rmse"], "blob_bytes": last_ours["model_h"]["blob_bytes"],
                         "read_seconds": last_ours["read_seconds"], "threads": last_ours["threads"]},
                "ours_phases_per_round": ours_phases,
                "peer": if peer_ok { json!({"command": cmd_peer, "fit_seconds": peer_p, "median": median(&peer_p),
                         "rmse_p": last_peer["model_p"]["rmse"], "rmse_h": last_peer["model_h"]["rmse"], "pickle_bytes": last_peer["model_h"]["pickle_bytes"]}) } else { Value::Null },
                "ratio_per_round": ratios,
                "ratio_median": median(&ratios),
                "notebook": if peer_ok { json!({"command": cmd_nb, "fit_seconds": nb_p, "median": median(&nb_p),
                         "rmse_p": last_nb["model_p"]["rmse"], "rmse_h": last_nb["model_h"]["rmse"]}) } else { Value::Null },
                "notebook_ratio_per_round": nb_ratios,
                "notebook_ratio_median": median(&nb_ratios),
            },
            "fixed_default": {
                "ours": {"command": cmd_oh, "fit_seconds": oh["fit_seconds"], "median": oh["fit_seconds_median"], "rmse_p": oh["model_p"]["rmse"], "rmse_h": oh["model_h"]["rmse"]},
                "peer": if peer_ok { json!({"command": cmd_ph, "fit_seconds": ph["fit_seconds"], "median": ph["fit_seconds_median"],
                         "latch_seconds": ph["latch_seconds"], "rmse_p": ph["model_p"]["rmse"], "rmse_h": ph["model_h"]["rmse"]}) } else { Value::Null },
                "ratio": if peer_ok { json!(num(&ph, &["fit_seconds_median"]) / num(&oh, &["fit_seconds_median"])) } else { Value::Null },
            },
        }));
    }
    let ns: Vec<f64> = SIZES.iter().map(|(n, _)| *n as f64).collect();
    let slope = |path: &[&str]| {
        let t: Vec<f64> = sizes.iter().map(|s| num(s, path)).collect();
        if t.iter().all(|v| v.is_finite() && *v > 0.0) {
            json!(log_slope(&ns, &t))
        } else {
            Value::Null
        }
    };
    Ok(json!({
        "fixed_config": {"k": 32, "sigma_mult": 2.0, "alpha_rel": 1e-5, "dead_band_pm": 4.0, "kmeans_seed": 1},
        "sizes": sizes.clone(),
        "growth_exponent": {
            "ours_select": slope(&["ours_select", "median"]),
            "ours_fixed_paper": slope(&["fixed_paper", "ours", "median"]),
            "peer_fixed_paper": slope(&["fixed_paper", "peer", "median"]),
            "notebook_fixed_paper": slope(&["fixed_paper", "notebook", "median"]),
        },
    }))
}

fn accuracy_part(root: &Path, r: &Runner, peer_ok: bool) -> Result<Value> {
    fs::create_dir_all(root.join("target/bench/holdout"))?;
    let mut presets = Vec::new();
    let mut coverage = Vec::new();
    for preset in ["paper", "harsh"] {
        let csv = preset_csv(preset, 7);
        let errs = holdout_errors_csv(preset, 7);
        let (def, c_def) = r.trainer(&[
            "bench-fit",
            "--data",
            &csv,
            "--select",
            "--repeats",
            "1",
            "--json",
            "--holdout-errors",
            &errs,
        ])?;
        let (pap, c_pap) =
            r.trainer(&["bench-fit", "--data", &csv, "--select", "--features", "paper", "--repeats", "1", "--json"])?;
        let meta: Value = serde_json::from_str(&fs::read_to_string(root.join(csv.replace(".csv", ".meta.json")))?)?;
        let (bb, c_bb) = if peer_ok { r.peer(&["blackbox", "--data", &csv])? } else { (Value::Null, String::new()) };
        if preset == "paper" {
            coverage.push(json!({"seed": 7, "coverage_h": def["model_h"]["coverage"], "coverage_p": def["model_p"]["coverage"], "rmse_h": def["model_h"]["rmse"], "rmse_p": def["model_p"]["rmse"], "k": def["chosen"]["k"], "command": c_def}));
        }
        presets.push(json!({
            "preset": preset, "seed": 7, "data": csv,
            "model_p": {"rmse": def["model_p"]["rmse"], "bytes": def["model_p"]["blob_bytes"], "command": c_def},
            "model_h_default": {"rmse": def["model_h"]["rmse"], "bytes": def["model_h"]["blob_bytes"], "chosen": def["chosen"], "coverage": def["model_h"]["coverage"], "parity": def["parity"], "command": c_def},
            "model_h_paper": {"rmse": pap["model_h"]["rmse"], "bytes": pap["model_h"]["blob_bytes"], "chosen": pap["chosen"], "command": c_pap},
            "oracle_floor": {"rmse": meta["oracle_floor_holdout"], "source": format!("{} (written by the simulate command)", csv.replace(".csv", ".meta.json"))},
            "blackbox": if peer_ok { json!({"command": c_bb, "peers": bb["peers"]}) } else { Value::Null },
        }));
    }
    for seed in &COVERAGE_SEEDS[1..] {
        let csv = preset_csv("paper", *seed);
        let errs = holdout_errors_csv("paper", *seed);
        let (v, c) = r.trainer(&[
            "bench-fit",
            "--data",
            &csv,
            "--select",
            "--repeats",
            "1",
            "--json",
            "--holdout-errors",
            &errs,
        ])?;
        coverage.push(json!({"seed": seed, "coverage_h": v["model_h"]["coverage"], "coverage_p": v["model_p"]["coverage"], "rmse_h": v["model_h"]["rmse"], "rmse_p": v["model_p"]["rmse"], "k": v["chosen"]["k"], "command": c}));
    }
    // Gain of Model-H over Model-P per seed and channel [%].
    let gain =
        |s: &Value, c: usize| 100.0 * (1.0 - num(s, &["rmse_h", &c.to_string()]) / num(s, &["rmse_p", &c.to_string()]));
    let gains: Vec<Vec<f64>> = coverage.iter().map(|s| (0..3).map(|c| gain(s, c)).collect()).collect();
    let gain_mean: Vec<f64> =
        (0..3).map(|c| gains.iter().map(|g| g[c]).sum::<f64>() / gains.len().max(1) as f64).collect();
    let gain_min: Vec<f64> = (0..3).map(|c| gains.iter().map(|g| g[c]).fold(f64::INFINITY, f64::min)).collect();
    let seeds_all_25 = gains.iter().filter(|g| g.iter().all(|&v| v >= 25.0)).count();
    let per = |c: usize| -> Vec<f64> { coverage.iter().map(|s| num(s, &["coverage_h", &c.to_string()])).collect() };
    let mean: Vec<f64> = (0..3).map(|c| per(c).iter().sum::<f64>() / coverage.len() as f64).collect();
    let med: Vec<f64> = (0..3).map(|c| median(&per(c))).collect();
    let within: Vec<usize> = (0..3).map(|c| per(c).iter().filter(|v| (*v - 0.95).abs() <= 0.02).count()).collect();
    let files: Vec<PathBuf> = COVERAGE_SEEDS.iter().map(|&s| root.join(holdout_errors_csv("paper", s))).collect();
    let ensemble = ensemble_band_coverage(&files)?;
    Ok(json!({
        "presets": presets,
        "coverage_paper": {"per_seed": coverage, "mean_h": mean, "median_h": med, "seeds_within_95_pm_2": within, "ensemble_band": ensemble},
        "gain_paper": {"per_seed": gains, "mean_pct": gain_mean, "min_pct": gain_min, "seeds_all_channels_25": seeds_all_25},
    }))
}

fn fleet_part(root: &Path, r: &Runner, opts: &Opts) -> Result<Value> {
    let dir = root.join("target/bench/fleet");
    if dir.exists() {
        fs::remove_dir_all(&dir)?;
    }
    fs::create_dir_all(&dir)?;
    let cfg = dir.join("short.toml");
    fs::write(&cfg, "# a short scenario: 2 days at 60 s (2 880 samples, 1 440 calibrate)\n[clock]\ndays = 2.0\n")?;
    let mut manifest = String::from("# every group gets the full `train` grid (features all, K <= 32)\n");
    let mut sim_cmd = String::new();
    for g in 0..FLEET_GROUPS {
        let csv = dir.join(format!("g{g:02}.csv"));
        let (_, c) = r.trainer(&[
            "simulate",
            "--config",
            &rel(&cfg, root),
            "--seed",
            &(100 + g).to_string(),
            "--json",
            "--out",
            &rel(&csv, root),
        ])?;
        if g == 0 {
            sim_cmd = c;
        }
        let _ = write!(
            manifest,
            "\n[[group]]\nname = \"g{g:02}\"\ndata = \"g{g:02}.csv\"\nout = \"models/g{g:02}.fbgm\"\n"
        );
    }
    let m = dir.join("fleet.toml");
    fs::write(&m, manifest)?;
    let rounds = if opts.quick { 1 } else { 3 };
    let mut per_jobs: Vec<(usize, Vec<f64>, String)> = vec![(1, vec![], String::new()), (2, vec![], String::new())];
    let mut speedups = Vec::new();
    for _ in 0..rounds {
        let mut secs = [0.0; 2];
        for (i, (jobs, times, cmd)) in per_jobs.iter_mut().enumerate() {
            let models = dir.join("models");
            if models.exists() {
                fs::remove_dir_all(&models)?;
            }
            let (v, c) = r.trainer(&["fleet", "--manifest", &rel(&m, root), "--jobs", &jobs.to_string(), "--json"])?;
            if num(&v, &["trained"]) as usize != FLEET_GROUPS {
                bail!("fleet bench: expected {FLEET_GROUPS} trained groups, got {v}");
            }
            let s = num(&v, &["seconds"]);
            times.push(s);
            secs[i] = s;
            *cmd = c;
        }
        speedups.push(secs[0] / secs[1]);
    }
    // Nothing changed since the last run: everything is skipped.
    let (resume, c_resume) = r.trainer(&["fleet", "--manifest", &rel(&m, root), "--jobs", "2", "--json"])?;
    Ok(json!({
        "groups": FLEET_GROUPS,
        "scenario": "paper preset, 2 days at 60 s (2 880 samples, 1 440 calibrate), seeds 100..115",
        "simulate_command": format!("{sim_cmd}   (one per group, seeds 100..115)"),
        "rounds": rounds,
        "runs": per_jobs.iter().map(|(j, t, c)| json!({"jobs": j, "seconds": t, "median_seconds": median(t),
                 "groups_per_second": FLEET_GROUPS as f64 / median(t), "command": c})).collect::<Vec<_>>(),
        "speedup_2_over_1_per_round": speedups,
        "speedup_2_over_1_median": median(&speedups),
        "resume": {"command": c_resume, "skipped": resume["skipped"], "trained": resume["trained"], "seconds": resume["seconds"]},
    }))
}

// ---------------------------------------------------------------------------------------------
// BENCHMARKS.md

fn f(v: &Value, digits: usize) -> String {
    match v.as_f64() {
        Some(x) if x.is_finite() => format!("{x:.digits$}"),
        _ => "–".into(),
    }
}

fn fx(x: f64, digits: usize) -> String {
    f(&json!(x), digits)
}

/// Seconds with three significant figures.
fn secs(x: f64) -> String {
    if !x.is_finite() {
        return "–".into();
    }
    let d = if x >= 100.0 {
        0
    } else if x >= 10.0 {
        1
    } else if x >= 1.0 {
        2
    } else {
        3
    };
    format!("{x:.d$} s")
}

fn yes(b: bool) -> &'static str {
    if b {
        "**met**"
    } else {
        "**not met**"
    }
}

fn rmse3(v: &Value) -> [String; 3] {
    [f(&v[0], 3), f(&v[1], 2), f(&v[2], 2)]
}

fn markdown(rep: &Value) -> String {
    let mut s = String::new();
    let m = &rep["machine"];
    let tr = &rep["training"];
    let acc = &rep["accuracy"];
    let dev = &rep["device"];
    let inf = &rep["inference_host"];
    let fl = &rep["fleet"];
    let paper = &acc["presets"][0];
    let big = tr["sizes"].as_array().and_then(|a| a.last()).cloned().unwrap_or(Value::Null);

    let _ = writeln!(s, "# Benchmarks\n");
    let _ = writeln!(
        s,
        "Written by `cargo xtask bench` (xtask/src/bench.rs){}; the same numbers are in `BENCHMARKS.json`. \
         Every time is the median of repeated runs (counts below); every ratio compares runs taken side by side, \
         alternating, in the same invocation. Fits are timed inside the release binaries (CSV reading outside the clock).\n",
        if rep["quick"].as_bool() == Some(true) { " **with --quick (one repeat: not for publishing)**" } else { "" }
    );
    let _ = writeln!(s, "## Machine\n");
    let _ = writeln!(s, "| | |\n|---|---|");
    let _ = writeln!(
        s,
        "| CPU | {} ({} cores), {} RAM |",
        m["cpu"].as_str().unwrap_or("?"),
        m["cores"],
        m["memory"].as_str().unwrap_or("?")
    );
    let _ = writeln!(s, "| OS | {} |", m["os"].as_str().unwrap_or("?"));
    let _ = writeln!(s, "| Rust | {} |", m["rustc"].as_str().unwrap_or("?"));
    match m["scikit_learn"].as_str() {
        Some(v) => {
            let _ = writeln!(s, "| Python peer | Python {}, numpy {}, scikit-learn {} (venv `target/bench/venv`, `pip install scikit-learn numpy`) |", m["python"].as_str().unwrap_or("?"), m["numpy"].as_str().unwrap_or("?"), v);
        }
        None => {
            let _ = writeln!(
                s,
                "| Python peer | **skipped**: {} |",
                m["peer_skipped_because"].as_str().unwrap_or("python3/venv/pip unavailable")
            );
        }
    }
    let _ = writeln!(s, "| QEMU | {} |", m["qemu"].as_str().unwrap_or("?"));
    let dirty: Vec<&str> =
        m["git"]["modified_files"].as_array().map(|a| a.iter().filter_map(Value::as_str).collect()).unwrap_or_default();
    let _ = writeln!(
        s,
        "| source | commit {}{} |",
        m["git"]["commit"].as_str().unwrap_or("?"),
        if dirty.is_empty() { String::new() } else { format!(" with uncommitted changes to {}", dirty.join(", ")) }
    );
    let _ = writeln!(
        s,
        "| load average (1/5/15 min) | {} at the start, {} at the end |",
        m["loadavg_start"].as_str().unwrap_or("?"),
        m["loadavg_end"].as_str().unwrap_or("?")
    );
    let _ = writeln!(s, "| whole run | {:.0} s |\n", rep["wall_seconds"].as_f64().unwrap_or(0.0));

    // Headline.
    let _ = writeln!(s, "## Targets (DESIGN §8)\n");
    let _ = writeln!(s, "| target | measured | verdict | command |\n|---|---|---|---|");
    let gains: Vec<f64> = (0..3)
        .map(|c| {
            100.0
                * (1.0
                    - num(paper, &["model_h_default", "rmse", &c.to_string()])
                        / num(paper, &["model_p", "rmse", &c.to_string()]))
        })
        .collect();
    let _ = writeln!(
        s,
        "| accuracy, `paper` preset: Model-H hold-out RMSE ≥ 25 % below Model-P on every channel | {:.1} / {:.1} / {:.1} % below (T / ε / p); Model-H at {:.2} / {:.2} / {:.2} × the per-sample oracle | {} | `{}` |",
        gains[0], gains[1], gains[2],
        num(paper, &["model_h_default", "rmse", "0"]) / num(paper, &["oracle_floor", "rmse", "0"]),
        num(paper, &["model_h_default", "rmse", "1"]) / num(paper, &["oracle_floor", "rmse", "1"]),
        num(paper, &["model_h_default", "rmse", "2"]) / num(paper, &["oracle_floor", "rmse", "2"]),
        yes(gains.iter().all(|g| *g >= 25.0)),
        paper["model_h_default"]["command"].as_str().unwrap_or("")
    );
    let g = &acc["gain_paper"];
    let gm: Vec<f64> = (0..3).map(|c| num(g, &["mean_pct", &c.to_string()])).collect();
    let gmin: Vec<f64> = (0..3).map(|c| num(g, &["min_pct", &c.to_string()])).collect();
    let n_all = g["seeds_all_channels_25"].as_u64().unwrap_or(0) as usize;
    let _ = writeln!(
        s,
        "| accuracy, `paper` preset, seeds {}–{}: ≥ 25 % on every channel on every seed; mean ≥ 40 / 30 / 40 % (T / ε / p) | mean {:.1} / {:.1} / {:.1} %, smallest {:.1} / {:.1} / {:.1} %; {} of {} seeds ≥ 25 % on every channel | {} | coverage runs (below) |",
        COVERAGE_SEEDS[0], COVERAGE_SEEDS[COVERAGE_SEEDS.len() - 1],
        gm[0], gm[1], gm[2], gmin[0], gmin[1], gmin[2], n_all, COVERAGE_SEEDS.len(),
        yes(n_all == COVERAGE_SEEDS.len() && gm[0] >= 40.0 && gm[1] >= 30.0 && gm[2] >= 40.0)
    );
    let par = &paper["model_h_default"]["parity"];
    let pmax: Vec<f64> = (0..3).map(|c| 100.0 * num(par, &["max_diff_over_rmse", &c.to_string()])).collect();
    let _ = writeln!(
        s,
        "| f32 device path vs f64 host: max difference ≤ 1 % of Model-H's RMSE | {:.4} / {:.4} / {:.4} % ({} hold-out samples, {} flag mismatches) | {} | same run |",
        pmax[0], pmax[1], pmax[2], par["samples"], par["flag_mismatches"], yes(pmax.iter().all(|p| *p <= 1.0))
    );
    let d0 =
        dev["step"].as_array().and_then(|a| a.iter().find(|x| x["name"] == "default")).cloned().unwrap_or(Value::Null);
    let ins = num(&d0, &["instructions_per_step"]);
    let _ = writeln!(
        s,
        "| inference cost, default model with its memory bank (K = {}, {} memory terms): ≤ 2 500 instructions per step (QEMU -icount) | {} instructions ({} with a new Δt every step; arithmetic lower bound {}) | {} | `{}` |",
        d0["k"], d0["memory_terms"], fx(ins, 0), f(&d0["instructions_per_step_new_dt_every_step"], 0), d0["lower_bound_ops"], yes(ins <= 2500.0), dev["command"].as_str().unwrap_or("cargo xtask bench")
    );
    let pr = &dev["product"];
    let flash = num(pr, &["flash_bytes"]);
    let ram = num(pr, &["static_ram_plus_stack_bytes"]);
    let ram_serving = num(pr, &["static_ram_plus_serving_stack_bytes"]);
    let blob = num(paper, &["model_h_default", "bytes"]);
    let _ = writeln!(
        s,
        "| firmware flash ≤ 32 KiB | {} B ({:.1} KiB) | {} | device part |",
        fx(flash, 0),
        flash / 1024.0,
        yes(flash <= 32768.0)
    );
    let _ = writeln!(
        s,
        "| static RAM + measured stack ≤ 8 KiB serving (≤ 12 KiB at the model-load / verification peak) | {} B while serving; {} B at the peak (boot / model update) | {} (load peak ≤ 12 KiB: {}) | device part |",
        fx(ram_serving, 0), fx(ram, 0), yes(ram_serving <= 8192.0), if ram <= 12288.0 { "met" } else { "not met" }
    );
    let _ = writeln!(
        s,
        "| blob ≤ 4 KiB | trained Model-H (K = {}) {} B; device default model {} B | {} | accuracy run; device part |",
        paper["model_h_default"]["chosen"]["k"],
        fx(blob, 0),
        f(&pr["default_blob_bytes"], 0),
        yes(blob <= 4096.0)
    );
    let ratio = num(&big, &["fixed_paper", "ratio_median"]);
    let nb_ratio = num(&big, &["fixed_paper", "notebook_ratio_median"]);
    let agree = max_rel_diff(&big["fixed_paper"]["ours"]["rmse_h"], &big["fixed_paper"]["notebook"]["rmse_h"]);
    let agree_sub = max_rel_diff(&big["fixed_paper"]["ours"]["rmse_h"], &big["fixed_paper"]["peer"]["rmse_h"]);
    let _ = writeln!(
        s,
        "| host training: 1 000 000 samples ≥ 5× faster than the equivalent scikit-learn pipeline, same accuracy | \
         fit time scikit-learn / ours = **{}×** against the pipeline as a notebook writes it (`KMeans` with its defaults on every calibration row; ours {} vs {}), \
         Model-H hold-out RMSE within {:.1} %; **{}×** against the same pipeline given our k-means subsample ({}; RMSE within {:.1} %) | \
         {} against the notebook pipeline; {} against the subsampled one | `{}` vs `{}` and `{}` |",
        fx(nb_ratio, 2), secs(num(&big, &["fixed_paper", "ours", "median"])), secs(num(&big, &["fixed_paper", "notebook", "median"])), 100.0 * agree,
        fx(ratio, 2), secs(num(&big, &["fixed_paper", "peer", "median"])), 100.0 * agree_sub,
        yes(nb_ratio >= 5.0 && agree <= 0.05), yes(ratio >= 5.0 && agree_sub <= 0.05),
        big["fixed_paper"]["ours"]["command"].as_str().unwrap_or(""), big["fixed_paper"]["notebook"]["command"].as_str().unwrap_or(""),
        big["fixed_paper"]["peer"]["command"].as_str().unwrap_or("")
    );
    let cov = &paper["model_h_default"]["coverage"];
    let covs: Vec<f64> = (0..3).map(|c| 100.0 * num(cov, &[&c.to_string()])).collect();
    let mean = &acc["coverage_paper"]["mean_h"];
    let _ = writeln!(
        s,
        "| band coverage 95 ± 2 % on the `paper` hold-out | seed 7: {:.1} / {:.1} / {:.1} %; mean of seeds 7–26: {:.1} / {:.1} / {:.1} % | {} (seed 7) | accuracy run; coverage runs |\n",
        covs[0], covs[1], covs[2], 100.0 * num(mean, &["0"]), 100.0 * num(mean, &["1"]), 100.0 * num(mean, &["2"]),
        yes(covs.iter().all(|c| (c - 95.0).abs() <= 2.0))
    );

    // Training.
    let _ = writeln!(s, "## Host training time\n");
    let _ = writeln!(
        s,
        "Model-P + Model-H on the calibration half of the `paper` scenario sampled at 1e4, 1e5 and 1e6 points over its 14 days \
         (`[clock] dt_s` = 120.96 / 12.096 / 1.2096 s, seed 7). *Select* is `train`'s full hyper-parameter selection by blocked \
         time-series cross-validation (540 grid points; beyond 40 000 calibration rows the CV works on an even stride, the final fit uses every row). \
         *Fixed* is one configuration, K = 32, σ = 2 × the median nearest-neighbour distance of the centres, α = 1e-5·n, dead band 4 pm; \
         ours still runs the cross-validation once for the 95 % band, which the peer does not compute. Both sides use every core \
         (ours: rayon; scikit-learn: its OpenMP/BLAS threads).\n"
    );
    let _ = writeln!(
        s,
        "| samples | calibration rows | ours, select (default: memory terms) | ours, fixed | scikit-learn notebook, fixed | ratio notebook / ours | scikit-learn with our k-means subsample | ratio subsampled / ours | ours, fixed, latch features | sklearn (subsample), latch features | ratio | ours, fixed, latch RBF + memory terms (no peer) |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for z in tr["sizes"].as_array().into_iter().flatten() {
        let fp = &z["fixed_paper"];
        let fd = &z["fixed_default"];
        let rounds = |key: &str| f64s(&fp[key]).iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", ");
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | **{}×** (rounds: {}) | {} | **{}×** (rounds: {}) | {} | {} (+ {} latch loop) | {}× | {} |",
            z["n_samples"], z["n_cal"], secs(num(z, &["ours_select", "median"])), secs(num(fp, &["ours", "median"])),
            secs(num(fp, &["notebook", "median"])), fx(num(fp, &["notebook_ratio_median"]), 2), rounds("notebook_ratio_per_round"),
            secs(num(fp, &["peer", "median"])), fx(num(fp, &["ratio_median"]), 2), rounds("ratio_per_round"),
            secs(num(fd, &["ours", "median"])), secs(num(fd, &["peer", "median"])), secs(num(fd, &["peer", "latch_seconds"])), fx(num(fd, &["ratio"]), 2),
            secs(num(z, &["fixed_memory", "median"]))
        );
    }
    // What a user waits for: `train` from the CSV to the written blobs.
    let _ = writeln!(
        s,
        "\n`train` end to end (one run per size, wall clock of the process: read the CSV, select by cross-validation, fit, write both blobs and the coefficients) beside the fit time it reports and the CSV read rate of `bench-fit`:\n"
    );
    let _ = writeln!(
        s,
        "| samples | `train` wall clock | of which the fit | CSV size | CSV read | read rate | command |\n|---|---|---|---|---|---|---|"
    );
    for z in tr["sizes"].as_array().into_iter().flatten() {
        let e = &z["train_end_to_end"];
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} MB | {} | {:.0} MB/s | `{}` |",
            z["n_samples"],
            secs(num(e, &["wall_seconds"])),
            secs(num(e, &["fit_seconds"])),
            num(e, &["csv_bytes"]) / 1e6,
            secs(num(e, &["csv_read_seconds"])),
            num(e, &["csv_read_mb_per_s"]),
            e["command"].as_str().unwrap_or("")
        );
    }
    // Where our fixed fit spends its time at the largest size (median over rounds per phase).
    if let Some(rounds) = big["fixed_paper"]["ours_phases_per_round"].as_array().filter(|a| !a.is_empty()) {
        let names: Vec<String> =
            rounds[0].as_array().into_iter().flatten().map(|p| p[0].as_str().unwrap_or("").to_string()).collect();
        let _ = writeln!(
            s,
            "\nOur fixed fit at {} samples, phase by phase (median over the rounds of each process's median):\n",
            big["n_samples"]
        );
        let _ = writeln!(s, "| phase | seconds |\n|---|---|");
        for (k, name) in names.iter().enumerate() {
            let t: Vec<f64> =
                rounds.iter().filter_map(|r| r.get(k).and_then(|p| p.get(1)).and_then(Value::as_f64)).collect();
            let _ = writeln!(s, "| {name} | {} |", secs(median(&t)));
        }
    }
    let g = &tr["growth_exponent"];
    let _ = writeln!(
        s,
        "\nGrowth exponent (least-squares slope of ln time against ln n over the three sizes): ours with selection **{}**, ours fixed **{}**, scikit-learn with our subsample, fixed **{}**. \
         Below 1 because costs that do not grow with n still weigh at these sizes: k-means on at most 20 000 points on both sides, and on ours the \
         cross-validation on at most 40 000 rows; the per-sample passes (design matrix, ΨᵀΨ, latches) grow linearly. \
         The notebook pipeline's k-means sees every row, so it grows faster: exponent **{}**.\n",
        f(&g["ours_select"], 2), f(&g["ours_fixed_paper"], 2), f(&g["peer_fixed_paper"], 2), f(&g["notebook_fixed_paper"], 2)
    );
    if let Some(z) = tr["sizes"].as_array().and_then(|a| a.first()) {
        let _ = writeln!(
            s,
            "Repeats: each process fits {} times at 1e4 and 1e5 and {} times at 1e6 and reports the median; the paper-feature comparison alternates ours / the notebook pipeline / the subsampled pipeline for {} rounds and each ratio is the median of the rounds' ratios; the other columns are one process each.\n",
            z["repeats_per_process"], big["repeats_per_process"], z["rounds"]
        );
    }
    let _ = writeln!(s, "Hold-out RMSE of the fixed fits, ours vs scikit-learn (T [°C] / ε [µε] / p [kPa]):\n");
    let _ = writeln!(s, "| samples | features | peer | ours Model-P | sklearn Model-P | ours Model-H | sklearn Model-H | max relative difference (Model-H) |\n|---|---|---|---|---|---|---|---|");
    for z in tr["sizes"].as_array().into_iter().flatten() {
        for (key, peer, name, how) in [
            ("fixed_paper", "notebook", "paper", "notebook"),
            ("fixed_paper", "peer", "paper", "our subsample"),
            ("fixed_default", "peer", "hysteresis-aware", "our subsample"),
        ] {
            let o = &z[key]["ours"];
            let p = &z[key][peer];
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {:.1} % |",
                z["n_samples"],
                name,
                how,
                rmse3(&o["rmse_p"]).join(" / "),
                rmse3(&p["rmse_p"]).join(" / "),
                rmse3(&o["rmse_h"]).join(" / "),
                rmse3(&p["rmse_h"]).join(" / "),
                100.0 * max_rel_diff(&o["rmse_h"], &p["rmse_h"])
            );
        }
    }
    let _ = writeln!(s, "\nCommands (n = 1e6 shown; the others differ only in the CSV):\n");
    for c in [
        &big["ours_select"]["command"],
        &big["fixed_paper"]["ours"]["command"],
        &big["fixed_paper"]["notebook"]["command"],
        &big["fixed_paper"]["peer"]["command"],
        &big["fixed_default"]["ours"]["command"],
        &big["fixed_default"]["peer"]["command"],
    ] {
        if let Some(c) = c.as_str().filter(|c| !c.is_empty()) {
            let _ = writeln!(s, "    {c}");
        }
    }
    let _ = writeln!(s, "\nDatasets:\n");
    for c in rep["datasets"].as_array().into_iter().flatten() {
        let _ = writeln!(s, "    {}", c.as_str().unwrap_or(""));
    }
    let _ = writeln!(s, "\n{PEER_TEXT}\n");

    // Inference.
    let _ = writeln!(s, "## Host inference throughput (`fbg-shared`, criterion)\n");
    let _ = writeln!(s, "`Compensator::step` on a stream of 1 024 samples per iteration, synthetic hysteresis-aware models (`shared/benches/step.rs`); criterion median of 100 samples, one core.\n");
    let _ = writeln!(s, "| precision | K | ns per step | samples per second |\n|---|---|---|---|");
    for row in inf["rows"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.2} M |",
            row["precision"].as_str().unwrap_or(""),
            row["k"],
            f(&row["ns_per_step"], 0),
            num(row, &["samples_per_second"]) / 1e6
        );
    }
    let _ = writeln!(s, "\n    {}\n", inf["command"].as_str().unwrap_or(""));

    // Accuracy.
    let _ = writeln!(s, "## Accuracy against black-box peers and the per-sample oracle\n");
    let _ = writeln!(
        s,
        "Hold-out RMSE per channel on the `paper` and `harsh` presets (seed 7, 14 days at 60 s, first half calibrates). Ours: `train`'s selection \
         (default: memory terms fitted with the core, groups and λ by cross-validation, plus the RBF residual on the latches; `--features paper`: only Eq. 5's inputs, no memory terms). Black boxes: scikit-learn on the same \
         calibration rows with the inputs named; *Model-P + HistGradientBoosting residual* is a hybrid whose residual learner is a gradient-boosting \
         model instead of the RBF ridge, on the latches or on 59 causal history inputs (`bench/sklearn_peer.py`'s `history_features`): how far far more \
         information and a far larger learner get. Size: our `.fbgm` blob; scikit-learn: `len(pickle.dumps(model))`.\n"
    );
    for p in acc["presets"].as_array().into_iter().flatten() {
        let _ = writeln!(s, "### `{}`\n", p["preset"].as_str().unwrap_or(""));
        let _ = writeln!(s, "| model | inputs | T [°C] | ε [µε] | p [kPa] | below Model-P (T / ε / p) | size |\n|---|---|---|---|---|---|---|");
        let base: Vec<f64> = (0..3).map(|c| num(p, &["model_p", "rmse", &c.to_string()])).collect();
        let row = |s: &mut String, name: &str, inputs: &str, rm: &Value, size: String| {
            let r = rmse3(rm);
            // Rounded first, so that a gain of −0.3 % reads 0 %, not −0 %.
            let gain: Vec<String> = (0..3)
                .map(|c| format!("{:.0} %", (100.0 * (1.0 - num(rm, &[&c.to_string()]) / base[c])).round() + 0.0))
                .collect();
            let _ =
                writeln!(s, "| {name} | {inputs} | {} | {} | {} | {} | {size} |", r[0], r[1], r[2], gain.join(" / "));
        };
        row(&mut s, "Model-P", "Δλ, T_amb", &p["model_p"]["rmse"], format!("{} B", p["model_p"]["bytes"]));
        let ch = &p["model_h_default"]["chosen"];
        row(
            &mut s,
            "Model-H (default: memory terms + RBF)",
            &format!("chosen: {}, K = {}", ch["feature_set"].as_str().unwrap_or("?"), ch["k"]),
            &p["model_h_default"]["rmse"],
            format!("{} B", p["model_h_default"]["bytes"]),
        );
        let cp = &p["model_h_paper"]["chosen"];
        row(
            &mut s,
            "Model-H (`--features paper`)",
            &format!("Δλ, T_amb, t; K = {}", cp["k"]),
            &p["model_h_paper"]["rmse"],
            format!("{} B", p["model_h_paper"]["bytes"]),
        );
        let mut best = [f64::INFINITY; 3];
        for b in p["blackbox"]["peers"].as_array().into_iter().flatten() {
            for (c, bst) in best.iter_mut().enumerate() {
                *bst = bst.min(num(b, &["rmse", &c.to_string()]));
            }
            let inputs = match b["n_inputs"].as_u64() {
                Some(n) => format!("{} ({n} inputs)", b["inputs"].as_str().unwrap_or("")),
                None => b["inputs"].as_str().unwrap_or("").to_string(),
            };
            row(
                &mut s,
                &format!("scikit-learn {}", b["model"].as_str().unwrap_or("")),
                &inputs,
                &b["rmse"],
                format!("{} B", b["pickle_bytes"]),
            );
        }
        row(
            &mut s,
            "per-sample oracle",
            "true physics inverted sample by sample, noise-only wavelengths",
            &p["oracle_floor"]["rmse"],
            "–".into(),
        );
        if best[0].is_finite() {
            let h: Vec<f64> = (0..3).map(|c| num(p, &["model_h_default", "rmse", &c.to_string()])).collect();
            let fl: Vec<f64> = (0..3).map(|c| num(p, &["oracle_floor", "rmse", &c.to_string()])).collect();
            let _ = writeln!(
                s,
                "\nModel-H (default) / best black box: {:.2} / {:.2} / {:.2}; Model-H / per-sample oracle: {:.2} / {:.2} / {:.2}; best black box / oracle: {:.2} / {:.2} / {:.2}.",
                h[0] / best[0], h[1] / best[1], h[2] / best[2], h[0] / fl[0], h[1] / fl[1], h[2] / fl[2], best[0] / fl[0], best[1] / fl[1], best[2] / fl[2]
            );
        }
        let _ = writeln!(
            s,
            "\n    {}\n    {}",
            p["model_h_default"]["command"].as_str().unwrap_or(""),
            p["model_h_paper"]["command"].as_str().unwrap_or("")
        );
        if let Some(c) = p["blackbox"]["command"].as_str() {
            let _ = writeln!(s, "    {c}");
        }
        let _ = writeln!(s, "    (per-sample oracle: {})\n", p["oracle_floor"]["source"].as_str().unwrap_or(""));
    }
    let _ = writeln!(
        s,
        "### Gain over Model-P and band coverage of Model-H, `paper` preset, seeds {}–{}\n",
        COVERAGE_SEEDS[0],
        COVERAGE_SEEDS[COVERAGE_SEEDS.len() - 1]
    );
    let _ = writeln!(s, "| seed | K | gain T | gain ε | gain p | coverage T | coverage ε | coverage p | command |\n|---|---|---|---|---|---|---|---|---|");
    for c in acc["coverage_paper"]["per_seed"].as_array().into_iter().flatten() {
        let gain =
            |ch: usize| 100.0 * (1.0 - num(c, &["rmse_h", &ch.to_string()]) / num(c, &["rmse_p", &ch.to_string()]));
        let _ = writeln!(
            s,
            "| {} | {} | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % | {:.1} % | `{}` |",
            c["seed"],
            c["k"],
            gain(0),
            gain(1),
            gain(2),
            100.0 * num(c, &["coverage_h", "0"]),
            100.0 * num(c, &["coverage_h", "1"]),
            100.0 * num(c, &["coverage_h", "2"]),
            c["command"].as_str().unwrap_or("")
        );
    }
    let g = &acc["gain_paper"];
    let _ = writeln!(
        s,
        "| **gain mean** | | **{:.1} %** | **{:.1} %** | **{:.1} %** | | | | target ≥ 40 / 30 / 40 % |",
        num(g, &["mean_pct", "0"]),
        num(g, &["mean_pct", "1"]),
        num(g, &["mean_pct", "2"])
    );
    let _ = writeln!(
        s,
        "| gain smallest | | {:.1} % | {:.1} % | {:.1} % | | | | target ≥ 25 % on every seed |",
        num(g, &["min_pct", "0"]),
        num(g, &["min_pct", "1"]),
        num(g, &["min_pct", "2"])
    );
    let _ = writeln!(
        s,
        "| **coverage mean** | | | | | **{:.1} %** | **{:.1} %** | **{:.1} %** | target 95 ± 1 % |",
        100.0 * num(mean, &["0"]),
        100.0 * num(mean, &["1"]),
        100.0 * num(mean, &["2"])
    );
    let med = &acc["coverage_paper"]["median_h"];
    let _ = writeln!(
        s,
        "| coverage median | | | | | {:.1} % | {:.1} % | {:.1} % | |",
        100.0 * num(med, &["0"]),
        100.0 * num(med, &["1"]),
        100.0 * num(med, &["2"])
    );
    let w = &acc["coverage_paper"]["seeds_within_95_pm_2"];
    let _ = writeln!(
        s,
        "| seeds within 95 ± 2 % | | | | | {} of {n} | {} of {n} | {} of {n} | target ≥ 16 of {n} |",
        w[0],
        w[1],
        w[2],
        n = COVERAGE_SEEDS.len()
    );
    let ens = &acc["coverage_paper"]["ensemble_band"]["channels"];
    let _ = writeln!(
        s,
        "| *reference: ensemble band*, seeds within 95 ± 2 % | | | | | {} of {n} | {} of {n} | {} of {n} | |",
        ens[0]["seeds_within_95_pm_2"],
        ens[1]["seeds_within_95_pm_2"],
        ens[2]["seeds_within_95_pm_2"],
        n = COVERAGE_SEEDS.len()
    );
    let _ = writeln!(
        s,
        "| *reference: ensemble band*, lowest seed | | | | | {:.1} % | {:.1} % | {:.1} % | |\n",
        100.0 * num(&ens[0], &["min"]),
        100.0 * num(&ens[1], &["min"]),
        100.0 * num(&ens[2], &["min"]),
    );
    let _ = writeln!(
        s,
        "The *ensemble band* is a reference no model can have: a band that depends on the lead time alone, \
         set to the 95 % quantile of |error| of Model-H over all {n} seeds' hold-outs at once (2-hour lead bins). \
         Its per-seed coverage is the spread that comes from the hold-out week itself (each seed is one drift path; \
         a seed whose error keeps one sign for the whole week falls outside any band of the right average width), \
         not from the band a model estimates from its own calibration batch. Where it stays below 16 of {n}, \
         no band that depends on the lead time alone meets the per-seed target. \
         Per-sample errors and bands: `target/bench/holdout/paper-s<seed>.csv` (`bench-fit --holdout-errors`).\n",
        n = COVERAGE_SEEDS.len()
    );

    // Device.
    let _ = writeln!(s, "## Device (Cortex-M4F under QEMU)\n");
    if let Some(e) = dev["error"].as_str() {
        let _ = writeln!(s, "**The device bench failed:** {e}\n");
    } else {
        let _ = writeln!(
            s,
            "{}. Models: the device bench's fixtures at each K (`xtask/src/fixtures.rs`). Lower bound: the arithmetic operations of one f32 `step` counted from the code ({} operations; table in `shared/src/lib.rs`), each at least one instruction.{}\n",
            dev["method"].as_str().unwrap_or(""),
            dev["arithmetic_lower_bound"]["formula"].as_str().unwrap_or(""),
            if dev["reused_existing_results"].as_bool() == Some(true) { " **Reused from an earlier run (--no-device).**" } else { "" }
        );
        let _ = writeln!(s, "| model | K | memory terms | instructions per step | new Δt every step | arithmetic lower bound | measured / bound | blob | bench image stack |\n|---|---|---|---|---|---|---|---|---|");
        for st in dev["step"].as_array().into_iter().flatten() {
            let i = num(st, &["instructions_per_step"]);
            let lb = num(st, &["lower_bound_ops"]);
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {:.2} | {} B | {} B |",
                st["name"].as_str().unwrap_or("?"),
                st["k"],
                st["memory_terms"],
                fx(i, 0),
                f(&st["instructions_per_step_new_dt_every_step"], 0),
                fx(lb, 0),
                i / lb,
                st["blob_bytes"],
                st["stack_peak_bytes"]
            );
        }
        let sz = &dev["sizes"];
        let _ = writeln!(
            s,
            "\nDevice types (`size_of` on the target, K = {}): memory state `MemoryState<f32>` {} B, stream state (latches + memory) {} B, `MemoryBank<f32>` {} B, `Compensator<f32, {}>` {} B, parameter slot `ModelParams<f32, {}>` (on the stack during a load) {} B, blob staging buffer {} B.",
            sz["k"], sz["memory_state_bytes"], sz["stream_state_bytes"], sz["memory_bank_bytes"], sz["k"], sz["compensator_bytes"], sz["k"], sz["model_params_bytes"], sz["staging_bytes"]
        );
        let _ = writeln!(
            s,
            "\nProduct image (K = {}): flash {} B, static RAM {} B, stack peak {} B at boot, {} B while serving, {} B through a model update; default blob {} B.\n\n    {}\n",
            pr["k"], pr["flash_bytes"], pr["static_ram_bytes"], pr["stack_peak_boot_bytes"], pr["stack_peak_serving_bytes"], pr["stack_peak_update_bytes"], pr["default_blob_bytes"],
            dev["command"].as_str().unwrap_or("")
        );
    }

    // Fleet.
    let _ = writeln!(s, "## Fleet calibration (`fbg-trainer fleet`)\n");
    let _ = writeln!(s, "{} sensor groups, each {}, with `train`'s full selection; every run starts from no outputs; the two pool sizes alternate for {} rounds; time is the fleet's own wall clock (manifest parsed, every group read, fitted and written).\n", fl["groups"], fl["scenario"].as_str().unwrap_or(""), fl["rounds"]);
    let _ =
        writeln!(s, "| jobs (cores) | median wall time | groups per second | runs | command |\n|---|---|---|---|---|");
    for run in fl["runs"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} | {} | `{}` |",
            run["jobs"],
            secs(num(run, &["median_seconds"])),
            num(run, &["groups_per_second"]),
            f64s(&run["seconds"]).iter().map(|x| format!("{x:.2}")).collect::<Vec<_>>().join(", "),
            run["command"].as_str().unwrap_or("")
        );
    }
    let _ = writeln!(
        s,
        "\nSpeed-up of 2 jobs over 1 (median of the rounds' ratios): **{}×**. A rerun with nothing changed skipped {} groups and trained {} in {} (`{}`).\n\n    {}\n",
        f(&fl["speedup_2_over_1_median"], 2), fl["resume"]["skipped"], fl["resume"]["trained"], secs(num(fl, &["resume", "seconds"])),
        fl["resume"]["command"].as_str().unwrap_or(""), fl["simulate_command"].as_str().unwrap_or("")
    );
    s
}

/// Largest |a − b| / b over the channels (NaN when either side is missing).
fn max_rel_diff(a: &Value, b: &Value) -> f64 {
    let (a, b) = (f64s(a), f64s(b));
    if a.len() != 3 || b.len() != 3 {
        return f64::NAN;
    }
    a.iter().zip(&b).map(|(x, y)| ((x - y) / y).abs()).fold(0.0, f64::max)
}

const PEER_TEXT: &str = "What the scikit-learn peer computes (`bench/sklearn_peer.py fit`, timed like ours: the CSV read once, then each fit timed alone): \
on the calibration rows, stage 1 `LinearRegression` from [Δλ1..3, T_amb] to [T, ε, p]; stage 2 `StandardScaler` → `PolynomialFeatures(2)` → \
`LinearRegression` on the first guesses (Model-P, the same ten terms as Eq. 3); the RBF inputs z (`paper`: Δλ1..3, T_amb, t; `hysteresis-aware`: \
Δλ1..3, T_amb and the three direction latches, computed by a Python port of `fbg_shared::DirectionLatch` over the whole record *before* the clock \
starts, its time shown separately) through `StandardScaler`; then k-means in one of two ways: the *notebook* pipeline (`--kmeans all`) runs \
`KMeans(K, random_state=seed)` with scikit-learn's defaults (k-means++, one initialisation, up to 300 iterations, tol 1e-4) on every calibration row, \
as DESIGN §4's \"k-means over the calibration batch\" reads and as one writes it in a notebook; the *subsampled* pipeline (`--kmeans subsample`) runs \
`KMeans(K, init=\"k-means++\", n_init=1, max_iter=100)` on every ceil(n/20 000)-th row, our own subsample and iteration cap ported to scikit-learn, \
so that it compares the two implementations of one algorithm; σ = σ-multiplier × the median nearest-neighbour distance of the centres; ψ = `rbf_kernel(z, centres, γ = 1/2σ²)`; \
`Ridge(alpha = α_rel·n, fit_intercept=False)` from ψ to the Model-P residuals. It does not compute the band (our fit's cross-validation of the \
residual variance), the envelope, the weak-support threshold or the variance eigen-directions.";
