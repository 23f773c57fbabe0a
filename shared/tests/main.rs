//! fbg-shared's integration tests, one module per subject, linked as one test binary
//! (`cargo test -p fbg-shared --test shared [module::test]`): one binary builds the
//! compensator's generic code once where thirteen binaries built it thirteen times.

// A test crate: clippy.toml allows the panicking shorthand in #[test] functions, not in
// the helpers around them.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

mod common;

mod batch;
mod blob;
mod blob_validation;
mod compensator;
mod memory;
mod memory_terms;
mod modules;
mod plausibility;
#[cfg(all(feature = "verify", feature = "key-id"))]
mod signature;
mod spectrum;
mod spectrum_template;
mod stream_state;
mod trust;
