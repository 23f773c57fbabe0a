//! Device measurements (DESIGN §8): `cargo xtask size` and the device part of `cargo xtask bench`.
//!
//! - Instructions per `Compensator::step` for every bench model (`fixtures::ensure_device`):
//!   the trainer's default model, the synthetic model with the full memory bank at K = 0, 16,
//!   32 (and 64) and without memory at K = 16, 32, 64, the random models of other dims
//!   (2 → 2, 8 → 4) and the trainer's Model-H of the other presets
//!   (`fixtures::TRAINED_PRESETS`: strain-pair, temperature-1, array-8). The `bench` image (one build per
//!   capacity, 32 and 64, each embedding its models) runs under `qemu-system-arm -icount
//!   shift=0` (one instruction = 1 ns of virtual time), counts SysTick ticks around `n` steps
//!   and around the same loop without the step, for n = 200 and 800. Ticks become instructions
//!   through a calibration loop of known length; the cost per step is `Δ(step − empty) / Δn`
//!   between the two runs (fixed costs cancel), and the per-run values must agree within 2 %
//!   (linearity). Mode `regular` replays the samples on their 60 s clock (the memory bank's
//!   smoothing factors cached), mode `jitter` gives every step a new Δt (recomputed).
//! - The sizes of the device's types (`MemoryState<f32>`, `Compensator<f32, 32>`, …) as the
//!   bench image reports them (`size_of` on the target).
//! - Flash and static RAM of the product image from its ELF sections ([`crate::elf`]); the same
//!   of the product built with spectrum frames (`--features spectrum`), beside it.
//! - Stack high-water mark of the product image by stack painting, read over the link from
//!   `Status::stack_peak_bytes`: after boot, after streaming, after a (signed) model update,
//!   whose peak includes the signature verification (on the spectrum build, streaming includes
//!   spectrum readings).
//! - The model store ([`store`]): flash operations and erases of one update, boot time to
//!   serving with a full event log (emulated time under `-icount`).
//! - The Ed25519 verifier candidates ([`verifiers`]): verify-only images of salty,
//!   ed25519-compact (with and without `opt_size`) and ed25519-dalek, each running the RFC 8032
//!   vectors on the device; flash, stack and instructions of one verification.
//! - Instructions of one signature check of a model update (`fbg_firmware_app::authenticate`:
//!   trailer, key lookup, Ed25519 verification, serial) on the default model signed with the
//!   QEMU test key, timed by the bench image like a step, with the stack it reached.
//!
//! Results are printed and written to `target/bench/device.json` ([`record::DeviceRecord`],
//! through serde; `cargo xtask bench` reads the same type back). The arithmetic lower bound
//! each step is set beside is counted in [`ops`].

use crate::targets::verdict;
use std::fs;
use std::path::Path;

use anyhow::{Context, Result};

use crate::cmd::write_atomic;
use crate::firmware::emulator;
use crate::targets::TARGET_INSNS_K32;
use record::DeviceRecord;
pub use size::{size, SizeReport};

pub mod ops;
mod pack;
pub mod profile;
pub mod record;
mod size;
pub mod store;
pub mod verifiers;

/// One signature check of a model update, timed by the bench image.
#[derive(Clone, Debug, Default)]
pub struct VerifyBench {
    /// Bytes of the signed model checked.
    pub bytes: u64,
    /// Instructions of one `authenticate` call.
    pub instructions: f64,
    /// Stack the check reached, in bytes (the bench's own frames included).
    pub stack_peak: u32,
}

/// Instructions per 512-pixel channel frame with three gratings (the device target).
pub const TARGET_INSNS_SPECTRUM_FRAME: f64 = 10_000.0;

/// The spectrum bench of the bench image: one 512-pixel channel frame with three gratings
/// through the device's spectrum front (`fbg_firmware_app::spectrum`: begin, six chunks of 96
/// pixels, the windows' pixels kept, three peaks by cross-correlation in f32), without the
/// link's framing and the step (timed apart).
#[derive(Clone, Debug, Default)]
pub struct SpectrumBench {
    /// Instructions per frame from the two-run difference.
    pub insns_per_frame: f64,
    /// Per-run estimates ((frames − empty) / n).
    pub per_run: Vec<(u32, f64)>,
    /// Instructions of a frame's reception alone (a channel without gratings: begin, chunks).
    pub ingest_per_frame: f64,
    /// Instructions of one window's detection (25 pixels) with the maximum: the detector's
    /// common part.
    pub window_maximum: f64,
    /// The same with the cross-correlation (the device's method).
    pub window_cross_correlation: f64,
}

/// One model of the step bench.
#[derive(Clone, Debug)]
pub struct StepBench {
    /// Row name (`default`, `memory_k32`, `plain_k64`, …).
    pub name: &'static str,
    /// Centres of the model.
    pub k: usize,
    /// Memory slots the model uses (0: no memory bank).
    pub memory_terms: usize,
    /// Capacity of the bench image.
    pub capacity: usize,
    /// Instructions per SysTick tick from the calibration loop.
    pub insns_per_tick: f64,
    /// Instructions per step from the two-run difference, regular clock.
    pub insns_per_step: f64,
    /// Per-run estimates ((step − empty) / n) for n = 200 and 800, regular clock.
    pub per_run: Vec<(u32, f64)>,
    /// Instructions per step when every step has a new Δt (mode `jitter`).
    pub insns_per_step_jitter: f64,
    /// Stack peak of the bench image \[B\] (all its models).
    pub stack_peak: u32,
    /// Blob size of the bench model \[B\].
    pub blob_bytes: u64,
    /// Arithmetic operations of one step of this model ([`ops::step_ops_of`]).
    pub lower_bound_ops: usize,
    /// DWT cycles per step (0 under QEMU, which does not model cycles).
    pub cycles_per_step: f64,
    /// Where the model comes from.
    pub model_source: &'static str,
}

/// Sizes of the device's types \[B\], from the bench image (`size_of` on the target).
#[derive(Clone, Debug, Default)]
pub struct TypeSizes {
    /// Capacity they were measured at.
    pub k: usize,
    /// `MemoryState<f32>`: the memory bank's stream state.
    pub memory_state: u64,
    /// `StreamState<f32>`: latches and memory state.
    pub stream_state: u64,
    /// `MemoryBank<f32>`: the bank's coefficients, cached factors and state.
    pub memory_bank: u64,
    /// `Compensator<f32, K>`.
    pub compensator: u64,
    /// `ModelParams<f32, K>`: the parameter slot a model is parsed into (on the stack of a load).
    pub model_params: u64,
    /// `FrameReader<HOST_MAX_FRAME>`: the link's frame reader.
    pub reader: u64,
    /// The longest update the build stages (in its flash slot, not in RAM): `STAGING_LEN`.
    pub staging: u64,
}

/// The sizes of the device's types, as the bench image of capacity 32 reports them (it runs
/// that capacity's step benches too).
pub fn type_sizes(root: &Path, q: &Path) -> Result<TypeSizes> {
    let (mut sizes, mut verify, mut spectrum) = (None, None, None);
    pack::bench_pack(root, q, 32, &mut sizes, &mut verify, &mut spectrum)?;
    sizes.context("the bench image reported no type sizes")
}

/// `cargo xtask bench` (device part): step cost of every bench model, the sizes of the device's
/// types and the footprint; writes `target/bench/device.json`.
pub fn run(root: &Path) -> Result<(Vec<StepBench>, SizeReport)> {
    let q = emulator::ensure_qemu()?;
    let mut steps = Vec::new();
    let mut sizes = None;
    let mut sizes64 = None;
    let mut verify = None;
    let mut verify64 = None;
    let mut spectrum = None;
    let mut spectrum64 = None;
    steps.extend(pack::bench_pack(root, &q, 32, &mut sizes, &mut verify, &mut spectrum)?);
    steps.extend(pack::bench_pack(root, &q, 64, &mut sizes64, &mut verify64, &mut spectrum64)?);
    let spectrum = spectrum.context("the bench image did not time the spectrum frames")?;
    let sizes = sizes.context("the bench image reported no type sizes")?;
    let verify = verify.context("the bench image did not time the signature check")?;
    let bins = size::product_images(root)?;
    let size = size::measure_size(root, &q, &bins)?;
    let store = store_bench(root, &q, &bins)?;
    let verifiers = verifiers::measure(root, &q)?;
    println!();
    for s in &steps {
        let target = if s.name == "default" {
            format!("  (target ≤ {TARGET_INSNS_K32:.0}: {})", verdict(s.insns_per_step <= TARGET_INSNS_K32))
        } else {
            String::new()
        };
        println!(
            "{:<13} K = {:>2}, {:>2} memory terms: {:>7.0} instructions per step ({:.0} with a new Δt every step){target}",
            s.name, s.k, s.memory_terms, s.insns_per_step, s.insns_per_step_jitter
        );
    }
    print_sizes(&sizes);
    size::print_size(&size);
    println!(
        "signature check of a model update ({} B signed model): {:.0} instructions (once per update, not per sample); stack reached {} B",
        verify.bytes, verify.instructions, verify.stack_peak
    );
    println!(
        "spectrum frame (512 pixels, 3 gratings, cross-correlation, f32): {:.0} instructions per channel frame ({:.0} / {:.0} over {} / {} frames)  (target ≤ {TARGET_INSNS_SPECTRUM_FRAME:.0}: {})",
        spectrum.insns_per_frame,
        spectrum.per_run[0].1,
        spectrum.per_run[1].1,
        spectrum.per_run[0].0,
        spectrum.per_run[1].0,
        verdict(spectrum.insns_per_frame <= TARGET_INSNS_SPECTRUM_FRAME)
    );
    println!(
        "  of it: reception {:.0} per frame (begin, 6 chunks, no window); one window's detection (25 pixels) {:.0} by cross-correlation, {:.0} by the maximum (the detector's common part)",
        spectrum.ingest_per_frame, spectrum.window_cross_correlation, spectrum.window_maximum
    );
    store::print(&store);
    let mut record = DeviceRecord::new(&steps, &sizes, &size, &verify, Some(&store));
    record.spectrum = Some(record::SpectrumRow::new(&spectrum));
    record.verifiers = Some(verifiers);
    let json = serde_json::to_string_pretty(&record)?;
    let dir = root.join("target").join("bench");
    fs::create_dir_all(&dir)?;
    let path = dir.join("device.json");
    write_atomic(&path, format!("{json}\n").as_bytes())?;
    println!("wrote {}", path.display());
    Ok((steps, size))
}

/// The product images' footprint and stack peaks (`cargo xtask size`'s figures, the default
/// product and the build with spectrum frames), without printing them.
pub fn footprint(root: &Path, q: &Path) -> Result<SizeReport> {
    let bins = size::product_images(root)?;
    size::measure_size(root, q, &bins)
}

/// The model store's figures ([`store`]) on the product images `bins`, with the signed
/// fixtures of the QEMU tests.
fn store_bench(root: &Path, q: &Path, bins: &crate::firmware::Bins) -> Result<store::StoreBench> {
    let fx = crate::fixtures::ensure(root)?;
    let dfx = crate::fixtures::ensure_device(root)?;
    let sfx = crate::signing::ensure(root, &fx, &dfx)?;
    store::measure(root, q, bins, &sfx)
}

/// Only the store's figures (prints them; writes nothing): `cargo test -p xtask -- --ignored
/// store_bench_alone --nocapture`, for working on the store without the whole device bench.
#[cfg(test)]
#[test]
#[ignore = "runs QEMU for a minute; part of `cargo xtask device-bench`"]
fn store_bench_alone() -> Result<()> {
    let root = crate::cmd::root();
    let q = emulator::ensure_qemu()?;
    let bins = size::product_images(&root)?;
    let b = store_bench(&root, &q, &bins)?;
    store::print(&b);
    Ok(())
}

fn print_sizes(t: &TypeSizes) {
    println!("device types (size_of on thumbv7em-none-eabihf, K = {}):", t.k);
    println!("  MemoryState<f32>     {:>6} B  (the memory bank's stream state)", t.memory_state);
    println!("  StreamState<f32>     {:>6} B  (latches + memory state)", t.stream_state);
    println!("  MemoryBank<f32>      {:>6} B  (coefficients, cached factors, state)", t.memory_bank);
    println!("  Compensator<f32, {}> {:>6} B", t.k, t.compensator);
    println!(
        "  ModelParams<f32, 0, 0> {:>6} B  (parameter slot without centres and Γ, on the stack during a load)",
        t.model_params
    );
    println!("  FrameReader          {:>6} B  (the link's frame reader)", t.reader);
    println!("  longest staged update {:>5} B  (in the flash slot, not RAM: STAGING_LEN)", t.staging);
}
