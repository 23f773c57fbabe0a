//! The Python wheel's build (maturin, `python/`, a member of the workspace left out of `cargo
//! test`) reuses the test build's compiled `fbg-trainer` only when every unit under it —
//! package, target, mode, features, profile — is the same in both builds; one feature more on one
//! side compiles the trainer and most of its dependencies again. `wheel-features/` gives both builds the union of
//! what each enables; this step compares cargo's unit graphs of the two builds (`--unit-graph`,
//! unstable, enabled with `RUSTC_BOOTSTRAP=1`; nothing is compiled) and names what differs.

use std::collections::HashSet;
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context, Result};
use serde_json::Value;

use crate::cmd::{cargo, step};

/// Every unit of the wheel's build that `fbg-trainer`'s library needs is also one of the test
/// build's.
pub fn check(root: &Path) -> Result<()> {
    step("lint: the Python wheel's build shares the test build's fbg-trainer (cargo's unit graphs)");
    let tests = unit_graph(cargo().current_dir(root).args(crate::HOST_TEST_BUILD))?;
    let wheel = unit_graph(cargo().current_dir(root).args([
        "build",
        "--release",
        "--locked",
        "--lib",
        "-p",
        crate::python::PACKAGE,
    ]))?;
    let built: HashSet<String> = units(&tests).iter().map(key).collect();
    let wheel_units = units(&wheel);
    let trainer = wheel_units
        .iter()
        .position(|u| u["pkg_id"].as_str().is_some_and(|p| p.contains("/host-trainer#")) && u["mode"] == "build")
        .context("the wheel's unit graph has no fbg-trainer library")?;
    // The trainer's unit and everything it depends on, by the graph's indices.
    let (mut seen, mut todo) = (HashSet::from([trainer]), vec![trainer]);
    while let Some(i) = todo.pop() {
        let deps = wheel_units.get(i).and_then(|u| u["dependencies"].as_array()).into_iter().flatten();
        for d in deps.filter_map(|d| d["index"].as_u64()).map(|d| d as usize) {
            if seen.insert(d) {
                todo.push(d);
            }
        }
    }
    let mut differ: Vec<String> = seen
        .iter()
        .filter_map(|&i| wheel_units.get(i))
        .filter(|u| !built.contains(&key(u)))
        .map(|u| format!("{} ({} {}) features {}", u["pkg_id"], u["target"]["kind"], u["mode"], u["features"]))
        .collect();
    differ.sort();
    if !differ.is_empty() {
        bail!(
            "the Python wheel's build would compile fbg-trainer again: {} of its units differ from the test build's \
             (give both builds the same features in wheel-features/Cargo.toml):\n  {}",
            differ.len(),
            differ.join("\n  ")
        );
    }
    eprintln!("xtask: the wheel's build needs {} units for fbg-trainer, all of them the test build's", seen.len());
    Ok(())
}

fn unit_graph(c: &mut Command) -> Result<Value> {
    let out = c
        .args(["--unit-graph", "-Z", "unstable-options"])
        .env("RUSTC_BOOTSTRAP", "1")
        .output()
        .context("running cargo --unit-graph")?;
    if !out.status.success() {
        bail!("cargo --unit-graph failed: {}", String::from_utf8_lossy(&out.stderr));
    }
    serde_json::from_slice(&out.stdout).context("reading cargo's unit graph")
}

fn units(graph: &Value) -> &[Value] {
    graph["units"].as_array().map(Vec::as_slice).unwrap_or_default()
}

/// What makes a unit the same compilation: everything but its place in the graph.
fn key(u: &Value) -> String {
    let part = |k: &str| u[k].to_string();
    [part("pkg_id"), u["target"]["name"].to_string(), part("mode"), part("features"), part("profile"), part("platform")]
        .join("|")
}
