//! No code: see Cargo.toml.
#![no_std]
