//! `cargo xtask board`: the STM32F405 images of `firmware/board/` (crate
//! `fbg-firmware-board`).
//!
//! 1. builds both builds of the board images — for the part (`stm32f4xx-hal` clocks, the
//!    flash controller, defmt-rtt) and with the `emulator` feature (for QEMU's
//!    `netduinoplus2`: reset clocks, a RAM-backed store, defmt over semihosting) — and keeps
//!    them apart in `target/board/{part,emulator}/` (both builds link to the same file name);
//! 2. prints the part's product image footprint from its ELF: flash (vector table, code,
//!    read-only data, `.data` initialisers) and static RAM (`.data`, `.bss`, `.uninit`);
//! 3. runs the `emulator` golden image on `netduinoplus2`: every estimate of the golden pack,
//!    sent over USART1 to a file, compared with the host's f64 answers exactly as the mps2
//!    golden test does ([`crate::firmware::golden::run_golden`]);
//! 4. serves the `emulator` product image's link on `netduinoplus2` (USART1 on a loopback TCP
//!    port): ping, status, a few hundred golden samples answered as the host does, a signed
//!    model update accepted; the stack peaks it reports (painting, as on mps2) are the board's
//!    at boot, serving and the update peak. The part's build differs in its logger (defmt-rtt:
//!    a RAM buffer, counted in its static RAM) and its clock and flash code, not in the paths
//!    whose stack is measured.
//!
//! Writes `target/bench/board.json` ([`BoardRecord`]), which `cargo xtask bench` puts into
//! BENCHMARKS.json/.md.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use fbg_link::parity::{compare, REL_TOL};
use fbg_shared::protocol::UpdateResult;

use serde::{Deserialize, Serialize};

use crate::cmd::{cargo_own_target, run, step, write_atomic};
use crate::elf::{self, Footprint};
use crate::firmware::emulator::{self, Machine};
use crate::firmware::golden::{golden_scale, run_golden};
use crate::firmware::session::LinkSession;
use crate::firmware::{self, release_dir};
use crate::fixtures::{self, Fixtures};
use crate::signing;
use crate::targets::{verdict, PRODUCT_K, TARGET_BOARD_FLASH, TARGET_RAM_LOAD};

/// The board images of one build.
#[derive(Clone, Debug)]
pub struct BoardImages {
    /// The product image (`fbg-board`).
    pub product: PathBuf,
    /// The golden-vector image (`fbg-board-golden`): the `emulator` build's only (nothing runs
    /// it on the part, so the part's build links the product alone).
    pub golden: Option<PathBuf>,
}

/// The board crate's directory.
pub fn dir(root: &Path) -> PathBuf {
    firmware::dir(root).join("board")
}

/// Build the board images: for the part (`emulator` false) the product alone, for QEMU's
/// `netduinoplus2` the product and the golden image; copied to `target/board/{part,emulator}/`.
pub fn build(root: &Path, emulator: bool) -> Result<BoardImages> {
    let features: &[&str] = if emulator { &["--features", "emulator"] } else { &[] };
    // The firmware's build environment, so that the crates both workspaces' images share
    // (kernel, loader: `FBG_K`) are not rebuilt between them.
    let names: &[&str] = if emulator { &["fbg-board", "fbg-board-golden"] } else { &["fbg-board"] };
    let mut c = cargo_own_target();
    c.current_dir(dir(root)).args(["build", "--release", "--locked", "-p", "fbg-firmware-board"]);
    for name in names {
        c.args(["--bin", name]);
    }
    run(c.args(features).envs(firmware::build_env(root, PRODUCT_K, None)))?;
    let out = root.join("target").join("board").join(if emulator { "emulator" } else { "part" });
    fs::create_dir_all(&out)?;
    let copy = |name: &str| -> Result<PathBuf> {
        let to = out.join(name);
        fs::copy(release_dir(root).join(name), &to).with_context(|| format!("copying {name} to {}", to.display()))?;
        Ok(to)
    };
    let product = copy("fbg-board")?;
    let golden = if emulator { Some(copy("fbg-board-golden")?) } else { None };
    Ok(BoardImages { product, golden })
}

/// The flash budget on the product as it ships (`cargo xtask size`, after the mps2 figures):
/// the STM32F405 product image built for the part, its flash against the target and no
/// `core::fmt` in it.
pub fn flash_budget(root: &Path, mps2_flash: u64) -> Result<()> {
    step("size: the STM32F405 product image (the build for the part), the one held to the flash budget");
    let part = build(root, false)?;
    let f = elf::footprint(&part.product)?;
    elf::ensure_no_core_fmt(&part.product, "the STM32F405 product image")?;
    println!(
        "STM32F405 product image (the part): flash {} B ({:.1} KiB; target ≤ {} KiB with the signature verifier: {}); static RAM {} B; the mps2 QEMU image {} B",
        f.flash,
        f.flash as f64 / 1024.0,
        TARGET_BOARD_FLASH / 1024,
        verdict(f.flash <= TARGET_BOARD_FLASH),
        f.ram_static,
        mps2_flash
    );
    Ok(())
}

/// `cargo xtask board`: build both builds, print the footprint, run the golden vectors and the
/// link on `netduinoplus2`; writes `target/bench/board.json`.
pub fn run_all(root: &Path) -> Result<BoardRecord> {
    let started = Instant::now();
    step("board: QEMU prerequisites and fixtures");
    let qemu = emulator::ensure_qemu()?;
    let fx = fixtures::ensure(root)?;
    let images = build_both(root)?;
    let record = run_images(root, &qemu, &fx, &images)?;
    eprintln!("xtask: board: built, measured and tested in {:.1} s", started.elapsed().as_secs_f64());
    Ok(record)
}

/// The board images of both builds: (for the part, for QEMU's `netduinoplus2`).
pub fn build_both(root: &Path) -> Result<(BoardImages, BoardImages)> {
    step("board: build the STM32F405 images (for the part, then the `emulator` build)");
    Ok((build(root, false)?, build(root, true)?))
}

/// The footprint of the part's product image, the golden vectors and the link of the
/// `emulator` build on `netduinoplus2`; writes `target/bench/board.json`.
pub fn run_images(
    root: &Path,
    qemu: &Path,
    fx: &Fixtures,
    (part, emu): &(BoardImages, BoardImages),
) -> Result<BoardRecord> {
    let footprint = elf::footprint(&part.product)?;
    step("board: no core::fmt in the product image for the part (its symbols)");
    elf::ensure_no_core_fmt(&part.product, "the STM32F405 product image")?;
    let emu_footprint = elf::footprint(&emu.product)?;
    step("board: golden vectors on QEMU netduinoplus2 (the `emulator` build)");
    let image = emu.golden.as_ref().context("the emulator build links the golden image")?;
    let golden = run_golden(root, qemu, Machine::NetduinoPlus2, image, "board-golden", fx)?;
    eprintln!(
        "xtask: board golden on netduinoplus2: {} samples of {} sets identical to the host within tolerance ({:.1} s)",
        golden.samples, golden.sets, golden.run_secs
    );
    step("board: link on QEMU netduinoplus2 (samples, status, a signed update; stack peaks)");
    let stack = link_smoke(root, qemu, &emu.product, fx)?;
    let record = BoardRecord::new(&footprint, &emu_footprint, (golden.sets, golden.samples, golden.flagged), &stack);
    print_board(&footprint, &record);
    let json = serde_json::to_string_pretty(&record)?;
    let out = root.join("target").join("bench");
    fs::create_dir_all(&out)?;
    let path = out.join("board.json");
    write_atomic(&path, format!("{json}\n").as_bytes())?;
    println!("wrote {}", path.display());
    Ok(record)
}

/// How long the product image is given to boot before the first request.
const BOOT_GRACE: Duration = Duration::from_secs(1);

/// Samples of the link smoke test.
const SMOKE_SAMPLES: usize = 300;

/// The product image on `netduinoplus2` serving its link: every answer as the host's, a signed
/// model update accepted; returns the stack peaks it reports.
fn link_smoke(root: &Path, qemu: &Path, elf: &Path, fx: &Fixtures) -> Result<BoardStack> {
    let dfx = fixtures::ensure_device(root)?;
    let update = fs::read(signing::sign_one(root, fx, &dfx.update_model, 1)?)?;
    let model = fs::read(&fx.model)?;
    let (scale, _) = golden_scale(fx, &model)?;
    let tol: Vec<f64> = scale.iter().map(|s| REL_TOL * s).collect();
    let inputs = fixtures::read_inputs(&fx.golden_inputs)?;
    let expected = fixtures::read_expected(&fx.golden_expected)?;
    let mut s = LinkSession::start_on(Machine::NetduinoPlus2, root, qemu, elf, "board-link")?;
    // QEMU starts the guest when the client connects, and its STM32 USART drops what arrives
    // before the firmware enables the receiver (as the part does): give the image time to boot
    // (its model load takes milliseconds of emulated time) before the first request.
    std::thread::sleep(BOOT_GRACE);
    s.link()?.ping(7)?;
    let boot = s.link()?.status()?.stack_boot_bytes;
    let n = SMOKE_SAMPLES.min(inputs.len());
    for (i, (x, want)) in inputs.iter().zip(&expected).take(n).enumerate() {
        let e = s.link()?.compensate(i as u32, x)?;
        if let Err(why) = compare(&e, want, &tol) {
            bail!("board link: sample {i}: {why}");
        }
    }
    let serving = s.link()?.status()?.stack_peak_bytes;
    match s.link()?.update_model(&update)? {
        UpdateResult::Accepted { .. } => {}
        other => bail!("board link: the signed model update was refused: {other:?}"),
    }
    for (i, x) in inputs.iter().take(20).enumerate() {
        s.link()?.compensate(i as u32, x)?;
    }
    let st = s.link()?.status()?;
    ensure!(st.updates_accepted == 1, "board link: the status counts {} accepted updates, not 1", st.updates_accepted);
    s.disconnect()?;
    s.check_alive()?;
    eprintln!(
        "xtask: board link on netduinoplus2: {n} samples answered as the host does, a signed update accepted; \
         stack peak {boot} B boot, {serving} B serving, {} B through the update",
        st.stack_peak_bytes
    );
    Ok(BoardStack { boot, serving, update: st.stack_peak_bytes })
}

fn print_board(f: &Footprint, r: &BoardRecord) {
    println!("board product image (STM32F405, K = {PRODUCT_K}, the build for the part):");
    for (name, size, ram) in &f.sections {
        println!("  {name:<16} {size:>7} B  {}", if *ram { "RAM" } else { "flash" });
    }
    println!(
        "  flash            {:>7} B  ({:.1} KiB; target ≤ {} KiB with the store and the verifier: {})",
        r.flash_bytes,
        r.flash_bytes as f64 / 1024.0,
        TARGET_BOARD_FLASH / 1024,
        verdict(r.flash_bytes <= TARGET_BOARD_FLASH)
    );
    println!("  static RAM       {:>7} B  (the emulator build: {} B)", r.static_ram_bytes, r.emulator_static_ram_bytes);
    if let Some(st) = &r.stack {
        println!(
            "  stack peak       {:>7} B serving; {} B through a model update; {} B during boot (emulator build, painted)",
            st.serving, st.update, st.boot
        );
        let total = r.static_ram_bytes + u64::from(st.update.max(st.boot));
        println!(
            "  static + stack   {:>7} B  ({:.1} KiB) at the update peak; target ≤ {} KiB: {}",
            total,
            total as f64 / 1024.0,
            TARGET_RAM_LOAD / 1024,
            verdict(total <= TARGET_RAM_LOAD)
        );
    }
    println!(
        "  golden on netduinoplus2: {} sets, {} samples ({} flagged) identical to the host within {} %",
        r.golden_sets,
        r.golden_samples,
        r.golden_flagged,
        100.0 * REL_TOL
    );
}

/// Stack peaks of the board's product image \[B\], by painting, reported over its link.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoardStack {
    pub boot: u32,
    pub serving: u32,
    pub update: u32,
}

/// The STM32F405 board (`firmware/board/`, `cargo xtask board`): the footprint of the product
/// image built for the part, the golden vectors and the stack peaks of the `emulator` build on
/// QEMU's `netduinoplus2`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BoardRecord {
    pub chip: String,
    pub k: usize,
    pub flash_bytes: u64,
    pub static_ram_bytes: u64,
    pub emulator_flash_bytes: u64,
    pub emulator_static_ram_bytes: u64,
    /// Measured on the `emulator` build; absent when not measured.
    #[serde(default)]
    pub stack: Option<BoardStack>,
    /// Static RAM (the part's build) + the larger of the boot and update stack peaks.
    #[serde(default)]
    pub static_ram_plus_stack_bytes: Option<u64>,
    pub golden_machine: String,
    pub golden_sets: usize,
    pub golden_samples: usize,
    pub golden_flagged: usize,
    pub target_flash_bytes: u64,
    pub flash_met: bool,
    pub target_static_ram_plus_stack_bytes: u64,
    #[serde(default)]
    pub static_ram_plus_stack_met: Option<bool>,
}

impl BoardRecord {
    /// The record of one `cargo xtask board` run: `part` and `emu` are the footprints of the
    /// product image's two builds, `golden` the golden run's (sets, samples, flagged).
    pub fn new(
        part: &crate::elf::Footprint,
        emu: &crate::elf::Footprint,
        golden: (usize, usize, usize),
        stack: &BoardStack,
    ) -> Self {
        let total = part.ram_static + u64::from(stack.update.max(stack.boot));
        BoardRecord {
            chip: "STM32F405RG".into(),
            k: PRODUCT_K,
            flash_bytes: part.flash,
            static_ram_bytes: part.ram_static,
            emulator_flash_bytes: emu.flash,
            emulator_static_ram_bytes: emu.ram_static,
            stack: Some(stack.clone()),
            static_ram_plus_stack_bytes: Some(total),
            golden_machine: "QEMU netduinoplus2".into(),
            golden_sets: golden.0,
            golden_samples: golden.1,
            golden_flagged: golden.2,
            target_flash_bytes: TARGET_BOARD_FLASH,
            flash_met: part.flash <= TARGET_BOARD_FLASH,
            target_static_ram_plus_stack_bytes: TARGET_RAM_LOAD,
            static_ram_plus_stack_met: Some(total <= TARGET_RAM_LOAD),
        }
    }
}
