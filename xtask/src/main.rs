//! `cargo xtask test|qemu|bench|size`: the project's task runner (matklad's xtask pattern).
//!
//! `cargo xtask test` is the README's test command and what CI runs: it installs what it needs
//! (the thumb target comes from `rust-toolchain.toml`; `qemu-system-arm` with apt-get) or stops
//! with a message that says exactly what to install.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context, Result};

mod bench;
mod device_bench;
mod elf;
mod fixtures;
mod lint;
mod qemu;
mod signing;
mod slurm;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let task = args.first().map(String::as_str).unwrap_or("help");
    let rest = args.get(1..).unwrap_or(&[]);
    // `cargo xtask <task> --help` prints the help, whatever the task takes.
    if rest.iter().any(|a| a == "--help" || a == "-h") {
        println!("{HELP}");
        return Ok(());
    }
    match task {
        "test" => test(rest),
        "lint" => lint::run_all(&root()),
        "slurm" => slurm::run_all(&root()),
        "qemu" => qemu::run_all(&root()),
        "size" => device_bench::size(&root()).map(|_| ()),
        "device-bench" => device_bench::run(&root()).map(|_| ()),
        "bench" => bench::run_bench(&root(), rest),
        "fixtures" => fixtures_task(rest),
        "help" | "--help" | "-h" => {
            println!("{HELP}");
            Ok(())
        }
        other => bail!("unknown task `{other}`\n{HELP}"),
    }
}

const HELP: &str = "\
cargo xtask <task>
  test    lint, host tests of the whole workspace (doctests included), no_std build
          of fbg-shared for thumbv7em-none-eabihf, firmware build and its QEMU tests
          (CI runs this)
  lint    rustfmt --check, clippy on every crate and target (-D warnings), rustdoc
          (-D warnings) and the MSRV check, for both workspaces
  qemu    only the firmware QEMU tests
  size    firmware flash / static RAM from the ELF and the measured stack peak
  device-bench
          only the device part of bench: instructions per step at K = 16/32/64
          and of the trained models of other presets (strain-pair, temperature-1,
          array-8) under QEMU -icount and the footprint; writes target/bench/device.json
  bench [--quick] [--no-device]
          every benchmark: host fit times (ours and the scikit-learn peer), host
          inference throughput, accuracy peers, band coverage, fleet scaling and the
          device part (instructions per step at K = 16/32/64 under QEMU -icount,
          footprint); writes BENCHMARKS.md and BENCHMARKS.json
  bench --markdown-only
          only BENCHMARKS.md, rendered again from BENCHMARKS.json (measures nothing)
  slurm   the sharded fleet on a single-node Slurm started here (installs
          slurm-wlm and munge; needs root; not part of test): a 64-group array
          job in 4 shards, one task cancelled and resubmitted, fleet status, every
          blob equal to a single-machine run; writes target/slurm/slurm.json
  fixtures [--write-default]
          make the firmware's test fixtures with fbg-trainer in target/fixtures (the
          paper preset's and, in preset-<name>/, the strain-pair, temperature-1 and
          array-8 presets' trained Model-H with golden vectors) (and copy the paper
          Model-H, seed 7, to firmware/model/default.fbgm)";

fn fixtures_task(rest: &[String]) -> Result<()> {
    let root = root();
    let fx = fixtures::ensure(&root)?;
    let dev = fixtures::ensure_device(&root)?;
    println!("{fx:#?}\n{dev:#?}");
    if rest.iter().any(|a| a == "--write-default") {
        let path = root.join("firmware/model/default.fbgm");
        fixtures::write_atomic(&path, &std::fs::read(&fx.model)?)?;
        println!("wrote {} (the trainer's Model-H, paper preset, seed 7; commit it)", path.display());
    }
    Ok(())
}

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

pub fn describe(cmd: &Command) -> String {
    let mut s = cmd.get_program().to_string_lossy().into_owned();
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s
}

pub fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// `cargo` for the firmware workspace (`firmware/`, its own `target/`): a `CARGO_TARGET_DIR`
/// meant for the host workspace (e.g. `CARGO_TARGET_DIR=/tmp/t cargo xtask qemu`) must not
/// move the firmware's build, whose images the tasks look for under `firmware/target`.
pub fn firmware_cargo() -> Command {
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

fn test(rest: &[String]) -> Result<()> {
    let root = root();
    let skip_qemu = rest.iter().any(|a| a == "--no-qemu");
    ensure_thumb_target()?;
    lint::run_all(&root)?;

    step("host tests (whole workspace, doctests included)");
    run(cargo().current_dir(&root).args(["test", "--workspace", "--release", "--locked"]))?;

    step("fbg-shared: no_std build for thumbv7em-none-eabihf, without and with its defmt feature");
    run(cargo().current_dir(&root).args([
        "build",
        "-p",
        "fbg-shared",
        "--target",
        "thumbv7em-none-eabihf",
        "--release",
        "--locked",
    ]))?;

    if skip_qemu {
        eprintln!("xtask: --no-qemu given, skipping the firmware and its QEMU tests");
    } else {
        qemu::run_all(&root)?;
    }
    eprintln!("xtask: all tests passed");
    Ok(())
}

/// Whether this process runs as root (the tasks that install packages or start daemons need it).
pub fn is_root() -> bool {
    Command::new("id").arg("-u").output().map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0").unwrap_or(false)
}

pub fn step(what: &str) {
    eprintln!("\nxtask: ==== {what} ====");
}

/// The thumb target normally arrives through `rust-toolchain.toml`; make sure it is there.
fn ensure_thumb_target() -> Result<()> {
    let out = Command::new("rustup").args(["target", "list", "--installed"]).current_dir(root()).output();
    match out {
        Ok(o) if String::from_utf8_lossy(&o.stdout).contains("thumbv7em-none-eabihf") => Ok(()),
        Ok(_) => run(Command::new("rustup").args(["target", "add", "thumbv7em-none-eabihf"]).current_dir(root()))
            .context("install the target with `rustup target add thumbv7em-none-eabihf`"),
        Err(_) => {
            eprintln!("xtask: rustup not found; assuming the thumbv7em-none-eabihf target is installed");
            Ok(())
        }
    }
}
