//! `cargo xtask lint` (also the first step of `cargo xtask test`): formatting, clippy on every
//! crate and target, rustdoc with warnings denied, and the MSRV check.
//!
//! The MSRV cannot be checked by building with the old toolchain: CI machines have one Rust
//! toolchain and reach no toolchain server. It is checked from both sides instead:
//! - *dependencies*: every package's declared `rust-version` is at least the largest
//!   `rust-version` in its locked dependency closure (`cargo metadata --locked`), and no larger
//!   than the toolchain in use;
//! - *our code*: clippy's `incompatible_msrv` lint (on by default, denied here with every other
//!   warning) reads the same `rust-version` and rejects standard-library items stabilised later.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};
use serde_json::Value;

use crate::{cargo, firmware_cargo, run, step};

/// Every lint of both workspaces (host and firmware).
pub fn run_all(root: &Path) -> Result<()> {
    step("lint: rustfmt --check (host and firmware workspaces)");
    run(cargo().current_dir(root).args(["fmt", "--all", "--check"]))?;
    run(firmware_cargo().current_dir(root.join("firmware")).args(["fmt", "--all", "--check"]))?;

    step("lint: clippy on every crate and target of the host workspace, warnings denied");
    run(cargo().current_dir(root).args([
        "clippy",
        "--workspace",
        "--all-targets",
        "--locked",
        "--",
        "-D",
        "warnings",
    ]))?;
    // fbg-shared as the device sees it (thumb target), without and with the defmt feature
    // (derived `defmt::Format`, as firmware that logs with defmt builds it).
    for features in [&[][..], &["--features", "defmt"][..]] {
        run(cargo()
            .current_dir(root)
            .args(["clippy", "-p", "fbg-shared", "--target", "thumbv7em-none-eabihf", "--locked"])
            .args(features)
            .args(["--", "-D", "warnings"]))?;
    }

    step("lint: rustdoc of the host workspace, warnings denied");
    run(cargo()
        .current_dir(root)
        .args(["doc", "--workspace", "--no-deps", "--locked"])
        .env("RUSTDOCFLAGS", "-D warnings"))?;

    step("lint: MSRV (declared rust-version against the locked dependencies and the toolchain)");
    let toolchain = rustc_version()?;
    check_msrv(&cargo_metadata(cargo().current_dir(root))?, toolchain, "host workspace")?;
    check_msrv(&cargo_metadata(firmware_cargo().current_dir(root.join("firmware")))?, toolchain, "firmware workspace")?;

    step("lint: deploy files (Slurm job script syntax, Kubernetes Job against the API schema)");
    deploy_files(root)?;
    Ok(())
}

/// The pinned offline validator of Kubernetes manifests (JSON schemas of every API version ship
/// inside the package; no cluster or network at validation time).
const KUBERNETES_VALIDATE: &str = "kubernetes-validate==1.37.0";

fn deploy_files(root: &Path) -> Result<()> {
    run(Command::new("bash").arg("-n").arg(root.join("deploy/slurm/fleet.sbatch")))?;
    let venv = root.join("target/deploy-venv");
    let tool = venv.join("bin/kubernetes-validate");
    if !tool.exists() {
        run(Command::new("python3").args(["-m", "venv"]).arg(&venv))
            .context("creating a Python venv for kubernetes-validate (needs python3 with venv)")?;
        run(Command::new(venv.join("bin/pip")).args(["install", "-q", KUBERNETES_VALIDATE]))
            .context("installing kubernetes-validate from PyPI")?;
    }
    run(Command::new(&tool)
        .args(["--strict", "--kubernetes-version", "1.33"])
        .arg(root.join("deploy/kubernetes/fleet-job.yaml")))
}

/// A `major.minor[.patch]` version, compared numerically.
type Version = (u64, u64, u64);

fn parse_version(s: &str) -> Option<Version> {
    let mut it = s.trim().split('.').map(|p| p.parse::<u64>().ok());
    let major = it.next()??;
    let minor = it.next().unwrap_or(Some(0))?;
    let patch = it.next().unwrap_or(Some(0))?;
    Some((major, minor, patch))
}

fn show(v: Version) -> String {
    format!("{}.{}.{}", v.0, v.1, v.2)
}

fn rustc_version() -> Result<Version> {
    let out = Command::new(std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into()))
        .arg("--version")
        .output()
        .context("running rustc --version")?;
    let text = String::from_utf8_lossy(&out.stdout);
    // "rustc 1.95.0 (59807616e 2026-04-14)"
    text.split_whitespace()
        .nth(1)
        .and_then(|v| parse_version(v.split('-').next().unwrap_or(v)))
        .with_context(|| format!("cannot read the toolchain version from `{}`", text.trim()))
}

fn cargo_metadata(cmd: &mut Command) -> Result<Value> {
    let out = cmd.args(["metadata", "--locked", "--format-version", "1"]).output().context("running cargo metadata")?;
    if !out.status.success() {
        bail!("cargo metadata failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    serde_json::from_slice(&out.stdout).context("parsing cargo metadata")
}

/// Each workspace member's declared `rust-version` against its locked dependency closure and
/// the toolchain.
fn check_msrv(meta: &Value, toolchain: Version, what: &str) -> Result<()> {
    let empty = Vec::new();
    let packages = meta["packages"].as_array().unwrap_or(&empty);
    let by_id: BTreeMap<&str, &Value> = packages.iter().filter_map(|p| Some((p["id"].as_str()?, p))).collect();
    let deps: BTreeMap<&str, Vec<&str>> = meta["resolve"]["nodes"]
        .as_array()
        .unwrap_or(&empty)
        .iter()
        .filter_map(|n| {
            let id = n["id"].as_str()?;
            // Normal and build dependencies: dev-dependencies do not bind the users' toolchain.
            let d = n["deps"]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter(|d| {
                            d["dep_kinds"]
                                .as_array()
                                .is_none_or(|k| k.iter().any(|k| k["kind"].as_str() != Some("dev")))
                        })
                        .filter_map(|d| d["pkg"].as_str())
                        .collect()
                })
                .unwrap_or_default();
            Some((id, d))
        })
        .collect();
    let mut problems = Vec::new();
    for member in meta["workspace_members"].as_array().unwrap_or(&empty).iter().filter_map(Value::as_str) {
        let Some(pkg) = by_id.get(member) else { continue };
        let name = pkg["name"].as_str().unwrap_or(member);
        let Some(declared) = pkg["rust_version"].as_str().and_then(parse_version) else {
            problems.push(format!("{name} declares no rust-version"));
            continue;
        };
        if declared > toolchain {
            problems.push(format!(
                "{name} declares rust-version {} but the toolchain is {}",
                show(declared),
                show(toolchain)
            ));
        }
        // The closure of its normal and build dependencies, every platform (the lock pins them all).
        let mut seen = BTreeSet::new();
        let mut todo = vec![member];
        let mut needs: Option<(Version, String)> = None;
        while let Some(id) = todo.pop() {
            if !seen.insert(id) {
                continue;
            }
            if let Some(p) = by_id.get(id).filter(|_| id != member) {
                if let Some(v) = p["rust_version"].as_str().and_then(parse_version) {
                    if needs.as_ref().is_none_or(|n| v > n.0) {
                        needs = Some((
                            v,
                            format!("{} {}", p["name"].as_str().unwrap_or(""), p["version"].as_str().unwrap_or("")),
                        ));
                    }
                }
            }
            todo.extend(deps.get(id).into_iter().flatten().copied());
        }
        match needs {
            Some((v, who)) if v > declared => problems.push(format!(
                "{name} declares rust-version {} but its locked dependency {who} needs {}",
                show(declared),
                show(v)
            )),
            Some((v, who)) => eprintln!(
                "xtask: {name}: rust-version {} (largest in its dependencies: {} for {who}); toolchain {}",
                show(declared),
                show(v),
                show(toolchain)
            ),
            None => {}
        }
    }
    if !problems.is_empty() {
        bail!("MSRV check of the {what} failed:\n  {}", problems.join("\n  "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_compare_numerically() {
        assert!(parse_version("1.89").unwrap() > parse_version("1.9.0").unwrap());
        assert_eq!(parse_version("1.87"), Some((1, 87, 0)));
        assert_eq!(parse_version("x"), None);
    }

    #[test]
    fn a_dependency_newer_than_the_declared_msrv_is_named() {
        let meta = serde_json::json!({
            "packages": [
                {"id": "a", "name": "app", "version": "0.1.0", "rust_version": "1.85"},
                {"id": "b", "name": "lib", "version": "2.0.0", "rust_version": "1.80"},
                {"id": "c", "name": "deep", "version": "0.3.0", "rust_version": "1.89"},
                {"id": "t", "name": "test-only", "version": "1.0.0", "rust_version": "1.94"},
            ],
            "workspace_members": ["a"],
            "resolve": {"nodes": [
                {"id": "a", "deps": [{"pkg": "b", "dep_kinds": [{"kind": null}]}, {"pkg": "t", "dep_kinds": [{"kind": "dev"}]}]},
                {"id": "b", "deps": [{"pkg": "c", "dep_kinds": [{"kind": null}]}]},
                {"id": "c", "deps": []},
                {"id": "t", "deps": []},
            ]},
        });
        let e = check_msrv(&meta, (1, 95, 0), "test").unwrap_err().to_string();
        assert!(e.contains("app declares rust-version 1.85.0") && e.contains("deep 0.3.0 needs 1.89.0"), "{e}");
        let mut ok = meta.clone();
        ok["packages"][0]["rust_version"] = "1.89".into();
        check_msrv(&ok, (1, 95, 0), "test").unwrap();
        assert!(check_msrv(&ok, (1, 88, 0), "test").unwrap_err().to_string().contains("toolchain is 1.88.0"));
    }
}
