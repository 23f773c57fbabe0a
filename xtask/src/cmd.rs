//! Running commands and writing files: the workspace's paths, `cargo` for either workspace, a
//! command echoed and checked, step banners and their timing table, atomic writes.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};

/// Workspace root (the parent of this crate's directory).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().map(Path::to_path_buf).unwrap_or_default()
}

/// Run a command, echoing it, and fail with its name if it fails.
pub fn run(cmd: &mut Command) -> Result<()> {
    eprintln!("xtask: $ {}", describe(cmd));
    let status = cmd.status().with_context(|| format!("could not start `{}`", describe(cmd)))?;
    if !status.success() {
        bail!("`{}` failed with {status}", describe(cmd));
    }
    Ok(())
}

/// The command line of `cmd`, as echoed.
pub fn describe(cmd: &Command) -> String {
    let mut s = cmd.get_program().to_string_lossy().into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}

/// The `cargo` that runs xtask.
pub fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// `cargo` for the workspaces beside the host one, each with its own `target/` (the firmware,
/// the fuzz target): a `CARGO_TARGET_DIR` meant for the host workspace (e.g.
/// `CARGO_TARGET_DIR=/tmp/t cargo xtask qemu`) must not move their builds, whose outputs the
/// tasks look for under their own `target/`.
pub fn cargo_own_target() -> Command {
    let mut c = cargo();
    c.env_remove("CARGO_TARGET_DIR");
    c
}

/// The host workspace's target directory: `CARGO_TARGET_DIR` when set (relative to the
/// workspace root, as cargo takes it), else `target/`. The trainer the fixtures run is built
/// there.
pub fn target_dir() -> PathBuf {
    match std::env::var_os("CARGO_TARGET_DIR") {
        Some(d) if !d.is_empty() => root().join(d),
        _ => root().join("target"),
    }
}

/// The host's target triple (for the device-logic unit tests and the fuzz target).
pub fn host_triple() -> Result<String> {
    let out = Command::new("rustc").arg("-vV").output().context("running `rustc -vV`")?;
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(|l| l.strip_prefix("host: "))
        .map(|s| s.trim().to_string())
        .context("`rustc -vV` printed no host triple")
}

/// Whether this process runs as root (the tasks that install packages or start daemons need it).
pub fn is_root() -> bool {
    Command::new("id").arg("-u").output().map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0").unwrap_or(false)
}

/// A banner before each step of a task. It also ends the step before and starts timing this
/// one under the banner's head (the text before ` (`), for [`print_timings`].
pub fn step(what: &str) {
    eprintln!("\nxtask: ==== {what} ====");
    let name = what.split(" (").next().unwrap_or(what);
    let mut t = TIMINGS.lock().unwrap_or_else(|e| e.into_inner());
    t.close();
    t.open = Some((name.to_string(), Instant::now()));
}

/// The steps timed so far: those ended, and the one running.
struct Timings {
    done: Vec<(String, Duration)>,
    open: Option<(String, Instant)>,
}

impl Timings {
    fn close(&mut self) {
        if let Some((name, start)) = self.open.take() {
            self.done.push((name, start.elapsed()));
        }
    }
}

static TIMINGS: Mutex<Timings> = Mutex::new(Timings { done: Vec::new(), open: None });

/// End the running step and print every step's wall time (nothing when no step ran), so that
/// a slow step shows in every run's log, a failed run's too.
pub fn print_timings() {
    let mut t = TIMINGS.lock().unwrap_or_else(|e| e.into_inner());
    t.close();
    if t.done.is_empty() {
        return;
    }
    let width = t.done.iter().map(|(n, _)| n.chars().count()).max().unwrap_or(0);
    let total: Duration = t.done.iter().map(|(_, d)| *d).sum();
    eprintln!("\nxtask: step times (wall clock)");
    for (name, d) in t.done.iter().chain([&("total".to_string(), total)]) {
        eprintln!("  {name:<width$}  {:>7.1} s", d.as_secs_f64());
    }
}

/// Write `bytes` to `path` through a temporary file and a rename (no half-written output).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension(format!("{}.tmp", path.extension().and_then(|e| e.to_str()).unwrap_or("")));
    fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
}
