//! The library code of the firmware whose code generation matters more than its size, alone in
//! its crate so that it keeps a speed opt-level while the rest of the image is optimised for
//! size (`firmware/Cargo.toml`, profile): [`step`], `Compensator<f32, K>::step` (at opt-level
//! "s" it takes more than twice the instructions per step; README-firmware.md has the
//! measurements, BENCHMARKS.md the current figures).
//!
//! Generic code is compiled, with that crate's opt-level, in the crate that instantiates it.
//! `step` is generic, so here it is instantiated once, for this build's capacity [`K`], behind
//! a non-generic never-inlined function; [`KERNEL`] hands it to the application with the
//! model loader of `fbg-firmware-loader` (the blob parser and `Compensator::reload`, whose
//! opt-level is chosen for flash and stack instead). Every image (product, golden, bench) runs
//! this very code.

#![no_std]

use fbg_firmware_app::Kernel;
use fbg_shared::{Compensator, Estimate, Sample};

pub use fbg_firmware_loader::load;
/// Centre capacity of this build (env `FBG_K` at build time, default 32).
pub use fbg_firmware_loader::K;

/// `comp.step(s)` at opt-level 3 (see the crate docs).
#[inline(never)]
pub fn step(comp: &mut Compensator<f32, K>, s: &Sample<f32>) -> Estimate<f32> {
    comp.step(s)
}

/// The step and the model loader, for `fbg_firmware_app`.
pub const KERNEL: Kernel<K> = Kernel { step, load };
