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

/// The largest blob this build stages: the blob target of DESIGN §8 (4 KiB), or the longest
/// blob of `K` centres at the capacity dims when that is smaller. A paper-dims model of 32
/// centres fits; an 8 → 4 model with its memory bank fits up to 18 centres; a longer update is
/// refused at `ModelBegin` (`TooLarge`). Here, beside `K`, so that every board image takes the
/// same limits.
pub const MAX_BLOB: usize = {
    let longest = fbg_shared::blob::max_len(K);
    if longest < 4096 {
        longest
    } else {
        4096
    }
};

/// The longest update this build stages (in the model store's inactive slot): any signed
/// model it takes, its blob and a version-2 signature trailer; a longer transfer is refused at
/// `ModelBegin` (`TooLarge`).
pub const STAGING_LEN: usize = MAX_BLOB + fbg_shared::signature::TRAILER_V2_LEN;

/// `comp.step(s)` at opt-level 3 (see the crate docs).
#[inline(never)]
pub fn step(comp: &mut Compensator<f32, K>, s: &Sample<f32>) -> Estimate<f32> {
    // The compensator's address kept opaque: for a compensator in a `static`, LLVM otherwise
    // folds the address into each field's and materialises every one with an add (a Thumb-2
    // float load reaches 1 020 bytes from its base), where a base register serves them all.
    core::hint::black_box(&mut *comp).step(s)
}

/// The step and the model loader, for `fbg_firmware_app`.
pub const KERNEL: Kernel<K> = Kernel { step, load };
