//! What the CLI tests share: the built binary, a run capturing its output, a short record.
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

/// A short simulated record (3 days, 4320 rows) in `dir`.
pub fn short_csv(dir: &Path) -> PathBuf {
    let cfg = dir.join("short.toml");
    std::fs::write(&cfg, "name = \"short\"\n[clock]\ndays = 3.0\n").unwrap();
    let csv = dir.join("data.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "2", "--config"]).arg(&cfg).arg("--out").arg(&csv));
    assert!(ok, "{err}");
    csv
}
