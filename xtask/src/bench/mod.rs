//! `cargo xtask bench`: every figure of DESIGN §8, written to `BENCHMARKS.md` and its
//! twin `BENCHMARKS.json` at the top of the workspace.
//!
//! xtask itself runs in the dev profile, so nothing is timed in this process: it builds the
//! release trainer and times its `bench-fit` command (each fit timed alone inside the process,
//! the CSV read outside the clock), runs the scikit-learn peer (`bench/sklearn_peer.py`, in a
//! venv under `target/bench/venv`) the same way, the criterion bench of `fbg-shared`, the
//! `fleet` command, the peak memory of `train`, `compensate` and `evaluate` (`memory`), and
//! the device bench (`device_bench::run`, QEMU). Every figure is a median
//! of repeated runs, and every ratio compares runs taken side by side, alternating, in the same
//! invocation. The exact command behind each figure is recorded next to it.
//!
//! `cargo xtask bench --spectrum-only [--quick]` measures only the spectrum part
//! ([`spectrum`]) into the BENCHMARKS.json already there; `--import-memory-only [--quick]`
//! only the spectra import's peak memory ([`memory::spectra_import`]); `--installations-only`
//! only the hold-out band coverage of `array-8` and `strain-pair` ([`installations`]).
//!
//! `cargo xtask bench [--quick] [--no-device]`: `--quick` takes one round of one repeat (for
//! trying the task out, not for publishing); `--no-device` reuses `target/bench/device.json`
//! instead of running QEMU; `--markdown-only` renders BENCHMARKS.md again from BENCHMARKS.json
//! and measures nothing.

use std::fs;
use std::path::Path;

use anyhow::Result;

use crate::cmd::{cargo, run, step, write_atomic};
use report::{Device, Report};
use runner::Runner;

/// `writeln!` into a `String`, which cannot fail.
macro_rules! out {
    ($s:expr) => {{
        let _ = std::fmt::Write::write_fmt($s, format_args!("\n"));
    }};
    ($s:expr, $($arg:tt)*) => {{
        let _ = std::fmt::Write::write_fmt($s, format_args!("{}\n", format_args!($($arg)*)));
    }};
}

pub mod accuracy;
pub mod device;
pub mod fleet;
pub mod inference;
pub mod installations;
pub mod machine;
pub mod markdown;
pub mod memory;
pub mod pace;
pub mod python;
pub mod report;
pub mod runner;
pub mod spectrum;
pub mod stats;
pub mod training;
pub mod verdict;

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

/// The flags of `cargo xtask bench` (`--markdown-only` excludes the others; each `--…-only`
/// measures one part into the BENCHMARKS.json already there).
#[derive(Debug, clap::Args)]
pub struct Opts {
    /// One round of one repeat (for trying the task out, not for publishing)
    #[arg(long)]
    pub quick: bool,
    /// Reuse target/bench/device.json instead of running QEMU
    #[arg(long)]
    pub no_device: bool,
    /// Only BENCHMARKS.md, rendered again from BENCHMARKS.json (measures nothing)
    #[arg(long, conflicts_with_all = ["quick", "no_device"])]
    pub markdown_only: bool,
    /// Only the spectrum part (detector throughput, accuracy table, the spectrum chain),
    /// into the BENCHMARKS.json already there
    #[arg(long, conflicts_with_all = ["no_device", "markdown_only"])]
    pub spectrum_only: bool,
    /// Only the peak memory of `import --format spectra-csv` on a 1 GB spectra file (0.1 GB
    /// with --quick), into the BENCHMARKS.json already there
    #[arg(long, conflicts_with_all = ["no_device", "markdown_only", "spectrum_only"])]
    pub import_memory_only: bool,
    /// Only the firmware's footprint (the device types' sizes, the product images' flash, RAM
    /// and stack, the Ed25519 verifier table from verify-only images, and the STM32F405
    /// board's figures, `cargo xtask board`), into the BENCHMARKS.json already there
    #[arg(long, conflicts_with_all = ["quick", "no_device", "markdown_only", "spectrum_only", "import_memory_only"])]
    pub footprint_only: bool,
    /// Only the hold-out band coverage of `array-8` and `strain-pair` over the coverage
    /// seeds (their records simulated when missing), into the BENCHMARKS.json already there
    #[arg(long, conflicts_with_all = ["quick", "no_device", "markdown_only", "spectrum_only", "import_memory_only", "footprint_only"])]
    pub installations_only: bool,
}

/// `cargo xtask bench`.
pub fn run_bench(root: &Path, opts: &Opts) -> Result<()> {
    if opts.markdown_only {
        return markdown_only(root);
    }
    // One part alone, into the BENCHMARKS.json already there.
    if opts.spectrum_only {
        return spectrum::only(root, opts);
    }
    if opts.import_memory_only {
        return memory::import_only(root, opts);
    }
    if opts.footprint_only {
        return device::footprint_only(root);
    }
    if opts.installations_only {
        return installations::only(root);
    }
    let r = Runner { root: root.to_path_buf() };
    let data_dir = root.join("target/bench/data");
    fs::create_dir_all(&data_dir)?;
    let t0 = std::time::Instant::now();
    let load_start = machine::loadavg();

    step("bench: device (QEMU)");
    let device = device::part(root, opts);

    step("bench: release build of the trainer");
    build_trainer(root)?;

    step("bench: scikit-learn peer environment");
    let peer_env = runner::python_env(root, &r);
    if let Err(e) = &peer_env {
        eprintln!("bench: scikit-learn peer skipped: {e:#}");
    }
    let peer_ok = peer_env.is_ok();

    step("bench: datasets");
    let datasets = simulate_datasets(root, &r)?;

    step("bench: host inference throughput (criterion)");
    let inference_host = inference::part(root, opts)?;

    step("bench: host training, ours and the scikit-learn peer");
    let training = training::part(root, &r, opts, peer_ok)?;

    step("bench: accuracy peers and band coverage");
    let accuracy = accuracy::part(root, &r, peer_ok)?;

    step("bench: hold-out band coverage of the other installations (`array-8`, `strain-pair`)");
    let installations = installations::part(root, &r)?;

    step("bench: static fidelity and pace study (train + evaluate --quick), `paper` and `field`");
    let (pace_paper, field) = pace::part(root, &r)?;

    step("bench: peak detection in spectra (criterion, bench-spectrum, demo --spectra)");
    let spectrum = spectrum::part(root, &r, opts)?;

    step("bench: fleet scaling");
    let fleet = fleet::part(root, &r, opts)?;

    step("bench: peak memory of train, compensate, evaluate on 1e6 and 1e7 rows");
    let memory = memory::part(root, &r, opts)?;

    step("bench: the Python package against the scikit-learn peer and the CLI");
    let python =
        python::part(root).map_err(|e| eprintln!("bench: the Python package's part failed: {e:#}")).ok().flatten();

    let load_end = machine::loadavg();
    let report = Report {
        generated_by: "cargo xtask bench".into(),
        quick: opts.quick,
        wall_seconds: t0.elapsed().as_secs_f64(),
        machine: machine::machine(root, peer_env.as_ref().ok(), peer_env.as_ref().err(), load_start, load_end),
        datasets,
        training,
        inference_host,
        accuracy,
        fleet,
        memory: Some(memory),
        device: match &device {
            Ok(v) => Device::Measured(Box::new(v.clone())),
            Err(e) => Device::Failed { error: format!("{e:#}") },
        },
        pace_paper: Some(pace_paper),
        spectrum: Some(spectrum),
        field: Some(field),
        installations: Some(installations),
        slurm: runner::read_json::<Report>(&root.join("BENCHMARKS.json")).ok().and_then(|old| old.slurm),
        python,
    };
    write(root, &report)?;
    eprintln!("bench: wrote BENCHMARKS.md and BENCHMARKS.json in {:.0} s", t0.elapsed().as_secs_f64());
    device.map(|_| ())
}

/// The datasets every part reads: the three sizes of the training study, the `paper`, `field`,
/// `array-8` and `strain-pair` presets for every coverage seed and `harsh` for seed 7. The commands that made them.
fn simulate_datasets(root: &Path, r: &Runner) -> Result<Vec<String>> {
    let data_dir = root.join("target/bench/data");
    let mut cmds = Vec::new();
    for (n, dt) in SIZES {
        let toml = data_dir.join(format!("n{n}.toml"));
        fs::write(&toml, format!("# {n} samples over the 14 days of the paper clock\n[clock]\ndt_s = {dt}\n"))?;
        cmds.push(r.simulate(&["--config", &rel(&toml, root), "--seed", "7", "--json", "--out", &data(n)])?);
    }
    for preset in ["paper", "harsh", "field", installations::PRESETS[0], installations::PRESETS[1]] {
        let seeds: &[u64] = if preset == "harsh" { &[7] } else { &COVERAGE_SEEDS };
        for &seed in seeds {
            let (seed, csv) = (seed.to_string(), preset_csv(preset, seed));
            cmds.push(r.simulate(&["--preset", preset, "--seed", &seed, "--json", "--out", &csv])?);
        }
    }
    Ok(cmds)
}

/// Put the figures of `cargo xtask slurm` into BENCHMARKS.json and render BENCHMARKS.md again.
pub fn record_slurm(root: &Path, figures: serde_json::Value) -> Result<()> {
    update(root, |r| {
        r.slurm = Some(figures);
        Ok(())
    })
}

/// `cargo xtask bench --markdown-only`: BENCHMARKS.md again from BENCHMARKS.json, measuring
/// nothing (after a change to the markdown writer).
fn markdown_only(root: &Path) -> Result<()> {
    let report: Report = runner::read_json(&root.join("BENCHMARKS.json"))?;
    write_atomic(&root.join("BENCHMARKS.md"), markdown::markdown(&report).as_bytes())?;
    eprintln!("bench: wrote BENCHMARKS.md from BENCHMARKS.json");
    Ok(())
}

/// One part measured alone: BENCHMARKS.json read, changed by `f`, written back with
/// BENCHMARKS.md rendered from it (the rest of the file kept as it was).
pub fn update(root: &Path, f: impl FnOnce(&mut Report) -> Result<()>) -> Result<()> {
    let mut report: Report = runner::read_json(&root.join("BENCHMARKS.json"))?;
    f(&mut report)?;
    write(root, &report)
}

/// BENCHMARKS.json and BENCHMARKS.md from `report`.
fn write(root: &Path, report: &Report) -> Result<()> {
    // Through a `Value`, whose maps are sorted: the keys come out in alphabetical order.
    let json = serde_json::to_string_pretty(&serde_json::to_value(report)?)?;
    write_atomic(&root.join("BENCHMARKS.json"), json.as_bytes())?;
    write_atomic(&root.join("BENCHMARKS.md"), markdown::markdown(report).as_bytes())
}

/// The release build of the trainer every part runs.
pub fn build_trainer(root: &Path) -> Result<()> {
    run(cargo().current_dir(root).args(["build", "--release", "--locked", "-p", "fbg-trainer"]))
}

fn data(n: usize) -> String {
    format!("target/bench/data/n{n}.csv")
}

/// The interrogator's stated stability every bench `train` is given (`--drift-spec`, pm/√day):
/// the presets simulate one interrogator, whose drift is a walk of 0.05 pm per one-minute step
/// (DESIGN §3), 0.05 · √1440 ≈ 1.9 pm/√day, as its datasheet would state it.
pub const DRIFT_SPEC_PM_PER_SQRT_DAY: &str = "1.9";

/// The interrogator's statement every bench `train` and `bench-fit` is given for the simulated
/// record `csv`: [`DRIFT_SPEC_PM_PER_SQRT_DAY`] and, from the record's `.meta.json`, the
/// drift's gain per channel (`--drift-gains`; the simulated interrogator's channels walk by
/// different gains, as a datasheet's per-channel stability would state).
fn drift_statement(root: &Path, csv: &str) -> Result<Vec<String>> {
    let meta: runner::SimMeta = runner::read_json(&root.join(csv.replace(".csv", ".meta.json")))?;
    let mut args = vec!["--drift-spec".to_string(), DRIFT_SPEC_PM_PER_SQRT_DAY.to_string()];
    if let Some(s) = meta.scenario {
        let gains: Vec<String> = s.drift.channel_gain.iter().map(f64::to_string).collect();
        args.extend(["--drift-gains".to_string(), gains.join(",")]);
    }
    Ok(args)
}

/// `bench-fit --select` on the coverage run of `preset` and `seed`, writing Model-H's hold-out
/// errors for the ensemble band.
fn coverage_run(root: &Path, r: &Runner, preset: &str, seed: u64) -> Result<(fbg_report::FitBench, String)> {
    let csv = preset_csv(preset, seed);
    let errs = holdout_errors_csv(preset, seed);
    let mut args: Vec<String> =
        ["bench-fit", "--data", &csv, "--select", "--repeats", "1", "--json", "--holdout-errors", &errs]
            .map(String::from)
            .to_vec();
    args.extend(drift_statement(root, &csv)?);
    r.trainer(&args)
}

fn preset_csv(preset: &str, seed: u64) -> String {
    format!("target/bench/data/{preset}-s{seed}.csv")
}

/// Model-H's per-sample hold-out errors and bands of one coverage run (`bench-fit --holdout-errors`).
fn holdout_errors_csv(preset: &str, seed: u64) -> String {
    format!("target/bench/holdout/{preset}-s{seed}.csv")
}

fn rel(p: &Path, root: &Path) -> String {
    p.strip_prefix(root).unwrap_or(p).display().to_string()
}
