//! `fbg-trainer`: simulate FBG installations, fit and evaluate the hybrid compensator, export
//! models for the `fbg-shared` inference.

pub mod dataset;
pub mod fit;
pub mod error;
pub mod import;
pub mod evaluate;
pub mod meta;
pub mod metrics;
pub mod rng;
pub mod scenario;
pub mod sim;
pub mod study;
pub mod parity;
pub mod report;
pub mod recalibrate;
pub mod tables;
pub mod export;
pub mod benchmark;
pub mod fleet;
pub mod stream;

pub use error::TrainerError;
