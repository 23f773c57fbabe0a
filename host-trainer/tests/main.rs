//! The trainer's integration tests, one module per subject, linked as one test binary
//! (`cargo test --release -p fbg-trainer --test trainer [module::test]`): one binary builds the
//! library's generic code once where thirty binaries built it thirty times.

// A test crate: clippy.toml allows the panicking shorthand in #[test] functions, not in
// the helpers around them.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

mod common;

mod bounded;
mod checks;
mod cli;
mod cli_apart;
mod compensate;
mod evaluate_stream;
mod field;
mod fit;
mod fleet;
mod import;
mod import_spectra;
mod layout;
mod modules;
mod outputs;
mod physics;
mod pipes;
mod plausibility;
mod presets;
mod recalibrate;
mod record_sidecar;
mod report;
mod sensitivity;
mod shapes;
mod signing;
mod simulator;
mod spectra_round_trip;
mod spectrum_chain;
mod spectrum_sim;
mod static_fidelity;
mod trust;
mod warnings;
