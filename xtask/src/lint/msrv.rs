//! The MSRV: every package's declared `rust-version` against its locked dependencies and the
//! toolchain in use (`cargo metadata --locked`), and a build with the MSRV toolchain when it
//! is installed.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};
use serde_json::Value;

use crate::cmd::{cargo, cargo_own_target, host_triple, run};

/// Both workspaces: the declared versions against the dependencies and the toolchain, then the
/// build with each declared version's toolchain where it is installed.
pub(super) fn check(root: &Path) -> Result<()> {
    let toolchain = rustc_version()?;
    let host = cargo_metadata(cargo().current_dir(root))?;
    let firmware = cargo_metadata(cargo_own_target().current_dir(root.join("firmware")))?;
    check_msrv(&host, toolchain, "host workspace")?;
    check_msrv(&firmware, toolchain, "firmware workspace")?;
    let installed = installed_toolchains();
    let host_triple = host_triple()?;
    for (what, meta, dir) in
        [("host workspace", &host, root.to_path_buf()), ("firmware workspace", &firmware, root.join("firmware"))]
    {
        for (version, members) in declared_versions(meta) {
            let Some(tc) = toolchain_for(&version, &installed) else {
                eprintln!(
                    "xtask: MSRV build skipped for rust-version {version} ({what}: {}): no toolchain {version} is \
                     installed (CI has one toolchain and fetches none; `rustup toolchain install {version}` runs \
                     this build here). The declared version is checked above against the locked dependencies and \
                     the toolchain, and clippy's `incompatible_msrv` rejects standard-library items newer than it",
                    members.join(", ")
                );
                continue;
            };
            // The firmware image needs the thumb target of that toolchain: not assumed.
            let packages: Vec<&String> = members.iter().filter(|m| m.as_str() != "fbg-firmware").collect();
            if packages.len() < members.len() {
                eprintln!("xtask: MSRV build of the firmware image skipped (the thumb target of {tc} is not assumed)");
            }
            if packages.is_empty() {
                continue;
            }
            // Libraries and binaries only (dev-dependencies do not bind users' toolchains), for
            // the host, in a target directory of its own; through rustup, since `cargo()` is
            // the current toolchain's cargo.
            let mut c = Command::new("rustup");
            c.current_dir(&dir).args(["run", &tc, "cargo", "check", "--locked", "--target", &host_triple]);
            c.arg("--target-dir").arg(dir.join("target").join(format!("msrv-{version}")));
            for p in packages {
                c.args(["-p", p]);
            }
            for var in ["CARGO", "RUSTC", "RUSTDOC", "RUSTUP_TOOLCHAIN", "CARGO_TARGET_DIR"] {
                c.env_remove(var);
            }
            run(c.env("RUSTUP_AUTO_INSTALL", "0"))?;
        }
    }
    Ok(())
}

/// Each declared `rust-version` of the workspace's members, with the members declaring it.
fn declared_versions(meta: &Value) -> BTreeMap<String, Vec<String>> {
    let empty = Vec::new();
    let members: BTreeSet<&str> =
        meta["workspace_members"].as_array().unwrap_or(&empty).iter().filter_map(Value::as_str).collect();
    let mut out: BTreeMap<String, Vec<String>> = BTreeMap::new();
    for p in meta["packages"].as_array().unwrap_or(&empty) {
        let (Some(id), Some(name), Some(v)) = (p["id"].as_str(), p["name"].as_str(), p["rust_version"].as_str()) else {
            continue;
        };
        if members.contains(id) {
            out.entry(v.to_string()).or_default().push(name.to_string());
        }
    }
    out
}

/// The names of the installed rustup toolchains (none without rustup).
fn installed_toolchains() -> Vec<String> {
    Command::new("rustup")
        .args(["toolchain", "list"])
        .output()
        .map(|o| {
            String::from_utf8_lossy(&o.stdout)
                .lines()
                .filter_map(|l| l.split_whitespace().next())
                .map(str::to_string)
                .collect()
        })
        .unwrap_or_default()
}

/// An installed toolchain of `version` (`1.89` is `1.89`, `1.89.0`, `1.89-<host>` or
/// `1.89.0-<host>`; a channel such as `stable` never counts, whatever version it is).
fn toolchain_for(version: &str, installed: &[String]) -> Option<String> {
    let want = parse_version(version)?;
    installed
        .iter()
        .find(|t| {
            let v = t.split('-').next().unwrap_or("");
            v.chars().next().is_some_and(|c| c.is_ascii_digit()) && parse_version(v) == Some(want)
        })
        .cloned()
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
    fn only_a_toolchain_of_the_version_builds_it() {
        let installed =
            ["stable-x86_64-unknown-linux-gnu", "nightly-x86_64-unknown-linux-gnu", "1.95.0-x86_64-unknown-linux-gnu"]
                .map(String::from);
        assert_eq!(toolchain_for("1.89", &installed), None);
        assert_eq!(toolchain_for("1.95", &installed).as_deref(), Some("1.95.0-x86_64-unknown-linux-gnu"));
        assert_eq!(
            toolchain_for("1.87", &["1.87-x86_64-unknown-linux-gnu".to_string()]).as_deref(),
            Some("1.87-x86_64-unknown-linux-gnu")
        );
    }

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
