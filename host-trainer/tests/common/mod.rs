//! What the tests share: the built binary, a run capturing its output, a child's peak resident
//! set, a short record, a small training grid, the readings of an artefact on rising and falling
//! stretches, the options of an import.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// The `fbg-trainer` binary under test.
pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
}

/// Run `cmd`: (success, stdout, stderr).
pub fn run(cmd: &mut Command) -> (bool, String, String) {
    let o = cmd.output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Run `cmd` to its end and return (success, stderr, peak resident set in bytes) of that one
/// process.
///
/// Not `wait4` on a child of this process: Linux carries the high-water mark of the address
/// space a process `exec`s from into its own peak, and `Command::spawn` execs from this test
/// process's (many tests, hundreds of MB). So this binary is started again with only
/// [`peak_rss_probe`], a small process, which runs `cmd` and reports its `wait4` figures.
#[cfg(target_os = "linux")]
pub fn run_peak_rss(cmd: &mut Command) -> (bool, String, u64) {
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let mut spec = cmd.get_program().as_bytes().to_vec();
    for a in cmd.get_args() {
        spec.push(0);
        spec.extend_from_slice(a.as_bytes());
    }
    std::fs::write(dir.path().join("cmd"), spec).unwrap();
    let mut probe = Command::new(std::env::current_exe().unwrap());
    probe
        .args(["--exact", "common::peak_rss_probe", "--nocapture", "--test-threads", "1", "-q"])
        .env(PEAK_RSS_PROBE, dir.path())
        .stdout(std::process::Stdio::null());
    for (k, v) in cmd.get_envs() {
        match v {
            Some(v) => probe.env(k, v),
            None => probe.env_remove(k),
        };
    }
    if let Some(d) = cmd.get_current_dir() {
        probe.current_dir(d);
    }
    let (ok, _, probe_err) = run(&mut probe);
    assert!(ok, "the peak-RSS probe failed: {probe_err}");
    let result = std::fs::read_to_string(dir.path().join("result")).unwrap();
    let (status, rss) = result.split_once(' ').unwrap();
    (status == "ok", std::fs::read_to_string(dir.path().join("stderr")).unwrap(), rss.parse().unwrap())
}

/// The directory through which [`run_peak_rss`] hands a command to [`peak_rss_probe`].
#[cfg(target_os = "linux")]
const PEAK_RSS_PROBE: &str = "FBG_TEST_PEAK_RSS_PROBE";

/// Not a check: when [`run_peak_rss`] starts this binary with [`PEAK_RSS_PROBE`] set, runs the
/// command written there and writes its exit ("ok"/"failed") and peak resident set in bytes;
/// otherwise does nothing.
#[cfg(target_os = "linux")]
#[test]
#[allow(clippy::zombie_processes)] // reaped by `wait4`, which `Child::wait` cannot replace
fn peak_rss_probe() {
    use std::os::unix::ffi::OsStrExt;
    let Some(dir) = std::env::var_os(PEAK_RSS_PROBE).map(PathBuf::from) else { return };
    let spec = std::fs::read(dir.join("cmd")).unwrap();
    let mut parts = spec.split(|&b| b == 0).map(std::ffi::OsStr::from_bytes);
    let child = Command::new(parts.next().unwrap())
        .args(parts)
        .stdout(std::process::Stdio::null())
        .stderr(std::fs::File::create(dir.join("stderr")).unwrap())
        .spawn()
        .unwrap();
    let mut status = 0;
    // SAFETY: `rusage` is plain data; `wait4` fills it for our own child.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut ru) };
    assert_eq!(pid, child.id() as libc::pid_t);
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    let rss = ru.ru_maxrss as u64 * 1024;
    std::fs::write(dir.join("result"), format!("{} {rss}", if ok { "ok" } else { "failed" })).unwrap();
}

/// The probe measures the command, not the process that asks: a small command reads small
/// after this process has touched 256 MB.
#[cfg(target_os = "linux")]
#[test]
fn a_peak_rss_is_the_commands_own() {
    let big = vec![1u8; 256 << 20];
    let (ok, _, rss) = run_peak_rss(bin().arg("--version"));
    assert!(ok);
    assert!(
        rss < 64 << 20,
        "peak RSS {} MB after this process touched {} MB",
        rss >> 20,
        std::hint::black_box(&big).len() >> 20
    );
}

/// A short simulated record (3 days, 4320 rows) in `dir`.
pub fn short_csv(dir: &Path) -> PathBuf {
    let cfg = dir.join("short.toml");
    std::fs::write(&cfg, "name = \"short\"\n[clock]\ndays = 3.0\n").unwrap();
    let csv = dir.join("data.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "2", "--config"]).arg(&cfg).arg("--out").arg(&csv));
    assert!(ok, "{err}");
    csv
}

/// `train` on `csv` with at most 8 centres into `dir/m.fbgm` (asserting it succeeds): a model
/// for tests of what other commands do with one.
pub fn train_small(dir: &Path, csv: &Path) -> PathBuf {
    let model = dir.join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    model
}

/// A small hyper-parameter grid for fits on short records.
pub fn small_grid() -> fbg_trainer::fit::TrainOptions {
    fbg_trainer::fit::TrainOptions::builder()
        .centres(vec![8, 16])
        .sigma_mults(vec![1.0, 2.0])
        .alpha_rels(vec![1e-5, 1e-3])
        .dead_bands_pm(vec![2.0, 4.0])
        .check()
        .unwrap()
}

/// The values of `h` at the samples that end a stretch of 10 steps over which `x` rose
/// (fell) at every step and by more than 20 in all: (rising, falling).
pub fn on_long_moves(x: &[f64], h: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let (mut up, mut down) = (vec![], vec![]);
    for i in 10..x.len() {
        let run = &x[i - 10..=i];
        if run.windows(2).all(|w| w[1] > w[0]) && x[i] - x[i - 10] > 20.0 {
            up.push(h[i]);
        }
        if run.windows(2).all(|w| w[1] < w[0]) && x[i - 10] - x[i] > 20.0 {
            down.push(h[i]);
        }
    }
    (up, down)
}

/// A dataset CSV's text without the comment lines before its header (the record's λ_ref and
/// start time): what a test that edits rows works on.
pub fn csv_body(text: &str) -> &str {
    let mut rest = text;
    while rest.starts_with('#') {
        rest = rest.split_once('\n').map_or("", |(_, r)| r);
    }
    rest
}

/// [`csv_body`] of the file at `p`.
pub fn read_csv_body(p: &Path) -> String {
    csv_body(&std::fs::read_to_string(p).unwrap()).to_string()
}

/// The options of `import --format FORMAT INPUT [--map MAP]` with every other option at its
/// default (fail on the first bad row).
pub fn import_options(
    format: fbg_trainer::data::import::Format,
    input: PathBuf,
    map: Option<PathBuf>,
) -> fbg_trainer::data::import::ImportOptions {
    use fbg_trainer::data::import::{ImportOptions, OnError, SplitChoice, DEFAULT_MAX_SKIPPED};
    ImportOptions {
        format,
        input,
        map,
        refs: None,
        split: SplitChoice::default(),
        on_error: OnError::Fail,
        max_skipped: DEFAULT_MAX_SKIPPED,
        zero_from: None,
        start_unix_s: None,
        scale: None,
    }
}
