//! A closed stdout ends a command quietly: `fbg-trainer inspect m.fbgm | head -1` exits 0 or by
//! SIGPIPE (141 in the shell), never with a panic.
#![cfg(unix)]

use crate::common;
use std::os::unix::process::ExitStatusExt;
use std::process::Command;

use common::{bin, short_csv, train_small as train};

/// Run `cmd` with stdout a pipe whose reading end is closed before it starts, so its first
/// write fails for certain; assert it ended quietly.
fn with_closed_stdout(cmd: &mut Command, what: &str) {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let o = cmd.stdout(writer).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked") && !err.contains("Broken pipe"), "{what}: {err}");
    assert!(
        o.status.code() == Some(0) || o.status.signal() == Some(libc::SIGPIPE),
        "{what}: ended with {:?}: {err}",
        o.status
    );
}

#[test]
fn inspect_compensate_and_evaluate_into_a_closed_pipe_end_quietly() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = train(d.path(), &csv);
    with_closed_stdout(bin().arg("inspect").arg(&model), "inspect");
    with_closed_stdout(bin().arg("inspect").arg("--json").arg(&model), "inspect --json");
    with_closed_stdout(
        bin()
            .args(["compensate", "--json", "--model"])
            .arg(&model)
            .arg("--data")
            .arg(&csv)
            .arg("--out")
            .arg(d.path().join("c.csv")),
        "compensate --json",
    );
    // The command's files are written before it prints: the closed pipe loses only the print.
    assert!(d.path().join("c.csv").is_file());
    with_closed_stdout(bin().args(["evaluate", "--quick", "--model"]).arg(&model).arg("--data").arg(&csv), "evaluate");
    with_closed_stdout(
        bin().args(["evaluate", "--quick", "--json", "--model"]).arg(&model).arg("--data").arg(&csv),
        "evaluate --json",
    );
}
