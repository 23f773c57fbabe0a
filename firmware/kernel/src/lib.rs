//! The library code of the firmware whose code generation matters more than its size, alone in
//! its crate so that it keeps a speed opt-level while the rest of the image is optimised for
//! size (`firmware/Cargo.toml`, profile):
//!
//! - [`step`], `Compensator<f32, K>::step`: at opt-level "s" ≈ 6 600 instructions per step at
//!   K = 32 instead of ≈ 2 900;
//! - [`decode`], `blob::decode_into`, and [`reload`], `Compensator::reload`: at opt-level "s"
//!   their temporaries take ≈ 300 and ≈ 120 more bytes of stack (values passed through
//!   postcard/serde layers, folded centres returned by value), which a model update cannot
//!   afford (DESIGN §8: static RAM + stack ≤ 8 KiB; 8 084 B measured with this crate at 3).
//!
//! Generic code is compiled, with that crate's opt-level, in the crate that instantiates it.
//! These are generic, so here they are instantiated once, for this build's capacity [`K`],
//! behind non-generic never-inlined functions ([`KERNEL`] hands them to the application):
//! every image (product, golden, bench) runs this very code. Cost: ≈ 5 KB more flash than at
//! "s" (32 200 B in all).

#![no_std]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use fbg_firmware_app::Kernel;
use fbg_shared::{blob, Compensator, Error, Estimate, ModelParams, Sample};

include!(concat!(env!("OUT_DIR"), "/config.rs"));

/// `comp.step(s)` at opt-level 3 (see the crate docs).
#[inline(never)]
pub fn step(comp: &mut Compensator<f32, K>, s: &Sample<f32>) -> Estimate<f32> {
    comp.step(s)
}

/// `blob::decode_into(bytes, out)` (see the crate docs).
#[inline(never)]
pub fn decode(bytes: &[u8], out: &mut ModelParams<f32, K>) -> Result<(), Error> {
    blob::decode_into(bytes, out)
}

/// `comp.reload(params)` (see the crate docs).
#[inline(never)]
pub fn reload(comp: &mut Compensator<f32, K>, params: &ModelParams<f32, K>) -> Result<(), Error> {
    comp.reload(params)
}

/// All three, for `fbg_firmware_app`.
pub const KERNEL: Kernel<K> = Kernel { step, decode, reload };
