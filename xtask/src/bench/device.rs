//! The device part: instructions per step and the footprint under QEMU (`device_bench`), and
//! the arithmetic lower bound counted from the code (`device_bench::ops`).

use std::path::Path;

use anyhow::Result;

use fbg_shared::layout::paper::N_MEMORY;
use fbg_shared::layout::Dims;
use fbg_shared::MemorySpec;

use super::report::{Device, DeviceResults, LowerBound, LowerBoundAtK};
use super::runner::read_json;
use super::Opts;
use crate::device_bench;
use crate::device_bench::ops::{memory_ops, step_ops};

/// Run the device bench (or, with `--no-device`, reuse `target/bench/device.json`) and add the
/// arithmetic lower bound.
pub fn part(root: &Path, opts: &Opts) -> Result<DeviceResults> {
    let path = root.join("target/bench/device.json");
    if opts.no_device {
        eprintln!("bench: --no-device: reusing {}", path.display());
    } else {
        device_bench::run(root)?;
    }
    let board = root.join("target/bench/board.json");
    if !opts.no_device {
        crate::board::run_all(root)?;
    }
    let mut v: DeviceResults =
        read_json(&path).map_err(|e| e.context(format!("{}: no device results", path.display())))?;
    // The STM32F405 board's figures (`cargo xtask board`); absent, they render as not measured.
    v.record.board = read_json(&board).ok();
    v.reused_existing_results = opts.no_device;
    v.command = if opts.no_device {
        "(earlier) cargo xtask bench"
    } else {
        "cargo xtask bench (device part: xtask/src/device_bench.rs)"
    }
    .to_string();
    let full = memory_ops(&Dims::PAPER, &MemorySpec::<f32>::off(), true);
    v.arithmetic_lower_bound = Some(LowerBound {
        formula: format!(
            "{} K + {} without memory terms; + {} with the full memory bank ({} terms), + M_ops in general",
            step_ops(1, 0) - step_ops(0, 0),
            step_ops(0, 0),
            full,
            N_MEMORY
        ),
        per_k: [16, 32, 64]
            .map(|k| LowerBoundAtK { k, operations: step_ops(k, 0), operations_full_memory: step_ops(k, full) })
            .to_vec(),
        memory_full_bank: full,
        source: "shared/src/lib.rs, `Cost of one step`; memory bank: xtask/src/device_bench/ops.rs, `memory_ops`"
            .into(),
    });
    Ok(v)
}

/// `cargo xtask bench --footprint-only`: the product images' footprint and stack peaks (mps2:
/// the default product and the build with spectrum frames), the Ed25519 verifier table and
/// the STM32F405 board's figures measured again, into the device part of the BENCHMARKS.json
/// already there (which must have one; its step figures stay), and BENCHMARKS.md rendered
/// from it.
pub fn footprint_only(root: &Path) -> Result<()> {
    let q = crate::firmware::emulator::ensure_qemu()?;
    let size = device_bench::footprint(root, &q)?;
    let sizes = device_bench::type_sizes(root, &q)?;
    let verifiers = device_bench::verifiers::measure(root, &q)?;
    let board = crate::board::run_all(root)?;
    super::update(root, |report| {
        let Device::Measured(dev) = &mut report.device else {
            anyhow::bail!("BENCHMARKS.json has no device results to add the footprint to: run `cargo xtask bench`");
        };
        dev.record.set_footprint(&size, &sizes);
        dev.record.verifiers = Some(verifiers);
        dev.record.board = Some(board);
        Ok(())
    })?;
    eprintln!(
        "bench: wrote the footprint, the verifier table and the board's figures into BENCHMARKS.md and BENCHMARKS.json"
    );
    Ok(())
}
