//! Running commands and writing files: the workspace's paths, `cargo` for either workspace, a
//! command echoed and checked, step banners and their timing table, content hashes for stamps,
//! atomic writes.

use std::fs;
use std::hash::{DefaultHasher, Hasher};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;
use std::thread::ThreadId;
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

/// `c` (a `cargo` command) with clippy as the compiler of its workspace's own crates, warnings
/// denied: what it builds is linted as `cargo clippy -- -D warnings` would lint it, and compiled
/// too, so that `cargo xtask test` checks the host crates once instead of a `clippy` pass beside
/// the build. Cargo keeps the wrapper in its fingerprints: a build of the same crates without it
/// compiles them again, so every build of `cargo xtask test` in the host target directory goes
/// through here (the tests, their run, xtask's own tests, the Python wheel).
pub fn with_clippy(mut c: Command) -> Command {
    c.envs(clippy_env());
    c
}

/// The environment of [`with_clippy`], for a build that cargo runs under another program
/// (the wheel's, under pip and maturin).
pub fn clippy_env() -> [(&'static str, std::ffi::OsString); 2] {
    // clippy-driver sits beside the toolchain's cargo (rustup's proxy of it on PATH otherwise).
    let beside = std::env::var_os("CARGO").map(PathBuf::from).map(|p| p.with_file_name("clippy-driver"));
    let driver = beside.filter(|p| p.exists()).unwrap_or_else(|| PathBuf::from("clippy-driver"));
    // The arguments `cargo clippy -- -D warnings` hands the driver, in its own encoding.
    [
        ("RUSTC_WORKSPACE_WRAPPER", driver.into_os_string()),
        ("CLIPPY_ARGS", "-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__".into()),
    ]
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

/// A banner before each step of a task. It also ends the step this thread ran before and
/// starts timing this one under the banner's head (the text before ` (`), for
/// [`print_timings`]. A step on another thread than the main one runs beside others, within
/// the main thread's step: its row is indented and not added to the total.
pub fn step(what: &str) {
    eprintln!("\nxtask: ==== {what} ====");
    let mut t = TIMINGS.lock().unwrap_or_else(|e| e.into_inner());
    let thread = std::thread::current();
    t.close(thread.id());
    let at = t.done.len();
    let beside = thread.name() != Some("main");
    t.open.push(Open {
        thread: thread.id(),
        name: what.split(" (").next().unwrap_or(what).to_string(),
        start: Instant::now(),
        at,
        beside,
    });
}

/// End the step this thread runs (a thread's last step, before the thread ends).
pub fn end_step() {
    TIMINGS.lock().unwrap_or_else(|e| e.into_inner()).close(std::thread::current().id());
}

/// One line of the timing table.
struct Row {
    name: String,
    time: Duration,
    beside: bool,
}

/// A step running on `thread`; a main-thread step's row goes to `at` (before the steps that
/// ran beside it), another's where it ends.
struct Open {
    thread: ThreadId,
    name: String,
    start: Instant,
    at: usize,
    beside: bool,
}

/// The steps ended, and those running.
struct Timings {
    done: Vec<Row>,
    open: Vec<Open>,
}

impl Timings {
    fn close(&mut self, thread: ThreadId) {
        while let Some(i) = self.open.iter().position(|o| o.thread == thread) {
            let o = self.open.remove(i);
            let row = Row { name: o.name, time: o.start.elapsed(), beside: o.beside };
            if o.beside {
                self.done.push(row);
            } else {
                self.done.insert(o.at.min(self.done.len()), row);
            }
        }
    }
}

static TIMINGS: Mutex<Timings> = Mutex::new(Timings { done: Vec::new(), open: Vec::new() });

/// End the running step and print every step's wall time (nothing when no step ran), so that
/// a slow step shows in every run's log, a failed run's too.
pub fn print_timings() {
    let mut t = TIMINGS.lock().unwrap_or_else(|e| e.into_inner());
    while let Some(o) = t.open.first() {
        let thread = o.thread;
        t.close(thread);
    }
    if t.done.is_empty() {
        return;
    }
    let width = t.done.iter().map(|r| r.name.chars().count() + 2).max().unwrap_or(0);
    let total: Duration = t.done.iter().filter(|r| !r.beside).map(|r| r.time).sum();
    eprintln!("\nxtask: step times (wall clock; indented: ran beside each other within the step above)");
    for r in &t.done {
        let name = if r.beside { format!("  {}", r.name) } else { r.name.clone() };
        eprintln!("  {name:<width$}  {:>7.1} s", r.time.as_secs_f64());
    }
    eprintln!("  {:<width$}  {:>7.1} s", "total", total.as_secs_f64());
}

/// Write `bytes` to `path` through a temporary file and a rename (no half-written output).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension(format!("{}.tmp", path.extension().and_then(|e| e.to_str()).unwrap_or("")));
    fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
}

/// A hash of the contents of `paths` (files, and every file under a directory, in path order,
/// skipping `target/` and Python caches), with their paths: a stamp that changes when a file's
/// content does, not when only its time does. `DefaultHasher`'s keys are fixed, so the hash is
/// stable for a toolchain; another toolchain at worst redoes the work once.
pub fn content_hash(paths: &[PathBuf]) -> Result<u64> {
    fn add(h: &mut DefaultHasher, path: &Path) -> Result<()> {
        if path.is_dir() {
            let mut entries = fs::read_dir(path)
                .with_context(|| format!("reading {}", path.display()))?
                .map(|e| e.map(|e| e.path()))
                .collect::<std::io::Result<Vec<_>>>()?;
            entries.sort();
            for e in entries {
                let name = e.file_name().and_then(|n| n.to_str()).unwrap_or_default();
                if !matches!(name, "target" | "__pycache__" | ".pytest_cache") {
                    add(h, &e)?;
                }
            }
        } else {
            h.write(path.as_os_str().as_encoded_bytes());
            h.write(&fs::read(path).with_context(|| format!("reading {}", path.display()))?);
        }
        Ok(())
    }
    let mut h = DefaultHasher::new();
    for p in paths {
        add(&mut h, p)?;
    }
    Ok(h.finish())
}

/// Run `a` and `b` on two threads at once (the `what` lanes: "QEMU", "lint"); both run to their
/// end, and a failure of either is the result (both, when both fail).
pub fn in_lanes(
    what: &str,
    a: impl FnOnce() -> Result<()> + Send,
    b: impl FnOnce() -> Result<()> + Send,
) -> Result<()> {
    let (ra, rb) = std::thread::scope(|s| {
        let ha = s.spawn(|| {
            let r = a();
            end_step();
            r
        });
        let hb = s.spawn(|| {
            let r = b();
            end_step();
            r
        });
        let join = |h: std::thread::ScopedJoinHandle<'_, Result<()>>| {
            h.join().unwrap_or_else(|_| Err(anyhow::anyhow!("a {what} lane panicked")))
        };
        (join(ha), join(hb))
    });
    match (ra, rb) {
        (Err(a), Err(b)) => anyhow::bail!("two {what} lanes failed:\n{a:#}\n{b:#}"),
        (r, Ok(())) | (Ok(()), r) => r,
    }
}
