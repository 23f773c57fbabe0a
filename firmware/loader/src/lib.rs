//! The model loader of the firmware: `blob::decode_into` and `Compensator::reload`, instantiated
//! once for this build's capacity [`K`] behind non-generic never-inlined functions, alone in
//! their crate so that their opt-level is their own (`firmware/Cargo.toml`, profile): they run
//! once per model load, so their size (flash) and their stack depth during a model update
//! matter, not their speed. `fbg-firmware-kernel` hands them to the application with the step.

#![no_std]

use fbg_shared::{blob, Compensator, Error, ModelParams};

include!(concat!(env!("OUT_DIR"), "/config.rs"));

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
