//! The firmware images (`firmware/`, its own workspace): their build environment and build,
//! the emulator that runs them, and a link session to the product image.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use crate::cmd::{cargo_own_target, run};
use crate::fixtures;
use crate::targets::THUMB;

pub mod emulator;
pub mod golden;
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
    /// The bench image (without a bench pack here).
    pub bench: PathBuf,
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

/// Where cargo puts the release images of the firmware (every variant's, under the same
/// names: see [`build`]).
pub fn release_dir(root: &Path) -> PathBuf {
    dir(root).join("target").join(THUMB).join("release")
}

/// Where the images of one variant (`default`, `spectrum`) are kept once built.
fn images_dir(root: &Path, variant: &str) -> PathBuf {
    dir(root).join("target").join("images").join(variant)
}

/// Every image of the firmware package.
const IMAGES: [&str; 6] = ["fbg-firmware", "golden", "bench", "rollback", "torture", "fault"];

/// Build the images `bins` of one variant (`spectrum`: with spectrum frames) with capacity `k`
/// and bench pack `bench`, and copy them to [`images_dir`]. Both variants build in the one
/// target directory, so that they share their dependencies' builds; cargo leaves either's
/// images under the same names in [`release_dir`], where the other's next build replaces them
/// (hence the copies).
fn build_variant(root: &Path, k: usize, bench: Option<&Path>, spectrum: bool, bins: &[&str]) -> Result<PathBuf> {
    let mut c = cargo_own_target();
    c.current_dir(dir(root)).args(["build", "--release", "--locked"]);
    if spectrum {
        c.args(["--features", "spectrum"]);
    }
    for b in bins {
        c.args(["--bin", b]);
    }
    run(c.envs(build_env(root, k, bench)))?;
    let out = images_dir(root, if spectrum { "spectrum" } else { "default" });
    fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    for b in bins {
        let to = out.join(b);
        fs::copy(release_dir(root).join(b), &to).with_context(|| format!("copying {b} to {}", to.display()))?;
    }
    Ok(out)
}

/// Build the images `bins` (e.g. `fbg-firmware`, `bench`) with spectrum frames
/// (`--features spectrum`), capacity `k`, bench pack `bench`; returns the directory they are
/// kept in. The default product is built without them: it is the one measured against
/// DESIGN's RAM budgets.
pub fn build_spectrum(root: &Path, k: usize, bench: Option<&Path>, bins: &[&str]) -> Result<PathBuf> {
    build_variant(root, k, bench, true, bins)
}

/// The product image with spectrum frames, capacity `k` (the QEMU spectrum test's and the
/// second line of `cargo xtask size`).
pub fn build_spectrum_product(root: &Path, k: usize) -> Result<PathBuf> {
    Ok(build_spectrum(root, k, None, &["fbg-firmware"])?.join("fbg-firmware"))
}

/// Build every firmware image with capacity `k` (release profile), without spectrum frames.
pub fn build(root: &Path, k: usize, bench: Option<&Path>) -> Result<Bins> {
    let out = build_variant(root, k, bench, false, &IMAGES)?;
    Ok(Bins {
        product: out.join("fbg-firmware"),
        golden: out.join("golden"),
        fault: out.join("fault"),
        rollback: out.join("rollback"),
        torture: out.join("torture"),
        bench: out.join("bench"),
    })
}

/// Only the golden image, capacity `k`, without spectrum frames (the fast tier's).
pub fn build_golden(root: &Path, k: usize) -> Result<PathBuf> {
    Ok(build_variant(root, k, None, false, &["golden"])?.join("golden"))
}
