//! Writes `config.rs` with the centre capacity `K` of this build (env `FBG_K`, default 32).

// A build script runs on the host at build time: a bad environment stops the build with a panic.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::env;
use std::fs;
use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=FBG_K");
    let k: usize = match env::var("FBG_K") {
        Ok(v) => v.trim().parse().unwrap_or_else(|_| panic!("FBG_K must be a number of centres, got `{v}`")),
        Err(_) => 32,
    };
    assert!((1..=256).contains(&k), "FBG_K = {k} is outside 1..=256");
    fs::write(
        out.join("config.rs"),
        format!(
            "/// Centre capacity of this build (env `FBG_K` at build time, default 32).\npub const K: usize = {k};\n"
        ),
    )
    .expect("write config.rs");
}
