//! `cargo xtask size`: flash and static RAM of the product image from its ELF, and its stack
//! peaks measured over the link (boot, serving, model updates). The flash budget is the
//! STM32F405 product image's, the product as it ships (`crate::board::flash_budget`, which
//! `cargo xtask size` runs after this); the mps2 image carries a QEMU-only persistence driver
//! and is reported here beside it. The default product (without
//! spectrum frames) is the one checked against DESIGN's budgets; the product built with
//! spectrum frames (`--features spectrum`) is measured the same way, its serving peak over
//! spectrum readings too, and reported beside it.

use std::fs;
use std::path::Path;

use anyhow::{bail, Context, Result};

use super::verdict;
use crate::elf::{self, Footprint};
use crate::firmware::emulator::{self, out_dir};
use crate::firmware::session::LinkSession;
use crate::firmware::{self, Bins};
use crate::fixtures;
use crate::signing;
use crate::targets::{PRODUCT_K, TARGET_BLOB, TARGET_RAM, TARGET_RAM_LOAD};

/// Footprint of the product image.
#[derive(Clone, Debug)]
pub struct SizeReport {
    /// ELF sections.
    pub footprint: Footprint,
    /// Stack peak during boot (embedded model decoded and folded) \[B\].
    pub stack_boot: u32,
    /// Stack peak while serving samples, status and pings, and spectrum frames on the build
    /// with them (painted again after boot) \[B\].
    pub stack_serving: u32,
    /// Stack peak once a model update went through the link (includes serving) \[B\].
    pub stack_update: u32,
    /// Size of the embedded default blob \[B\].
    pub blob_bytes: u64,
    /// The model store's flash (`STORE` of `memory.x`: two model slots and the event log;
    /// flash outside the image, neither RAM nor part of the image) \[B\].
    pub store_region: u64,
    /// The same figures of the product built with spectrum frames (`--features spectrum`; not
    /// checked against the RAM budgets); `None` inside that report itself.
    pub spectrum: Option<Box<SizeReport>>,
}

/// The product images, built on the current fixtures.
pub(super) fn product_images(root: &Path) -> Result<Bins> {
    fixtures::ensure(root)?;
    firmware::build(root, PRODUCT_K, None)
}

/// `cargo xtask size`: flash, static RAM and measured stack of the product image.
pub fn size(root: &Path) -> Result<SizeReport> {
    let q = emulator::ensure_qemu()?;
    let bins = product_images(root)?;
    let report = measure_size(root, &q, &bins)?;
    print_size(&report);
    Ok(report)
}

/// The default product's figures (`bins.product`), then those of the product with spectrum
/// frames (built here).
pub(super) fn measure_size(root: &Path, q: &Path, bins: &Bins) -> Result<SizeReport> {
    crate::cmd::step("size: product image footprint and stack high-water mark");
    let mut report = measure_product(root, q, &bins.product, false)?;
    crate::cmd::step("size: the product with spectrum frames (--features spectrum)");
    let spectrum = firmware::build_spectrum_product(root, PRODUCT_K)?;
    report.spectrum = Some(Box::new(measure_product(root, q, &spectrum, true)?));
    Ok(report)
}

/// Footprint and stack peaks of the product image `elf`; `spectrum`: it has spectrum frames,
/// and serving includes spectrum readings.
fn measure_product(root: &Path, q: &Path, elf: &Path, spectrum: bool) -> Result<SizeReport> {
    let footprint = elf::footprint(elf)?;
    let fx = fixtures::ensure(root)?;
    let dfx = fixtures::ensure_device(root)?;
    let default = fs::read(firmware::dir(root).join("model/default.fbgm"))?;
    let update = fs::read(signing::sign_one(root, &fx, &dfx.update_model, 1)?)?;
    let mut s = LinkSession::start(root, q, elf, if spectrum { "size-spectrum" } else { "size" })?;
    s.link()?.ping(1)?;
    let stack_boot = s.link()?.status()?.stack_boot_bytes;
    // Serving: the golden samples (hold-out, then the flagged and non-finite edge cases).
    let samples = fixtures::read_inputs(&fx.golden_inputs)?;
    for (i, x) in samples.iter().enumerate() {
        s.link()?.compensate(i as u32, x)?;
    }
    // And spectrum frames on the build with them (set-up, chunks, detection, the step of each
    // reading).
    if spectrum {
        crate::qemu::spectrum::serve_readings(s.link()?, &default, 8)?;
    }
    let _ = s.link()?.status()?;
    let stack_serving = s.link()?.status()?.stack_peak_bytes;
    // Model updates: a refused one (it fails in the fold, after a full parse) and an accepted
    // one (parse and fold), then serving again.
    let mut p = fixtures::decode(&update)?;
    p.hyper.sigma = 1e-38; // valid, but 1/σ overflows f32 when folded
    let mut refused = vec![0u8; fbg_shared::blob::max_len(fixtures::MAX_K)];
    let n = fbg_shared::blob::encode(&p, &mut refused).map_err(|e| anyhow::anyhow!("{e}"))?;
    refused.truncate(n);
    // Signed, so that it passes the signature check and fails in the fold after a full parse.
    let refused_path = out_dir(root)?.join("size-refused.fbgm");
    fs::write(&refused_path, &refused)?;
    let refused = fs::read(signing::sign_one(root, &fx, &refused_path, 1)?)?;
    match s.link()?.update_model(&refused)? {
        fbg_shared::protocol::UpdateResult::Rejected(_) => {}
        other => bail!("the size run's corrupted update was accepted: {other:?}"),
    }
    match s.link()?.update_model(&update)? {
        fbg_shared::protocol::UpdateResult::Accepted { .. } => {}
        other => bail!("the size run's model update was refused: {other:?}"),
    }
    for (i, x) in samples.iter().take(50).enumerate() {
        s.link()?.compensate(i as u32, x)?;
    }
    let stack_update = s.link()?.status()?.stack_peak_bytes;
    s.disconnect()?;
    s.check_alive()?;
    let store_region = store_region(root)?;
    Ok(SizeReport {
        footprint,
        stack_boot,
        stack_serving,
        stack_update,
        blob_bytes: default.len() as u64,
        store_region,
        spectrum: None,
    })
}

/// Length of the `STORE` region of the top-level `memory.x` (`LENGTH = 64K` or a number of
/// bytes), the model store's flash.
fn store_region(root: &Path) -> Result<u64> {
    let path = root.join("memory.x");
    let text = fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("STORE"))
        .with_context(|| format!("{} has no STORE region", path.display()))?;
    let len = line.split("LENGTH").nth(1).and_then(|r| r.split('=').nth(1)).map(str::trim).unwrap_or_default();
    let (digits, scale) = match len.strip_suffix('K') {
        Some(d) => (d, 1024),
        None => (len, 1),
    };
    let n: u64 = digits.trim().parse().with_context(|| format!("STORE length `{len}` in {}", path.display()))?;
    Ok(n * scale)
}

pub(super) fn print_size(r: &SizeReport) {
    let f = &r.footprint;
    println!("product image (K = {PRODUCT_K}):");
    for (name, size, ram) in &f.sections {
        println!("  {name:<16} {size:>7} B  {}", if *ram { "RAM" } else { "flash" });
    }
    println!(
        "  flash            {:>7} B  ({:.1} KiB; the mps2 QEMU image, with its semihosting store driver: the 48 KiB budget is the STM32F405 image's, `cargo xtask board`)",
        f.flash,
        f.flash as f64 / 1024.0
    );
    println!("  static RAM       {:>7} B", f.ram_static);
    println!(
        "  model store      {:>7} B  flash outside the image (STORE of memory.x): two model slots (an update is programmed into the inactive one, not RAM) and the event log",
        r.store_region
    );
    println!(
        "  stack peak       {:>7} B serving samples; {} B during a model update; {} B during boot",
        r.stack_serving, r.stack_update, r.stack_boot
    );
    for (what, stack, target) in [
        ("serving", r.stack_serving, TARGET_RAM),
        ("model update", r.stack_update, TARGET_RAM_LOAD),
        ("boot", r.stack_boot, TARGET_RAM_LOAD),
    ] {
        let total = f.ram_static + stack as u64;
        println!(
            "  static + stack   {:>7} B  ({:.1} KiB) {what}; target ≤ {} KiB: {}",
            total,
            total as f64 / 1024.0,
            target / 1024,
            verdict(total <= target)
        );
    }
    println!("  model blob       {:>7} B  (target ≤ 4 KiB: {})", r.blob_bytes, verdict(r.blob_bytes <= TARGET_BLOB));
    if let Some(sp) = &r.spectrum {
        let g = &sp.footprint;
        println!("product with spectrum frames (--features spectrum; not checked against the budgets above):");
        println!(
            "  flash            {:>7} B  ({:.1} KiB; {:+} B over the default product)",
            g.flash,
            g.flash as f64 / 1024.0,
            g.flash as i64 - f.flash as i64
        );
        println!("  static RAM       {:>7} B  ({:+} B)", g.ram_static, g.ram_static as i64 - f.ram_static as i64);
        println!(
            "  stack peak       {:>7} B serving samples and spectrum frames; {} B during a model update; {} B during boot",
            sp.stack_serving, sp.stack_update, sp.stack_boot
        );
        for (what, stack) in [("serving", sp.stack_serving), ("model update", sp.stack_update), ("boot", sp.stack_boot)]
        {
            let total = g.ram_static + stack as u64;
            println!("  static + stack   {:>7} B  ({:.1} KiB) {what}", total, total as f64 / 1024.0);
        }
    }
}
