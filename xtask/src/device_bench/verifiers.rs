//! The choice of the Ed25519 verifier, measured: verify-only images of each candidate crate
//! (`firmware/verifiers/`, crate `fbg-firmware-verifiers`, one `v-*` feature per build), each
//! run under `qemu-system-arm -icount shift=0` on the mps2-an386. An image runs the RFC 8032
//! test vectors (TEST 1, 2, 3, SHA(abc); each must verify, and be refused with a bit of its
//! signature flipped, a byte more of message and `S + L`), then times one verification of the
//! bench's signed model (SysTick ticks calibrated to instructions by a loop of known length)
//! with the stack it reached. Flash is the image's (vector table, code, read-only data) less the
//! image built without a `v-*` feature, the same harness without a verifier.

use std::fs;
use std::path::Path;
use std::time::Duration;

use anyhow::{bail, ensure, Context, Result};
use serde::{Deserialize, Serialize};

use crate::cmd::{cargo_own_target, run, step};
use crate::elf;
use crate::firmware::emulator::{out_dir, Qemu};
use crate::firmware::{self, release_dir};
use crate::targets::PRODUCT_K;

/// The candidates: (feature, crate as the table names it, its build options).
const CANDIDATES: [(&str, &str, &str); 4] = [
    (
        "v-salty",
        "salty 0.3 (vendored, panic paths written out)",
        "default-features = false; Cortex-M4 assembly field arithmetic",
    ),
    ("v-compact", "ed25519-compact 2.6", "default-features = false"),
    ("v-compact-size", "ed25519-compact 2.6", "default-features = false, features = [\"opt_size\"]"),
    (
        "v-dalek",
        "ed25519-dalek 2.2",
        "default-features = false (no precomputed tables; curve25519-dalek's 32-bit serial backend)",
    ),
];

/// One verifier, measured (`verifiers` in device.json).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct VerifierRow {
    /// The crate and version.
    pub verifier: String,
    /// How it is built.
    pub options: String,
    /// Flash of the verify-only image less that of the same image without a verifier \[B\].
    pub flash_bytes: u64,
    /// Stack the verification reached, above the harness's own \[B\].
    pub stack_bytes: u32,
    /// Instructions of one verification of the signed model (`signed_model_bytes`).
    pub instructions: u64,
    /// Bytes of the signed model verified (message and signature).
    pub signed_model_bytes: u64,
    /// RFC 8032 vectors that passed on the device (each with its three refusals), of 4.
    pub rfc8032_vectors_passed: u32,
    /// Whether this is the product's verifier.
    pub in_product: bool,
}

/// What one verify-only image printed.
struct Output {
    insns_per_tick: f64,
    passed: u32,
    failed: u32,
    ticks: f64,
    bytes: u64,
    stack: u32,
}

fn kv(line: &str, key: &str) -> Result<f64> {
    line.split_whitespace()
        .filter_map(|w| w.split_once('='))
        .find(|(k, _)| *k == key)
        .with_context(|| format!("verifier output lacks `{key}`: {line}"))?
        .1
        .parse::<f64>()
        .with_context(|| format!("verifier `{key}` in {line}"))
}

fn parse(text: &str) -> Result<Output> {
    let mut o = Output { insns_per_tick: 0.0, passed: 0, failed: 0, ticks: 0.0, bytes: 0, stack: 0 };
    let mut done = false;
    for line in text.lines() {
        if line.starts_with("calib ") {
            let ticks = kv(line, "ticks")?;
            ensure!(ticks > 0.0, "SysTick did not count during calibration (is -icount on?)");
            o.insns_per_tick = kv(line, "insns")? / ticks;
        } else if line.starts_with("vector ") {
            let all = ["verifies", "flipped_refused", "longer_refused", "s_plus_l_refused"]
                .iter()
                .map(|k| kv(line, k))
                .collect::<Result<Vec<_>>>()?;
            if all.iter().all(|&v| v == 1.0) {
                o.passed += 1;
            }
        } else if line.starts_with("verify ") {
            o.ticks = kv(line, "ticks")?;
            o.bytes = kv(line, "bytes")? as u64;
            o.stack = (kv(line, "stack_peak")? - kv(line, "stack_before")?).max(0.0) as u32;
            ensure!(kv(line, "ok")? == 1.0 || text.contains("name=none"), "the timed verification failed: {line}");
        } else if line.starts_with("done ") {
            o.failed = kv(line, "failed")? as u32;
            done = true;
        }
    }
    ensure!(done, "the verifier image did not finish; output:\n{text}");
    Ok(o)
}

/// Build the verify-only image with `feature` (`""`: without a verifier) and keep it as
/// `target/bench/verifiers/<feature>`.
fn build(root: &Path, feature: &str) -> Result<std::path::PathBuf> {
    let mut c = cargo_own_target();
    c.current_dir(firmware::dir(root)).args(["build", "--release", "--locked", "-p", "fbg-firmware-verifiers"]);
    if !feature.is_empty() {
        c.args(["--features", feature]);
    }
    run(c.envs(firmware::build_env(root, PRODUCT_K, None)))?;
    let feature = if feature.is_empty() { "v-none" } else { feature };
    let dir = root.join("target/bench/verifiers");
    fs::create_dir_all(&dir)?;
    let to = dir.join(feature);
    fs::copy(release_dir(root).join("verifier"), &to).with_context(|| format!("copying the {feature} image"))?;
    Ok(to)
}

fn run_image(root: &Path, q: &Path, elf: &Path, feature: &str) -> Result<Output> {
    let dir = out_dir(root)?;
    let uart = dir.join(format!("verifier-{feature}.txt"));
    let _ = fs::remove_file(&uart);
    let mut qemu = Qemu::start(
        q,
        elf,
        &format!("file:{}", uart.display()),
        &dir.join(format!("verifier-{feature}.defmt")),
        &["-icount", "shift=0"],
    )?;
    let st = qemu.wait(Duration::from_secs(300))?;
    let text = fs::read_to_string(&uart).unwrap_or_default();
    let out = parse(&text)?;
    if !st.success() {
        qemu.show_log();
        bail!("the {feature} verifier image failed ({st}); output:\n{text}");
    }
    Ok(out)
}

/// Build and run every candidate; the RFC 8032 vectors must all pass on each.
pub fn measure(root: &Path, q: &Path) -> Result<Vec<VerifierRow>> {
    step("bench: Ed25519 verifiers, verify-only images (RFC 8032 vectors, flash, stack, instructions)");
    // The fixture the images time (the bench's signed model).
    let fx = crate::fixtures::ensure(root)?;
    crate::signing::bench_signed(root, &fx)?;
    let baseline = elf::footprint(&build(root, "")?)?.flash;
    let mut rows = Vec::new();
    for (feature, name, options) in CANDIDATES {
        let image = build(root, feature)?;
        let flash = elf::footprint(&image)?.flash;
        let o = run_image(root, q, &image, feature)?;
        ensure!(
            o.failed == 0 && o.passed == 4,
            "{name} ({options}): {} of 4 RFC 8032 vectors passed on the device",
            o.passed
        );
        rows.push(VerifierRow {
            verifier: name.to_string(),
            options: options.to_string(),
            flash_bytes: flash.saturating_sub(baseline),
            stack_bytes: o.stack,
            instructions: (o.ticks * o.insns_per_tick).round() as u64,
            signed_model_bytes: o.bytes,
            rfc8032_vectors_passed: o.passed,
            in_product: feature == "v-salty",
        });
    }
    print(&rows);
    Ok(rows)
}

/// The table on stdout.
pub fn print(rows: &[VerifierRow]) {
    println!(
        "Ed25519 verifiers (verify-only images on QEMU mps2-an386 -icount shift=0; RFC 8032 vectors on the device):"
    );
    for r in rows {
        println!(
            "  {:<48} {:<70} flash {:>6} B, stack {:>5} B, {:>8} instructions ({} B signed model), RFC 8032 {}/4{}",
            r.verifier,
            r.options,
            r.flash_bytes,
            r.stack_bytes,
            r.instructions,
            r.signed_model_bytes,
            r.rfc8032_vectors_passed,
            if r.in_product { "  (the product's)" } else { "" }
        );
    }
}
