//! `fbg-testkit`: the fixtures the tests, the benches and `cargo xtask` build models and
//! samples with, written once.
//!
//! - [`Rng`]: SplitMix64, the one deterministic generator of every test, bench and fixture;
//! - [`models`]: random, valid models of any feature set, capacity and provenance length, with
//!   or without memory terms (the codec and inference tests of `fbg-shared`);
//! - [`installation`]: a synthetic FBG installation (gauge matrix, trajectories with turning
//!   points, noise) and the hysteresis-aware models fitted to it by construction, with every
//!   slot of the memory bank in use or none (the firmware's golden vectors and bench models,
//!   the host inference bench);
//! - `modules` (feature `modules`): no import circle among a crate's files, for the crates'
//!   own tests.
//!
//! Host-only (std); nothing here runs on the device.
//!
//! ```
//! use fbg_testkit::{installation, Rng};
//!
//! let mut rng = Rng::new(7);
//! let u = rng.unit();
//! assert!((0.0..1.0).contains(&u));
//! let model = installation::synthetic_params(16, 1).expect("valid by construction");
//! assert_eq!(model.centres.len(), 16);
//! ```

pub mod installation;
pub mod models;
#[cfg(feature = "modules")]
pub mod modules;
mod rng;

pub use rng::Rng;
