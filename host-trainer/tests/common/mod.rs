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
/// child (`wait4`, so other children of the test process do not count).
#[cfg(target_os = "linux")]
#[allow(clippy::zombie_processes)] // reaped by `wait4`, which `Child::wait` cannot replace
pub fn run_peak_rss(cmd: &mut Command) -> (bool, String, u64) {
    let err = tempfile::NamedTempFile::new().unwrap();
    let child = cmd
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::from(err.reopen().unwrap()))
        .spawn()
        .unwrap();
    let mut status = 0;
    // SAFETY: `rusage` is plain data; `wait4` fills it for our own child.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut ru) };
    assert_eq!(pid, child.id() as libc::pid_t);
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    (ok, std::fs::read_to_string(err.path()).unwrap(), ru.ru_maxrss as u64 * 1024)
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
