//! The fuzz target of `fbg-shared` (`shared/fuzz`, its own workspace), on the stable toolchain:
//! the libFuzzer binary built with the coverage instrumentation cargo-fuzz would add (stable
//! codegen flags; no sanitizer, which needs a nightly), run over the versioned seeds and then
//! for a bounded, seeded number of inputs.

use std::fs;
use std::path::Path;
use std::process::Command;

use anyhow::{Context, Result};

use crate::cmd::{cargo_own_target, host_triple, run, step};

/// Inputs the fuzzer runs in `lint` (seconds on two cores).
const RUNS: u32 = 100_000;
/// Longest input (a K = 32 blob with provenance and signature fits).
const MAX_LEN: u32 = 4096;

/// cargo-fuzz's instrumentation for libFuzzer (`--sanitizer none`), as `CARGO_ENCODED_RUSTFLAGS`
/// (the variable cargo reads first). `--target` is given so that they reach the target's code
/// and not the build scripts.
const INSTRUMENT: [&str; 9] = [
    "-Cpasses=sancov-module",
    "-Cllvm-args=-sanitizer-coverage-level=4",
    "-Cllvm-args=-sanitizer-coverage-inline-8bit-counters",
    "-Cllvm-args=-sanitizer-coverage-pc-table",
    "-Cllvm-args=-sanitizer-coverage-trace-compares",
    "--cfg",
    "fuzzing",
    "-Cdebug-assertions",
    "-Coverflow-checks",
];

/// Build the instrumented target and run it over the seeds and beyond.
pub(super) fn check(root: &Path) -> Result<()> {
    step("lint: the fuzz target of fbg-shared (corpus replayed; built with coverage and run on stable)");
    let dir = root.join("shared/fuzz");
    // Its own workspace and target directory, whatever CARGO_TARGET_DIR says. Its corpus test
    // (`cargo test` there, for toolchains without libFuzzer) is not run: libFuzzer replays every
    // seed through the same checks before it mutates any.
    let triple = host_triple()?;
    run(cargo_own_target()
        .current_dir(&dir)
        .args(["build", "--release", "--locked", "--bin", "decode", "--target", &triple])
        .args(["--target-dir", "target/fuzz"])
        .env_remove("RUSTFLAGS")
        .env("CARGO_ENCODED_RUSTFLAGS", INSTRUMENT.join("\u{1f}")))?;
    let out = dir.join("target/fuzz");
    // A scratch corpus seeded with the versioned seeds: what the run finds is not kept.
    let corpus = out.join("corpus");
    let _ = fs::remove_dir_all(&corpus);
    fs::create_dir_all(&corpus)?;
    let seeds = dir.join("corpus/decode");
    for e in fs::read_dir(&seeds).with_context(|| format!("reading {}", seeds.display()))? {
        let p = e?.path();
        if p.file_name().and_then(|n| n.to_str()).is_some_and(|n| n.starts_with("seed-")) {
            fs::copy(&p, corpus.join(p.file_name().unwrap_or_default()))?;
        }
    }
    let artifacts = out.join("artifacts");
    fs::create_dir_all(&artifacts)?;
    run(Command::new(out.join(&triple).join("release/decode"))
        .arg(&corpus)
        .arg(format!("-runs={RUNS}"))
        .arg(format!("-max_len={MAX_LEN}"))
        .arg("-seed=1")
        .arg(format!("-artifact_prefix={}/", artifacts.display())))
    .with_context(|| format!("the fuzz target failed; the input is in {}", artifacts.display()))
}
