//! `fbg-link`: the host side of the host ↔ device contract of the FBG compensator.
//!
//! - [`LinkClient`]: the lock-step client of a device's serial link ([`fbg_shared::protocol`])
//!   over any `std::io::Read + Write` (a TCP socket to QEMU, a serial port, a pipe in tests);
//! - [`parity`]: when a device's answer counts as the host's ([`parity::compare`]: within a
//!   tolerance per channel, NaN for NaN, ∞ for ∞, identical flags), for `fbg-trainer stream`
//!   and the firmware's QEMU tests alike;
//! - [`golden`]: the golden-vector files the trainer writes and the firmware tests read (the
//!   samples' byte layout itself is [`fbg_shared::golden`], which the device reads too).
//!
//! - [`spectrum`]: spectrum frames over the link (the detector's set-up, frames in chunks)
//!   and the host's own reading of the same frames, for the device-vs-host check.
//!
//! `fbg-shared` stays device code (no_std, no heap); everything std lives here.

mod client;
pub mod golden;
pub mod parity;
pub mod spectrum;

pub use client::{LinkClient, LinkError, ReadTimeout};
