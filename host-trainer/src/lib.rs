//! `fbg-trainer`: simulate FBG installations, fit and evaluate the hybrid compensator, export
//! models for the `fbg-shared` inference.
//!
//! The modules follow the data (ARCHITECTURE.md):
//!
//! ```text
//! data (CSV, import) ─┐
//! sim (scenario) ─────┴─> fit ─> eval ─> export ─> report
//!                                                  fleet, stream, benchmark
//! ```
//!
//! Each module uses only the ones before it in this list; `error`, `rng` and `stats` are used by
//! all. The command line (`src/cli/`) is the binary and uses the library only.

// Foundations.
pub mod error;
pub mod rng;
pub mod stats;

// The pipeline.
pub mod data;
pub mod eval;
pub mod export;
pub mod fit;
pub mod report;
pub mod sim;

// Operations built on the pipeline.
pub mod benchmark;
pub mod fleet;
pub mod stream;

pub use error::TrainerError;
