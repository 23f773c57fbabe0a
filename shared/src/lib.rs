//! `fbg-shared`: the one implementation of hybrid FBG compensation inference.
//!
//! `#![no_std]`, no heap, no panicking paths. The same generic code runs in `f32` on the
//! interrogator's Cortex-M4F and in `f64` in the host trainer, so host and device can only
//! differ by rounding.
//!
//! - [`layout`]: fixed dimensions and the feature layout;
//! - [`direction_latch`]: the stateful hysteresis-aware feature;
//! - [`model`]: the auditable parameters a blob carries;
//! - [`blob`]: the `.fbgm` codec (magic, version, dims, postcard payload, CRC-32);
//! - [`compensator`]: per-sample inference with band and flags;
//! - [`flags`]: the fault flags;
//! - [`protocol`]: the COBS-framed postcard messages of the host ↔ device serial link;
//! - `link_client` (feature `std`): the host side of that link over any `Read + Write`.
//!
//! # Cost of one `step` (K centres, `Z_DIMS` = 8, `VAR_RANK` = 8)
//!
//! Floating-point operations after load-time folding (a fused multiply-add counts as one):
//!
//! | part | operations | K = 32 |
//! |---|---|---|
//! | finiteness + envelope checks | 5 + 8 compares | 13 |
//! | stage 1 (3 × 5, scalers folded) | 12 fma | 12 |
//! | φ (6 products) + B (3 × 10) | 6 mul + 30 fma | 36 |
//! | z scaling (8 inputs, σ folded) | 8 fma | 8 |
//! | distance per centre | 8 sub + 8 fma | 512 |
//! | `exp(−d²)` per centre | ≈ 10 (6 fma + 4) | 320 |
//! | Wψ, variance projections, ‖ψ‖², max per centre | 3 + 8 + 1 fma + 1 max | 416 |
//! | leverage + 3 bands | 8 fma + 3 × (2 mul + sqrt) | 17 |
//! | **total** | ≈ 40 K + 100 | ≈ 1 330 |
//!
//! Each operation costs about one instruction plus its operand load on a Cortex-M4F, so the
//! count is the lower bound the firmware's measured instructions per step are compared with.

#![no_std]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

#[cfg(feature = "std")]
extern crate std;

pub mod blob;
pub mod compensator;
pub mod direction_latch;
pub mod error;
pub mod flags;
pub mod layout;
pub mod model;
pub mod protocol;
#[cfg(feature = "std")]
pub mod link_client;
pub mod real;

pub use compensator::{rbf_activation, Compensator, Estimate, Sample};
pub use direction_latch::{ticks, DirectionLatch, LatchBank};
pub use error::Error;
pub use flags::Flags;
pub use layout::FeatureSet;
pub use model::{Centre, Hyper, ModelParams, Provenance};
pub use real::Real;
