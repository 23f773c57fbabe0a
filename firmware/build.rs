//! Build script of the firmware:
//!
//! - puts the top-level `memory.x` on the linker search path (cortex-m-rt's `link.x` includes
//!   it), so a build that would not fit the co-processor fails to link;
//! - writes an empty `device.x` (cortex-m-rt's `device` feature; the interrupt table is the
//!   image's own, `__INTERRUPTS` in `src/lib.rs`);
//! - copies the test fixtures the test binaries embed into `OUT_DIR` (an empty file when a
//!   fixture is absent, so the product binary always builds): `FBG_GOLDEN_PACK` and
//!   `FBG_BENCH_PACK` (paths; defaults under `../target/fixtures/`, which `cargo xtask
//!   fixtures` makes with the trainer), each a pack of models and samples (`fbg_shared::golden`).
//!
//! The centre capacity `K` (env `FBG_K`, default 32) is `fbg-firmware-kernel`'s.

// A build script runs on the host at build time: a bad environment stops the build with a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));

    let memory = manifest.join("../memory.x");
    fs::copy(&memory, out.join("memory.x")).expect("copy ../memory.x (the top-level linker memory map)");
    // cortex-m-rt's `device` feature includes `device.x` (weak interrupt handler names, which a
    // PAC would provide): this firmware names none, its table (`__INTERRUPTS`) points every
    // line to `DefaultHandler`.
    fs::write(out.join("device.x"), "/* no named device interrupt handlers: see __INTERRUPTS in src/lib.rs */\n")
        .expect("write device.x");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    println!("cargo:rerun-if-changed=build.rs");

    let fixtures = manifest.join("../target/fixtures");
    for (var, default, name) in [
        ("FBG_GOLDEN_PACK", fixtures.join("golden_pack.bin"), "golden_pack.bin"),
        ("FBG_BENCH_PACK", fixtures.join("bench_pack_k32.bin"), "bench_pack.bin"),
    ] {
        println!("cargo:rerun-if-env-changed={var}");
        let src = env::var_os(var).map(PathBuf::from).unwrap_or(default);
        let bytes = fs::read(&src).unwrap_or_default();
        // A missing file counts as changed, so the copy refreshes once it appears.
        println!("cargo:rerun-if-changed={}", src.display());
        fs::write(out.join(name), bytes).expect("write fixture copy");
    }
}
