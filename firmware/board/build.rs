//! Build script of the board images:
//!
//! - puts this crate's memory map on the linker search path as `memory.x` (cortex-m-rt's
//!   `link.x` includes it): `memory.x` for the part, `memory-emulator.x` with the `emulator`
//!   feature (the model store in RAM, as QEMU's flash is ROM); the interrupt table's
//!   `device.x` is the PAC's (`stm32f4`, feature `rt`);
//! - copies the golden pack the golden image embeds (`FBG_GOLDEN_PACK`, default
//!   `../../target/fixtures/golden_pack.bin`; an empty file when absent, so the product always
//!   builds).
//!
//! The signature policy (`FBG_TRUSTED_KEYS`, …) is the device crate's build script's, every
//! board's; the centre capacity `K` (env `FBG_K`, default 32) is `fbg-firmware-kernel`'s.

// A build script runs on the host at build time: a bad environment stops the build with a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));

    let map = if env::var_os("CARGO_FEATURE_EMULATOR").is_some() { "memory-emulator.x" } else { "memory.x" };
    fs::copy(manifest.join(map), out.join("memory.x")).expect("copy the board's memory map");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=memory-emulator.x");
    println!("cargo:rerun-if-changed=build.rs");

    println!("cargo:rerun-if-env-changed=FBG_GOLDEN_PACK");
    let src = env::var_os("FBG_GOLDEN_PACK")
        .map(PathBuf::from)
        .unwrap_or_else(|| manifest.join("../../target/fixtures/golden_pack.bin"));
    let bytes = fs::read(&src).unwrap_or_default();
    // A missing file counts as changed, so the copy refreshes once it appears.
    println!("cargo:rerun-if-changed={}", src.display());
    fs::write(out.join("golden_pack.bin"), bytes).expect("write fixture copy");
}
