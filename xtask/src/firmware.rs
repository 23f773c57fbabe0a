//! The firmware images (`firmware/`, its own workspace): their build environment and build,
//! the emulator that runs them, and a link session to the product image.

use std::path::{Path, PathBuf};

use anyhow::Result;

use crate::cmd::{cargo_own_target, run};
use crate::fixtures;
use crate::targets::THUMB;

pub mod emulator;
pub mod session;

/// Paths of the built images.
#[derive(Clone, Debug)]
pub struct Bins {
    /// The product image.
    pub product: PathBuf,
    /// Golden-vector image.
    pub golden: PathBuf,
    /// Fault-path image.
    pub fault: PathBuf,
    /// The product with rollbacks accepted (the bounded-rollback test).
    pub rollback: PathBuf,
    /// The product whose store flash loses power in a chosen operation (the torture test).
    pub torture: PathBuf,
}

/// The firmware workspace.
pub fn dir(root: &Path) -> PathBuf {
    root.join("firmware")
}

/// Environment of a firmware build: capacity `k`, the golden pack of the fixtures, and the
/// bench pack (`bench`; none for builds that do not run the bench: the bench image then embeds
/// an empty pack, as the build script does for a missing fixture, so that it links beside the
/// product whatever the golden pack's size). Paths only: `cargo xtask lint` checks the firmware
/// with the same environment as the build (no rebuild between them) before any fixture exists.
pub fn build_env(root: &Path, k: usize, bench: Option<&Path>) -> Vec<(String, String)> {
    let s = |p: &Path| p.display().to_string();
    vec![
        ("FBG_K".to_string(), k.to_string()),
        ("FBG_GOLDEN_PACK".to_string(), s(&fixtures::golden_pack(root))),
        ("FBG_BENCH_PACK".to_string(), bench.map(s).unwrap_or_default()),
        ("FBG_BENCH_SIGNED".to_string(), s(&fixtures::dir(root).join("bench_signed.fbgm"))),
    ]
}

/// Where the release images of the firmware land.
pub fn release_dir(root: &Path) -> PathBuf {
    dir(root).join("target").join(THUMB).join("release")
}

/// The target directory of the spectrum variant (`--features spectrum`), apart from the
/// default images' so that neither build evicts the other.
pub fn spectrum_target_dir(root: &Path) -> PathBuf {
    dir(root).join("target").join("spectrum")
}

/// Where the release images of the spectrum variant land.
pub fn spectrum_release_dir(root: &Path) -> PathBuf {
    spectrum_target_dir(root).join(THUMB).join("release")
}

/// Build the images `bins` (e.g. `fbg-firmware`, `bench`) with spectrum frames
/// (`--features spectrum`) into [`spectrum_target_dir`], capacity `k`, bench pack `bench`;
/// returns [`spectrum_release_dir`]. The default product is built without them: it is the one
/// measured against DESIGN's RAM budgets.
pub fn build_spectrum(root: &Path, k: usize, bench: Option<&Path>, bins: &[&str]) -> Result<PathBuf> {
    let mut c = cargo_own_target();
    c.current_dir(dir(root))
        .args(["build", "--release", "--locked", "--features", "spectrum", "--target-dir"])
        .arg(spectrum_target_dir(root));
    for b in bins {
        c.args(["--bin", b]);
    }
    run(c.envs(build_env(root, k, bench)))?;
    Ok(spectrum_release_dir(root))
}

/// The product image with spectrum frames, capacity `k` (the QEMU spectrum test's and the
/// second line of `cargo xtask size`).
pub fn build_spectrum_product(root: &Path, k: usize) -> Result<PathBuf> {
    Ok(build_spectrum(root, k, None, &["fbg-firmware"])?.join("fbg-firmware"))
}

/// Build every firmware image with capacity `k` (release profile), without spectrum frames.
pub fn build(root: &Path, k: usize, bench: Option<&Path>) -> Result<Bins> {
    run(cargo_own_target()
        .current_dir(dir(root))
        .args(["build", "--release", "--locked", "--bins"])
        .envs(build_env(root, k, bench)))?;
    let out = release_dir(root);
    Ok(Bins {
        product: out.join("fbg-firmware"),
        golden: out.join("golden"),
        fault: out.join("fault"),
        rollback: out.join("rollback"),
        torture: out.join("torture"),
    })
}
