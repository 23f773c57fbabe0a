//! Puts the golden image's memory map (`memory-golden.x`: the part's RAM, a larger image
//! region) on the linker path of the verifier image, so that a verifier beyond the part's
//! flash still links and is measured.

// A build script runs on the host at build time: a bad environment stops the build with a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    let manifest = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let memory = manifest.join("../memory-golden.x");
    let dir = out.join("memory");
    fs::create_dir_all(&dir).expect("create the memory map directory");
    fs::copy(&memory, dir.join("memory.x")).expect("copy memory.x");
    println!("cargo:rustc-link-arg-bins=-L{}", dir.display());
    println!("cargo:rerun-if-changed={}", memory.display());
    // The signed model the image times (the bench's, `FBG_BENCH_SIGNED`; an empty file when
    // absent: the image then times an RFC 8032 vector) and the key it is signed with.
    println!("cargo:rerun-if-env-changed=FBG_BENCH_SIGNED");
    let signed = env::var_os("FBG_BENCH_SIGNED")
        .map(PathBuf::from)
        .unwrap_or_else(|| manifest.join("../../target/fixtures/bench_signed.fbgm"));
    println!("cargo:rerun-if-changed={}", signed.display());
    fs::write(out.join("bench_signed.fbgm"), fs::read(&signed).unwrap_or_default()).expect("write the signed model");
    let key = manifest.join("../keys/qemu-test.pub");
    println!("cargo:rerun-if-changed={}", key.display());
    fs::copy(&key, out.join("signer.pub")).expect("copy the QEMU test key");
    println!("cargo:rerun-if-changed=build.rs");
}
