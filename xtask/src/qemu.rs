//! Firmware build and QEMU tests (`cargo xtask qemu`, part of `cargo xtask test`).
//!
//! 1. host unit tests of the device logic (`fbg-firmware-app`; its clippy is in `cargo xtask lint`),
//!    with and without spectrum frames, and the default model checked against the trainer's;
//! 2. fault path: an image that executes UDF must end QEMU with a failure exit code;
//! 3. golden vectors: the `golden` image compensates the fixture samples on the emulated
//!    Cortex-M4F and sends its estimates over UART0 to a file; each is compared with the host's
//!    f64 answer (|Δ| ≤ 1 % of the reference scale per channel, flags identical). The sets:
//!    the trainer's paper model on its golden samples plus edge cases; the synthetic model
//!    with every slot of the memory bank in use on an irregular clock with a gap; random
//!    models of other dims (2 → 2 without ambient, 8 → 4); and the trainer's Model-H of each
//!    other preset of `fixtures::TRAINED_PRESETS` (strain-pair, temperature-1, array-8) on its
//!    own hold-out samples plus edge cases. The scale of every trained model is its hold-out
//!    RMSE from the trainer's `golden_meta.json` (required for the presets' sets), of the
//!    synthetic ones the square root of their residual variance. The test fails when a set is
//!    missing, or the pack the image embeds does not hold exactly these sets in order;
//! 4. link: the product image serves its serial port on a loopback TCP port; `fbg-trainer
//!    stream` (the real CLI) sends the paper hold-out and checks every estimate against the
//!    host's f64 compensator; then garbage (counted, then served), a corrupted and an oversized
//!    model (rejected with their reasons; the old model still answers like the host), and
//!    `fbg-trainer stream --update-first` with a second model (accepted, and its answers match
//!    the host on the new model);
//! 5. signed updates: a model signed by the trainer with the committed QEMU test key is
//!    accepted; unsigned, signed by an unknown key, tampered after signing (one payload bit)
//!    and an older serial replayed are each refused with their reason while the running model
//!    answers bit for bit as before; the device's counters and audit fields say so, also
//!    through `fbg-trainer device status`; so are another model under the running serial (a
//!    swap) and a rollback (the default build accepts none); 1 000 `ModelBegin` frames erase
//!    the staging slot at most once (`Status::staging_erases`). Then the `rollback` image (the
//!    product with rollbacks accepted): a rollback signed to replace serial 5 is refused over
//!    serial 3, accepted over serial 5, refused when replayed over itself and after the device
//!    moved on to serial 9;
//! 6. spectrum frames: the product image built with spectrum frames (`--features spectrum`;
//!    the default product refuses them) is set up for a 512-pixel spectrometer with three
//!    gratings on two channels and sent simulated spectra (Gaussian peaks at the paper
//!    hold-out's shifts, 30 dB) in chunks through `fbg-link`; every estimate equals the host's
//!    (`fbg-shared` f32 on the same frames) bit for bit with identical flags, the peaks' RMS
//!    error against the simulated shifts is under 3 pm, and an out-of-order chunk and an
//!    overrun are refused and counted (`qemu/spectrum.rs`); the default product refuses a
//!    spectrum message as `Unsupported` and counts it;
//! 7. memory over 14 days: the product image, given a model with memory terms (the default
//!    when it has them, else the default with the full memory bank added), compensates the
//!    whole paper data set — 20 160 samples, 14 days — on an irregular clock with a 5 h gap;
//!    every answer is compared with the host's f64 (≤ 1 % of Model-H's hold-out RMSE, flags
//!    identical), and the largest difference of the last day with that of the first, so that
//!    f32 memory state drifting over a long stream would show.
//!
//! Every QEMU run has a time-out and QEMU is killed on any failure. defmt logs (QEMU's
//! semihosting stdout) are kept in `target/qemu/*.defmt` and decoded with `defmt-print` when it
//! is installed (`cargo install defmt-print --locked`; not installed by the tests because it takes

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use fbg_shared::blob::stored_crc;
use fbg_shared::protocol::{RejectReason, UpdateResult};

use crate::cmd::{cargo_own_target, host_triple, run, step};
use crate::firmware::emulator::{self, decode_log, out_dir, Machine, Qemu};
use crate::firmware::{self, Bins};
use crate::fixtures::{self, Fixtures};
use crate::signing;
use crate::targets::PRODUCT_K;

mod link;
mod memory;
mod signed;
pub(crate) mod spectrum;
mod store;

/// Build the firmware and run every QEMU test; `all`: the long forms of the store tests
/// (`cargo xtask qemu --all`); `board`: also the STM32F405 board's images and their runs on
/// `netduinoplus2` (`cargo xtask board`, as `cargo xtask test` has them).
///
/// Every image is built first; then the suites run in two lanes at once, each on a thread of
/// its own (an emulator is one busy thread, and each suite has its own devices, logs and
/// ports), balanced by their run times: the signed updates, the 14-day memory stream and the
/// link in one lane, the store and the spectrum frames (and the board's runs) in the other.
pub fn run_all(root: &Path, all: bool, board: bool) -> Result<()> {
    step("firmware: QEMU prerequisites and fixtures");
    let qemu = emulator::ensure_qemu()?;
    let fx = fixtures::ensure(root)?;
    let dfx = fixtures::ensure_device(root)?;
    let sfx = signing::ensure(root, &fx, &dfx)?;
    app_tests(root, &fx, true)?;
    check_default_model(root, &fx)?;

    step("firmware: build (thumbv7em-none-eabihf, K = 32)");
    let bins = firmware::build(root, PRODUCT_K, None)?;
    step("firmware: the product with spectrum frames (--features spectrum)");
    let spectrum_product = firmware::build_spectrum_product(root, PRODUCT_K)?;
    let board_images = if board { Some(crate::board::build_both(root)?) } else { None };
    no_core_fmt(&bins)?;

    let started = Instant::now();
    step("QEMU: the suites, in two lanes at once");
    let (q, fx, dfx, sfx, bins) = (&qemu, &fx, &dfx, &sfx, &bins);
    let lane_a = || -> Result<()> {
        step("QEMU: fault path (UDF → HardFault → semihosting exit failure)");
        fault_test(root, q, bins)?;
        step("QEMU: golden vectors");
        crate::firmware::golden::golden_test(root, q, bins, fx)?;
        step(if all {
            "QEMU: the persistent model store (power cycles, 50 power cuts during an update, 1 000 updates of wear)"
        } else {
            "QEMU: the persistent model store (power cycles, 10 of the 50 power cuts, 300 updates of wear; all with --all)"
        });
        store::store_tests(root, q, bins, fx, sfx, all)?;
        step("QEMU: spectrum frames (512 pixels, 3 gratings, in chunks) answered bit for bit as the host's f32");
        spectrum::spectrum_test(root, q, &spectrum_product, fx)?;
        spectrum::unsupported_test(root, q, &bins.product)?;
        if let Some(images) = &board_images {
            crate::board::run_images(root, q, fx, images)?;
        }
        Ok(())
    };
    let lane_b = || -> Result<()> {
        step(
            "QEMU: signed model updates (accepted; unsigned, unknown key, tampered, rollback, swap refused), staging erases and the audit trail",
        );
        signed::signed_update_test(root, q, bins, fx, sfx)?;
        step("QEMU: a bounded rollback (the `rollback` image): accepted over the serial it names only");
        signed::rollback_test(root, q, bins, sfx)?;
        step("QEMU: a memory model over the whole 14-day paper stream (f32 device vs f64 host)");
        memory::long_memory_test(root, q, bins, fx)?;
        step("QEMU: link (streaming, garbage and model updates over a loopback TCP serial port)");
        link::link_test(root, q, bins, fx, dfx, sfx)?;
        Ok(())
    };
    crate::cmd::in_lanes("QEMU", lane_a, lane_b)?;
    eprintln!("xtask: QEMU tests passed in {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// The product image links no `core::fmt` (`elf::ensure_no_core_fmt`); the bench image, which
/// formats its report with it, shows that the check finds it where it is.
pub fn no_core_fmt(bins: &Bins) -> Result<()> {
    step("firmware: no core::fmt in the product image (its symbols)");
    crate::elf::ensure_no_core_fmt(&bins.product, "the mps2 product image")?;
    ensure!(
        !crate::elf::core_fmt_symbols(&bins.bench)?.is_empty(),
        "the core::fmt check found nothing in the bench image, which formats its report with core::fmt: the check is broken"
    );
    Ok(())
}

/// The fast tier's firmware part (`cargo xtask test --fast`): the device logic's host tests as
/// the crate's default features have them, the default-model check, and the golden vectors on
/// QEMU (only the golden image is built).
pub fn run_fast(root: &Path) -> Result<()> {
    step("firmware: QEMU prerequisites and fixtures");
    let qemu = emulator::ensure_qemu()?;
    let fx = fixtures::ensure(root)?;
    app_tests(root, &fx, false)?;
    check_default_model(root, &fx)?;
    step("firmware: build the golden image (thumbv7em-none-eabihf, K = 32)");
    let elf = firmware::build_golden(root, PRODUCT_K)?;
    step("QEMU: golden vectors");
    crate::firmware::golden::run_golden(root, &qemu, Machine::Mps2An386, &elf, "golden", &fx).map(|_| ())
}

/// The host tests of the device logic (`fbg-firmware-app`) with its default features (spectrum
/// frames), and when `both`, also as the default product builds it, without them (they are
/// refused). Clippy compiles them, warnings denied (`cmd::with_clippy`): this is the device
/// logic's host clippy of `cargo xtask test`.
fn app_tests(root: &Path, fx: &Fixtures, both: bool) -> Result<()> {
    step("firmware: host tests of the device logic (fbg-firmware-app; compiled with clippy)");
    let fw = firmware::dir(root);
    let triple = host_triple()?;
    let variants: &[&[&str]] = if both { &[&[], &["--no-default-features"]] } else { &[&[]] };
    for features in variants {
        run(crate::cmd::with_clippy(cargo_own_target())
            .current_dir(&fw)
            .args(["test", "-p", "fbg-firmware-app", "--locked", "--target", &triple])
            .args(*features)
            .env("FBG_TEST_MODEL", &fx.model))?;
    }
    Ok(())
}

/// The product embeds `firmware/model/default.fbgm`, which must be exactly the trainer's
/// Model-H for the paper preset, seed 7 (`target/fixtures/model.fbgm`, made just now by the
/// current trainer): it can never go stale.
pub fn check_default_model(root: &Path, fx: &Fixtures) -> Result<()> {
    let path = firmware::dir(root).join("model/default.fbgm");
    let committed = fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
    let fresh = fs::read(&fx.model).with_context(|| format!("reading {}", fx.model.display()))?;
    if committed != fresh {
        let why = match fbg_shared::blob::decode::<PRODUCT_K>(&committed) {
            Err(e) => format!("it does not even decode with the current fbg-shared ({e})"),
            Ok(_) => format!(
                "it decodes, but differs from what the trainer produces now ({} vs {} bytes, crc {:#010x} vs {:#010x})",
                committed.len(),
                fresh.len(),
                stored_crc(&committed).unwrap_or(0),
                stored_crc(&fresh).unwrap_or(0)
            ),
        };
        bail!(
            "{} is stale: {why}. It must be the trainer's Model-H for the paper preset, seed 7 \
             ({}). Regenerate it with `cargo xtask fixtures --write-default` and commit it",
            path.display(),
            fx.model.display()
        );
    }
    eprintln!("xtask: firmware/model/default.fbgm is the trainer's current Model-H (paper preset, seed 7)");
    Ok(())
}

fn fault_test(root: &Path, qemu: &Path, bins: &Bins) -> Result<()> {
    let log = out_dir(root)?.join("fault.defmt");
    let mut q = Qemu::start(qemu, &bins.fault, "null", &log, &[])?;
    let status = q.wait(Duration::from_secs(30))?;
    if status.success() {
        q.show_log();
        bail!("the fault image exited with success; a HardFault must end the run with failure");
    }
    if let Some(text) = decode_log(&q.elf, &q.log) {
        ensure!(text.contains("HardFault"), "the fault image's log does not name the HardFault:\n{text}");
    }
    eprintln!("xtask: fault image ended with {status} as it must");
    Ok(())
}

/// Only the store tests (`store_tests`), after the fixtures and the firmware build:
/// `cargo test -p xtask --release -- --ignored qemu_store_tests_alone` (`FBG_QEMU_ALL=1`: the
/// long forms), for working on the store without the other QEMU tests.
#[cfg(test)]
#[test]
#[ignore = "runs QEMU for minutes; part of `cargo xtask qemu`"]
fn qemu_store_tests_alone() -> Result<()> {
    let root = crate::cmd::root();
    let qemu = emulator::ensure_qemu()?;
    let fx = fixtures::ensure(&root)?;
    let dfx = fixtures::ensure_device(&root)?;
    let sfx = signing::ensure(&root, &fx, &dfx)?;
    let bins = firmware::build(&root, PRODUCT_K, None)?;
    store::store_tests(&root, &qemu, &bins, &fx, &sfx, std::env::var_os("FBG_QEMU_ALL").is_some())
}

/// `r` is a rejection for `reason` (`what` names the update in the messages).
pub(crate) fn expect_rejected(r: UpdateResult, reason: RejectReason, what: &str) -> Result<()> {
    match r {
        UpdateResult::Rejected(rej) if rej.reason == reason => {
            eprintln!("xtask: {what}: rejected as expected: {rej}");
            Ok(())
        }
        other => bail!("{what}: expected a rejection for {reason:?}, got {other:?}"),
    }
}
