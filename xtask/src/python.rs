//! `cargo xtask python`: the Python package (`python/`) built into a virtual environment and
//! its pytest suite run. The environment is `target/python/venv`, made with `python3 -m venv`
//! (the `python3-venv` package installed with apt-get when the module is missing and this runs
//! as root) and filled from PyPI with `python/requirements-test.txt` (pinned; installed again
//! only when that file changes). The wheel is built by `pip install ./python` (maturin over the
//! package's own cargo workspace, into the host's `target/`) when its sources' content hash
//! differs from the installed one's, and the tests compare it with the `fbg-trainer` binary of
//! the same tree. Without `python3` the task is skipped with a
//! message (the only case it is).

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, ensure, Context, Result};

use crate::cmd::{cargo, is_root, run, step, target_dir};

/// The Python package's crate (a member of the workspace, left out of `cargo test`).
pub const PACKAGE: &str = "fbg-compensation-py";
/// The requirements file, relative to the workspace root.
const REQUIREMENTS: &str = "python/requirements-test.txt";

/// Build the wheel into the venv and run the pytest suite.
pub fn run_all(root: &Path) -> Result<()> {
    step("Python package (wheel into target/python/venv, pytest)");
    let Some((py, trainer)) = prepare(root)? else { return Ok(()) };
    run(Command::new(&py)
        .current_dir(root.join("python"))
        .args(["-m", "pytest", "-q", "tests"])
        .env("FBG_TRAINER", &trainer))
}

/// The venv made and its pinned requirements installed, on a thread of its own: the downloads
/// and unpacking wait on the network and the disk, so `cargo xtask test` starts them before the
/// compilers take both cores. [`prepare`] finds the work done (or does it, when this failed).
pub fn warm_up(root: &Path) -> std::thread::JoinHandle<()> {
    let root = root.to_path_buf();
    std::thread::spawn(move || {
        if Command::new("python3").arg("--version").output().is_err() {
            return;
        }
        let venv = target_dir().join("python/venv");
        if let Err(e) = ensure_venv(&venv).and_then(|py| install_requirements(&root, &venv, &py)) {
            eprintln!("xtask: preparing the Python venv in the background failed (tried again later): {e:#}");
        }
    })
}

/// The venv's interpreter with the package installed from this tree, and the release
/// `fbg-trainer`; `None` (with a message) when there is no `python3`. The wheel is compiled as
/// the trainer was: with clippy after the host tests' build (`cargo xtask test`,
/// `cmd::with_clippy`), whose trainer it then reuses; with rustc otherwise (`cargo xtask
/// python`, the bench), as users build it.
pub fn prepare(root: &Path) -> Result<Option<(PathBuf, PathBuf)>> {
    if Command::new("python3").arg("--version").output().is_err() {
        eprintln!("xtask: python3 not found: skipping the Python package (install python3 to build and test it)");
        return Ok(None);
    }
    let venv = target_dir().join("python/venv");
    let py = ensure_venv(&venv)?;
    install_requirements(root, &venv, &py)?;
    // maturin is the venv's (no build isolation: nothing fetched per build); its directory
    // first on PATH, as an activated venv would have it.
    let path = std::env::join_paths(
        std::iter::once(venv.join("bin")).chain(std::env::var_os("PATH").iter().flat_map(std::env::split_paths)),
    )?;
    // The wheel is built and installed again only when its sources changed since the last
    // install (a content hash: a touched or rebuilt but equal tree keeps it).
    let stamp = venv.join("fbg-compensation.installed");
    let clippy = crate::fixtures::built_by_tests();
    let want = format!("{}compiled by {}\n", wheel_stamp(root)?, if clippy { "clippy" } else { "rustc" });
    if std::fs::read_to_string(&stamp).ok().as_deref() == Some(want.as_str()) {
        eprintln!("xtask: the installed wheel is built from these sources ({}); not rebuilt", stamp.display());
    } else {
        let _ = std::fs::remove_file(&stamp);
        let mut pip = Command::new(&py);
        if clippy {
            pip.envs(crate::cmd::clippy_env());
        }
        run(pip
            .current_dir(root)
            .args(["-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation", "--force-reinstall"])
            .arg("./python")
            .env("PATH", path)
            .env("CARGO_TARGET_DIR", target_dir()))?;
        crate::cmd::write_atomic(&stamp, want.as_bytes())?;
    }
    Ok(Some((py, crate::fixtures::trainer(root)?)))
}

/// The venv's interpreter, the venv made first when missing.
fn ensure_venv(venv: &Path) -> Result<PathBuf> {
    let py = venv.join("bin/python");
    if py.is_file() {
        return Ok(py);
    }
    let make = || Command::new("python3").args(["-m", "venv"]).arg(venv).status();
    if make().map(|s| s.success()).unwrap_or(false) {
        return Ok(py);
    }
    // Debian's python3 comes without `venv`/`ensurepip`; they are the python3-venv package.
    if is_root() {
        eprintln!("xtask: `python3 -m venv` failed; installing python3-venv with apt-get");
        let _ = std::fs::remove_dir_all(venv);
        run(Command::new("apt-get").args(["install", "-y", "python3-venv"]))
            .context("install the venv module (`apt-get install python3-venv`)")?;
        if make().map(|s| s.success()).unwrap_or(false) {
            return Ok(py);
        }
    }
    bail!(
        "`python3 -m venv {}` failed: install Python's venv module (Debian/Ubuntu: `apt-get install python3-venv`)",
        venv.display()
    )
}

/// Install the pinned requirements unless the venv already holds this exact file's.
fn install_requirements(root: &Path, venv: &Path, py: &Path) -> Result<()> {
    let req = root.join(REQUIREMENTS);
    let wanted = std::fs::read(&req).with_context(|| format!("reading {}", req.display()))?;
    let stamp = venv.join("requirements-test.installed");
    if std::fs::read(&stamp).ok().as_deref() == Some(wanted.as_slice()) {
        return Ok(());
    }
    run(Command::new(py).args(["-m", "pip", "install", "--quiet", "-r"]).arg(&req))?;
    crate::cmd::write_atomic(&stamp, &wanted)
}

/// What the wheel is built from: the files of every path package the Python package depends
/// on (the package, the trainer, the crates it uses), the lockfile, the top manifest (whose
/// `[workspace.dependencies]` the trainer's name) and the toolchain.
fn wheel_stamp(root: &Path) -> Result<String> {
    let out = cargo()
        .current_dir(root)
        .args(["metadata", "--format-version", "1", "--locked"])
        .output()
        .context("running `cargo metadata`")?;
    ensure!(out.status.success(), "`cargo metadata` failed: {}", String::from_utf8_lossy(&out.stderr));
    let meta: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    let packages = meta["packages"].as_array().context("`cargo metadata` printed no packages")?;
    let nodes = meta["resolve"]["nodes"].as_array().context("`cargo metadata` printed no resolve graph")?;
    let id_of = |name: &str| packages.iter().find(|p| p["name"] == name).and_then(|p| p["id"].as_str());
    let root_id = id_of(PACKAGE).with_context(|| format!("no package {PACKAGE} in the workspace"))?;
    // The package's dependency closure, by package id.
    let (mut closure, mut todo) = (std::collections::BTreeSet::from([root_id]), vec![root_id]);
    while let Some(id) = todo.pop() {
        let node = nodes.iter().find(|n| n["id"] == id);
        for dep in node.and_then(|n| n["dependencies"].as_array()).into_iter().flatten().filter_map(|d| d.as_str()) {
            if closure.insert(dep) {
                todo.push(dep);
            }
        }
    }
    let mut paths: Vec<PathBuf> = packages
        .iter()
        .filter(|p| p["source"].is_null() && p["id"].as_str().is_some_and(|id| closure.contains(id)))
        .filter_map(|p| Path::new(p["manifest_path"].as_str()?).parent().map(Path::to_path_buf))
        .collect();
    paths.sort();
    paths.extend(["Cargo.toml", "Cargo.lock"].map(|f| root.join(f)));
    let rustc = Command::new("rustc").arg("-vV").output().context("running `rustc -vV`")?;
    Ok(format!("wheel sources {:016x}\n{}", crate::cmd::content_hash(&paths)?, String::from_utf8_lossy(&rustc.stdout)))
}
