//! Build script of the firmware:
//!
//! - puts the top-level `memory.x` on the linker search path of every image but `golden`
//!   (cortex-m-rt's `link.x` includes it), so a build that would not fit the co-processor
//!   fails to link; `golden`, whose test vectors do not fit the part, links with
//!   `memory-golden.x`;
//! - writes an empty `device.x` (cortex-m-rt's `device` feature; the interrupt table is the
//!   image's own, `__INTERRUPTS` in `src/lib.rs`);
//! - copies the test fixtures the test binaries embed into `OUT_DIR` (an empty file when a
//!   fixture is absent, so the product binary always builds): `FBG_GOLDEN_PACK` and
//!   `FBG_BENCH_PACK` (paths; defaults under `../target/fixtures/`, which `cargo xtask
//!   fixtures` makes with the trainer), each a pack of models and samples (`fbg_shared::golden`),
//!   and `FBG_BENCH_SIGNED`, a model signed with the QEMU test key whose verification the bench
//!   image times.
//!
//! The signature policy compiled into the images (`trust.rs`: the trusted public keys from the
//! files named by `FBG_TRUSTED_KEYS` (comma-separated; each file holds one or more raw 32-byte
//! Ed25519 public keys back to back, as `fbg-trainer keygen` writes `lab.pub`, or their hex, as
//! in `lab.pub.hex`; default `keys/qemu-test.pub`, the committed TEST key, not for
//! production), `FBG_ALLOW_ROLLBACK` (default 0: every rollback is refused; 1: a rollback,
//! signed with the allow-rollback flag and the one serial it may replace, is accepted while
//! that serial runs) and `FBG_REQUIRE_SIGNED_DEFAULT` (default 0: the embedded model is
//! trusted as part of the image; 1: it must be signed by a trusted key too, or the image
//! refuses to start)) is the device crate's build script's (`device/build.rs`), every board's.
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

    // Each image links with its own `memory.x` (cortex-m-rt's `link.x` includes the one the
    // linker finds first, so no map is on the search path of every image): the top-level
    // memory.x, the part's budget, for every image but `golden`, whose pack of test vectors is
    // beyond that budget (`memory-golden.x` says why). The image names come from Cargo.toml.
    let memory = manifest.join("../memory.x");
    let golden_memory = manifest.join("memory-golden.x");
    // An older build script copied the map to OUT_DIR itself, on every image's search path.
    let _ = fs::remove_file(out.join("memory.x"));
    let cargo_toml = fs::read_to_string(manifest.join("Cargo.toml")).expect("read Cargo.toml");
    for bin in bin_names(&cargo_toml) {
        let map = if bin == "golden" { &golden_memory } else { &memory };
        let dir = out.join("memory").join(&bin);
        fs::create_dir_all(&dir).expect("create the image's memory map directory");
        fs::copy(map, dir.join("memory.x")).expect("copy the image's linker memory map");
        println!("cargo:rustc-link-arg-bin={bin}=-L{}", dir.display());
    }
    println!("cargo:rerun-if-changed={}", golden_memory.display());
    println!("cargo:rerun-if-changed=Cargo.toml");
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
        ("FBG_BENCH_SIGNED", fixtures.join("bench_signed.fbgm"), "bench_signed.fbgm"),
    ] {
        println!("cargo:rerun-if-env-changed={var}");
        let src = env::var_os(var).map(PathBuf::from).unwrap_or(default);
        let bytes = fs::read(&src).unwrap_or_default();
        // A missing file counts as changed, so the copy refreshes once it appears.
        println!("cargo:rerun-if-changed={}", src.display());
        fs::write(out.join(name), bytes).expect("write fixture copy");
    }
}

/// The `name`s of the `[[bin]]` tables of Cargo.toml.
fn bin_names(cargo_toml: &str) -> Vec<String> {
    let mut names = Vec::new();
    let mut in_bin = false;
    for line in cargo_toml.lines().map(str::trim) {
        if line.starts_with('[') {
            in_bin = line == "[[bin]]";
        } else if let Some(v) = line.strip_prefix("name").map(str::trim).and_then(|v| v.strip_prefix('=')) {
            if in_bin {
                names.push(v.trim().trim_matches('"').to_string());
            }
        }
    }
    assert!(!names.is_empty(), "Cargo.toml names no [[bin]]");
    names
}
