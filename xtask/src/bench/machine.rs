//! The machine a bench ran on: CPU, OS, toolchains, the peer's versions, the commit, the load.

use std::fs;
use std::path::Path;
use std::process::Command;

use super::report::{Git, Machine};
use super::runner::PeerVersions;

pub fn loadavg() -> String {
    fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default()
}

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

pub fn machine(
    root: &Path,
    peer: Option<&PeerVersions>,
    peer_err: Option<&anyhow::Error>,
    load_start: String,
    load_end: String,
) -> Machine {
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
    let memory = fs::read_to_string("/proc/meminfo").ok().and_then(|s| {
        s.lines().next().map(|l| {
            l.split_whitespace()
                .nth(1)
                .and_then(|k| k.parse::<f64>().ok())
                .map(|k| format!("{:.1} GiB", k / 1048576.0))
                .unwrap_or_default()
        })
    });
    Machine {
        cpu,
        cores: std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        memory,
        os: format!("{os}, kernel {}", first_line("uname", &["-r"])),
        rustc,
        qemu: first_line("qemu-system-arm", &["--version"]),
        python: peer.and_then(|p| p.python.clone()),
        numpy: peer.and_then(|p| p.numpy.clone()),
        scikit_learn: peer.and_then(|p| p.scikit_learn.clone()),
        peer_skipped_because: peer_err.map(|e| format!("{e:#}")),
        git: git_state(root),
        loadavg_start: load_start,
        loadavg_end: load_end,
    }
}

/// The commit benchmarked, and the files that differed from it (others may be editing the
/// same tree: the device part builds the firmware as it is on disk).
fn git_state(root: &Path) -> Git {
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
    let modified_files: Vec<String> = out(&["status", "--porcelain", "--untracked-files=no"])
        .lines()
        .map(|l| l.get(3..).unwrap_or(l).to_string())
        .collect();
    Git { commit: out(&["rev-parse", "--short", "HEAD"]), modified_files }
}
