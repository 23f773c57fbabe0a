//! `cargo xtask lint` (also the first step of `cargo xtask test`), step by step ([`Step`];
//! `--only STEP` runs some): formatting, clippy on every crate and target of the host
//! workspace, the firmware workspace's clippy (the thumb image and the device logic's host
//! tests), the feature matrix of `fbg-shared`, rustdoc, the MSRV, the fuzz target, the deploy
//! files, the source sizes and the Python wheel's reuse of the test build ([`wheel`]).
//!
//! The MSRV is checked from both sides ([`msrv`]):
//! - *dependencies*: every package's declared `rust-version` is at least the largest
//!   `rust-version` in its locked dependency closure (`cargo metadata --locked`), and no larger
//!   than the toolchain in use;
//! - *our code*: clippy's `incompatible_msrv` lint (on by default, denied here with every other
//!   warning) reads the same `rust-version` and rejects standard-library items stabilised later;
//!
//! and built with the MSRV toolchain when it is installed. CI has one toolchain and reaches no
//! toolchain server, so there the build is skipped, and the output says so.

use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result};
use clap::ValueEnum;

use crate::cmd::{cargo, cargo_own_target, host_triple, run, step};
use crate::firmware;
use crate::targets::{PRODUCT_K, THUMB};

mod fuzz;
mod msrv;
pub mod sizes;
mod wheel;

/// One step of `cargo xtask lint`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Step {
    /// rustfmt --check of the three workspaces and the fuzz target
    Fmt,
    /// clippy on every crate and target of the host workspace, warnings denied
    Clippy,
    /// clippy of the firmware workspace: the thumb image and the device logic's host tests
    Firmware,
    /// fbg-shared with no feature, each of verify, key-id, defmt alone and all together, on the
    /// thumb target (clippy, warnings denied)
    Features,
    /// rustdoc of the host workspace, warnings denied
    Doc,
    /// declared rust-version against the locked dependencies and the toolchain; built with the
    /// MSRV toolchain when installed
    Msrv,
    /// the fuzz target of fbg-shared: corpus replayed, built with coverage, run for a bounded
    /// number of inputs
    Fuzz,
    /// Slurm job script syntax, Kubernetes Job against the API schema
    Deploy,
    /// no source file over 800 lines, no function over 120 lines outside tests
    Sizes,
    /// the Python wheel's build needs no unit of fbg-trainer that the test build does not make
    Wheel,
}

impl Step {
    /// Every step, in the order `lint` runs them.
    pub const ALL: [Step; 10] = [
        Step::Fmt,
        Step::Clippy,
        Step::Firmware,
        Step::Features,
        Step::Doc,
        Step::Msrv,
        Step::Fuzz,
        Step::Deploy,
        Step::Sizes,
        Step::Wheel,
    ];
}

/// The lint steps `only` names (every step when empty), in their order, one after another:
/// in two lanes at once they took as long on two cores (docs/testing.md).
pub fn run_steps(root: &Path, only: &[Step]) -> Result<()> {
    Step::ALL.into_iter().filter(|s| only.is_empty() || only.contains(s)).try_for_each(|s| run_step(root, s))
}

fn run_step(root: &Path, s: Step) -> Result<()> {
    match s {
        Step::Fmt => fmt(root),
        Step::Clippy => clippy(root),
        Step::Firmware => firmware_clippy(root, true, true),
        Step::Features => features(root),
        Step::Doc => doc(root),
        Step::Msrv => {
            step("lint: MSRV (declared rust-version against the locked dependencies and the toolchain; its build)");
            msrv::check(root)
        }
        Step::Fuzz => fuzz::check(root),
        Step::Deploy => {
            step("lint: deploy files (Slurm job script syntax, Kubernetes Job against the API schema)");
            deploy_files(root)
        }
        Step::Sizes => {
            step("lint: source sizes (files ≤ 800 lines, functions outside tests ≤ 120 lines)");
            sizes::check(root)
        }
        Step::Wheel => wheel::check(root),
    }
}

/// The lint part of `cargo xtask test`: every step but the host workspace's clippy, which the
/// test build does as it compiles (`cmd::with_clippy`).
/// Likewise the firmware step leaves out the device logic's host clippy, which its host tests'
/// build does (`qemu::app_tests`).
pub fn run_for_tests(root: &Path) -> Result<()> {
    Step::ALL.into_iter().filter(|s| *s != Step::Clippy).try_for_each(|s| match s {
        Step::Firmware => firmware_clippy(root, true, false),
        s => run_step(root, s),
    })
}

/// The lint part of the fast tier (`cargo xtask test --fast`): formatting and clippy of the
/// firmware image at its default features (the host crates' and the device logic's clippy are
/// their test builds').
pub fn run_fast(root: &Path) -> Result<()> {
    fmt(root)?;
    firmware_clippy(root, false, false)
}

fn fmt(root: &Path) -> Result<()> {
    step("lint: rustfmt --check (host workspace with the Python package, firmware workspace, the fuzz target)");
    run(cargo().current_dir(root).args(["fmt", "--all", "--check"]))?;
    run(cargo_own_target().current_dir(root.join("firmware")).args(["fmt", "--all", "--check"]))?;
    run(cargo_own_target().current_dir(root.join("shared/fuzz")).args(["fmt", "--all", "--check"]))
}

fn clippy(root: &Path) -> Result<()> {
    step("lint: clippy (every crate and target of the host workspace, the Python package's included, warnings denied)");
    run(cargo().current_dir(root).args(["clippy", "--workspace", "--all-targets", "--locked", "--", "-D", "warnings"]))
}

/// The firmware workspace: the images for the thumb target (with the environment of the
/// product build, so that neither rebuilds the other's build script) and every target of the
/// device logic (`fbg-firmware-app`, whose tests run on the host; when `host`); when
/// `variants`, also the images with spectrum frames and the device logic without them.
fn firmware_clippy(root: &Path, variants: bool, host: bool) -> Result<()> {
    step(if host {
        "lint: clippy of the firmware workspace (thumb image; device logic with its host tests), warnings denied"
    } else {
        "lint: clippy of the firmware workspace (thumb image; the device logic's host tests build with clippy later), warnings denied"
    });
    let fw = firmware::dir(root);
    run(cargo_own_target()
        .current_dir(&fw)
        .args(["clippy", "--workspace", "--release", "--locked", "--", "-D", "warnings"])
        .envs(firmware::build_env(root, PRODUCT_K, None)))?;
    if variants {
        run(cargo_own_target()
            .current_dir(&fw)
            .args(["clippy", "--release", "--locked", "--bins", "--features", "spectrum"])
            .args(["--", "-D", "warnings"])
            .envs(firmware::build_env(root, PRODUCT_K, None)))?;
    }
    if !host {
        return Ok(());
    }
    let host = host_triple()?;
    run(cargo_own_target()
        .current_dir(&fw)
        .args(["clippy", "-p", "fbg-firmware-app", "--all-targets", "--locked", "--target", &host])
        .args(["--", "-D", "warnings"]))?;
    if variants {
        // Without spectrum frames, as the default product and the board build it.
        run(cargo_own_target()
            .current_dir(&fw)
            .args(["clippy", "-p", "fbg-firmware-app", "--all-targets", "--locked", "--no-default-features"])
            .args(["--target", &host, "--", "-D", "warnings"]))?;
    }
    Ok(())
}

/// The features of `fbg-shared`, each alone, none and all, on the device target (no_std): a
/// feature that only compiles with another (which the workspace's feature unification would
/// hide) fails here. `defmt` derives `defmt::Format` as firmware that logs with defmt builds it.
/// The host needs no matrix of its own: the workspace's clippy checks it with `verify` and
/// `key-id`, and this step with none (the host side of the one target-dependent function, in
/// `real.rs`).
fn features(root: &Path) -> Result<()> {
    step("lint: fbg-shared's feature matrix (none, verify, key-id, defmt, all) on the thumb target; none on the host");
    for features in ["", "verify", "key-id", "defmt", "verify,key-id,defmt"] {
        let mut c = cargo();
        c.current_dir(root).args(["clippy", "-p", "fbg-shared", "--locked", "--no-default-features"]);
        c.args(["--target", THUMB]);
        if !features.is_empty() {
            c.args(["--features", features]);
        }
        run(c.args(["--", "-D", "warnings"]))?;
    }
    run(cargo()
        .current_dir(root)
        .args(["clippy", "-p", "fbg-shared", "--locked", "--no-default-features"])
        .args(["--", "-D", "warnings"]))
}

fn doc(root: &Path) -> Result<()> {
    step("lint: rustdoc (host workspace, warnings denied)");
    run(cargo()
        .current_dir(root)
        .args(["doc", "--workspace", "--no-deps", "--locked"])
        .env("RUSTDOCFLAGS", "-D warnings"))
}

/// The pinned offline validator of Kubernetes manifests (JSON schemas of every API version ship
/// inside the package; no cluster or network at validation time).
const KUBERNETES_VALIDATE: &str = "kubernetes-validate==1.37.0";

fn deploy_files(root: &Path) -> Result<()> {
    run(Command::new("bash").arg("-n").arg(root.join("deploy/slurm/fleet.sbatch")))?;
    let venv = root.join("target/deploy-venv");
    let tool = venv.join("bin/kubernetes-validate");
    if !tool.exists() {
        run(Command::new("python3").args(["-m", "venv"]).arg(&venv))
            .context("creating a Python venv for kubernetes-validate (needs python3 with venv)")?;
        run(Command::new(venv.join("bin/pip")).args(["install", "-q", KUBERNETES_VALIDATE]))
            .context("installing kubernetes-validate from PyPI")?;
    }
    run(Command::new(&tool)
        .args(["--strict", "--kubernetes-version", "1.33"])
        .arg(root.join("deploy/kubernetes/fleet-job.yaml")))
}
