//! `fbg-shared`: the one implementation of hybrid FBG compensation inference.
//!
//! `#![no_std]`, no heap, no panicking paths. The same generic code runs in `f32` on the
//! interrogator's Cortex-M4F and in `f64` in the host trainer, so host and device can only
//! differ by rounding.
//!
//! - [`layout`]: fixed dimensions and the feature layout;
//! - [`direction_latch`]: the stateful hysteresis-aware feature;
//! - [`memory`]: the instrument's memory, causal operators whose terms enter Model-H linearly;
//! - [`model`]: the auditable parameters a blob carries, within [`bounds`]; [`field`]: what a field reading needs
//!   (each grating's zero λ_ref, the calibration's absolute clock, the output envelope);
//! - [`clock`]: how a stream's sample times give the band's lead time;
//! - [`blob`]: the `.fbgm` codec (magic, version, dims, postcard payload, CRC-32);
//! - [`container`]: a model file, a blob with or without a signature trailer, split;
//! - [`crc32c`]: the CRC-32/ISCSI of blobs and link frames;
//! - [`signature`]: the signature trailer of a signed blob (layout, parse, the signed message;
//!   Ed25519 verification with the `verify` feature);
//! - [`compensator`]: per-sample inference with band and flags: an immutable
//!   [`PreparedModel`] stepped over a stream's [`StreamState`], or the two as a [`Compensator`];
//! - [`flags`]: the fault flags;
//! - [`spectrum`]: peak detection in a spectrum (search windows, noise floor, maximum,
//!   centroid, Gaussian 3-point and least-squares fits, cross-correlation, quality flags);
//! - [`protocol`]: the COBS-framed postcard messages of the host ↔ device serial link;
//! - [`golden`]: the byte layout of the golden samples and packs the device is tested with.
//!
//! Linear algebra: the core's B·φ is a nalgebra fixed-size matrix–vector product (no heap,
//! no std); the RBF distances, Γm and the standardisation stay loops over arrays, where
//! nalgebra measured slower on the device (docs/DESIGN.md §7.1).
//!
//! # Cost of one `step` (K centres, `Z_DIMS` = 8, `VAR_RANK` = 4)
//!
//! Floating-point operations of the current [`Compensator::step`] after load-time folding, in
//! f32 as the device runs it, with the default (hysteresis-aware) feature set (a multiply-add
//! counts as one; the centre loop skips the time input that set does not use, so the `paper`
//! set costs one more multiply-add per centre):
//!
//! | part | operations | K = 32 |
//! |---|---|---|
//! | finiteness checks (Δλ1..3, T_amb, t) | 5 | 5 |
//! | direction latches: 3 × (scale, 2 converts, remainder, 2 compares, ≈ 4 integer compare/select) | 30 | 30 |
//! | envelope checks | 8 compares | 8 |
//! | stage 1 (3 × 5, scalers folded) | 12 mul-add | 12 |
//! | φ (6 products) + B (3 × 10) | 6 mul + 30 mul-add | 36 |
//! | z scaling (8 inputs, σ folded) and ‖z‖² | 8 + 8 mul-add | 16 |
//! | distance per centre, expanded: ‖z‖² + ‖μ‖² + z·(−2μ) over the 7 used inputs | 1 add + 7 mul-add | 256 |
//! | `exp(−d²)` per centre ([`real::exp_neg_f32`]: magic-number rounding, degree-5 polynomial) | 1 compare, 9 mul-add, 1 subtract, 1 negate, 2 exponent-field ops | 448 |
//! | Wψ (3), variance projections (4), ‖ψ‖² (1) per centre | 8 mul-add | 256 |
//! | weak support from ‖ψ‖² (2 products, 2 compares; a second ψ pass only near the threshold), leverage (1 mul + 4 mul-add) | 9 | 9 |
//! | output finiteness, lead time, 3 bands (mul-add, add, mul, sqrt, mul) | 3 + 2 + 15 | 20 |
//! | **total** | **30 K + 136** | **1 096** |
//!
//! (K = 16: 616; K = 64: 2 056.) Each centre also loads 15 words (−2μ without time, ‖μ‖², w,
//! v). Each operation is at least one instruction on a Cortex-M4F, so the count is the
//! arithmetic lower bound that the firmware's measured instructions per step are compared with
//! (`cargo xtask bench`, `BENCHMARKS.md`).

#![no_std]

#[cfg(test)]
extern crate std;

mod affine;
pub mod blob;
pub mod bounds;
pub mod clock;
pub mod compensator;
pub mod container;
pub mod crc32c;
pub mod direction_latch;
pub mod error;
pub mod field;
pub mod flags;
mod frame;
pub mod golden;
pub mod layout;
pub mod memory;
pub mod model;
pub mod protocol;
pub mod real;
pub mod signature;
pub mod spectrum;
pub mod trust;

pub use clock::StreamClock;
pub use compensator::{Compensator, Estimate, Pending, PreparedModel, Sample, StreamState};
pub use direction_latch::{ticks, DirectionLatch, LatchBank};
pub use error::Error;
pub use field::{FieldContext, ZeroSource};
pub use flags::{Flags, UnknownFlags};
pub use layout::FeatureSet;
pub use memory::{MemoryBank, MemoryGroup, MemoryOperators, MemorySpec, MemoryState};
pub use model::{Centre, Hyper, ModelParams, Provenance};
pub use real::Real;
pub use trust::TrustSpec;
