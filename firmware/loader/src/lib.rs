//! The model loader of the firmware: `Compensator::reload_blob` (`blob::decode_split`, then
//! the fold from the centres and Γ it leaves in the blob), instantiated once for this build's
//! capacity [`K`] behind a non-generic never-inlined function, alone in their crate so that
//! their opt-level is their own (`firmware/Cargo.toml`, profile): they run once per model
//! load, so their size (flash) and their stack depth during a model update matter, not their
//! speed. `fbg-firmware-kernel` hands them to the application with the step.

#![no_std]

use fbg_shared::{Compensator, Error};

include!(concat!(env!("OUT_DIR"), "/config.rs"));

/// `comp.reload_blob(bytes)` (see the crate docs): decode everything but the centres and Γ
/// into a parameter slot on this frame, read the centres and Γ from `bytes`, fold in place.
#[inline(never)]
pub fn load(comp: &mut Compensator<f32, K>, bytes: &[u8]) -> Result<(), Error> {
    comp.reload_blob(bytes)
}
