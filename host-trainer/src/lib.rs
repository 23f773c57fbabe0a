//! `fbg-trainer`: simulate FBG installations, fit and evaluate the hybrid compensator, export
//! models for the `fbg-shared` inference.

pub mod benchmark;
pub mod dataset;
pub mod error;
pub mod evaluate;
pub mod export;
pub mod fit;
pub mod fleet;
pub mod import;
pub mod meta;
pub mod metrics;
pub mod parity;
pub mod recalibrate;
pub mod report;
pub mod rng;
pub mod scenario;
pub mod shard;
pub mod sim;
pub mod stream;
pub mod study;
pub mod tables;

pub use error::TrainerError;
