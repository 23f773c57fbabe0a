//! Signed models for the firmware tests, made by the trainer itself (`fbg-trainer sign`,
//! `fbg-trainer keygen`), so that what the QEMU tests send is exactly what a lab would.
//!
//! The committed QEMU TEST key (`firmware/keys/qemu-test.key`, trusted by the default firmware
//! build) is copied into `target/qemu/signing/` and signs with a fresh serial ledger there on
//! every run (`FBG_SIGNING_STATE_DIR`: serials are kept per key id, so the user's own ledger
//! must not see the test key's serials); a second key made there is trusted by nobody.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{ensure, Context, Result};

use crate::fixtures::{DeviceFixtures, Fixtures};

/// The signed models of the QEMU tests, in the order of their serials.
#[derive(Clone, Debug)]
pub struct SignedFixtures {
    /// The test key's public half (as the firmware build trusts it).
    pub test_pub: PathBuf,
    /// The update model, serial 1 (the link test's accepted update).
    pub update: PathBuf,
    /// The default model, serial 3 (accepted, later replayed: a rollback).
    pub old: PathBuf,
    /// The default model signed as a rollback to serial 4 that may replace serial 5 only
    /// (trailer version 2): refused by the default build, accepted by the `rollback` image
    /// over serial 5 and nowhere else.
    pub rollback: PathBuf,
    /// The update model, serial 5.
    pub new: PathBuf,
    /// The default model, serial 5 too: another model under the serial of `new` (a swap).
    pub swap: PathBuf,
    /// The update model, serial 9 (the device moves on past the rollback's serial).
    pub later: PathBuf,
    /// The update model signed by a key the firmware does not trust.
    pub stranger: PathBuf,
}

/// The committed QEMU test key.
pub fn test_key(root: &Path) -> PathBuf {
    root.join("firmware/keys/qemu-test.key")
}

/// Copy the test key into `dir`, private to its owner like a real key (git checks files out
/// world-readable, which the trainer warns about).
fn copy_key(root: &Path, dir: &Path) -> Result<PathBuf> {
    let key = dir.join("qemu-test.key");
    fs::copy(test_key(root), &key).context("copying the QEMU test key")?;
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        fs::set_permissions(&key, fs::Permissions::from_mode(0o600))?;
    }
    Ok(key)
}

fn trainer(fx: &Fixtures) -> Command {
    Command::new(&fx.trainer)
}

/// Sign `model` into `out` with `key` and `serial` (a rollback that may replace `replaces`
/// when given), the serial ledger in `state` beside the key.
fn sign(fx: &Fixtures, key: &Path, model: &Path, out: &Path, serial: u64, replaces: Option<u64>) -> Result<()> {
    let mut c = trainer(fx);
    c.arg("sign").arg("--model").arg(model).arg("--out").arg(out).arg("--sign").arg(key);
    c.args(["--serial", &serial.to_string()]);
    if let Some(r) = replaces {
        c.args(["--allow-rollback", "--replaces", &r.to_string()]);
    }
    let state = key.parent().map(|d| d.join("serial-state")).unwrap_or_else(|| PathBuf::from("serial-state"));
    c.env("FBG_SIGNING_STATE_DIR", state);
    crate::cmd::run(&mut c)
}

/// Make the signed models in `target/qemu/signing/` (anew on every call).
pub fn ensure(root: &Path, fx: &Fixtures, dfx: &DeviceFixtures) -> Result<SignedFixtures> {
    let dir = root.join("target/qemu/signing");
    if dir.exists() {
        fs::remove_dir_all(&dir).with_context(|| format!("clearing {}", dir.display()))?;
    }
    fs::create_dir_all(&dir)?;
    let key = copy_key(root, &dir)?;
    let test_pub = root.join("firmware/keys/qemu-test.pub");
    let default = root.join("firmware/model/default.fbgm");
    let s = SignedFixtures {
        test_pub,
        update: dir.join("update-s1.fbgm"),
        old: dir.join("default-s3.fbgm"),
        rollback: dir.join("default-s4-rollback-of-s5.fbgm"),
        new: dir.join("update-s5.fbgm"),
        swap: dir.join("default-s5.fbgm"),
        later: dir.join("update-s9.fbgm"),
        stranger: dir.join("update-stranger.fbgm"),
    };
    // Serials only grow per key id (the trainer refuses a lower one, except for a rollback,
    // which must replace a serial already issued): sign in serial order.
    sign(fx, &key, &dfx.update_model, &s.update, 1, None)?;
    sign(fx, &key, &default, &s.old, 3, None)?;
    sign(fx, &key, &dfx.update_model, &s.new, 5, None)?;
    sign(fx, &key, &default, &s.swap, 5, None)?;
    sign(fx, &key, &default, &s.rollback, 4, Some(5))?;
    sign(fx, &key, &dfx.update_model, &s.later, 9, None)?;
    let stranger_key = dir.join("stranger.key");
    crate::cmd::run(trainer(fx).arg("keygen").arg("--out").arg(&stranger_key))?;
    sign(fx, &stranger_key, &dfx.update_model, &s.stranger, 6, None)?;
    for p in [&s.update, &s.old, &s.rollback, &s.new, &s.swap, &s.later, &s.stranger] {
        ensure!(p.exists(), "{} was not written", p.display());
    }
    Ok(s)
}

/// The default model signed with the test key (serial 1) for the bench image's verification
/// timing (`FBG_BENCH_SIGNED`), in the fixtures directory.
pub fn bench_signed(root: &Path, fx: &Fixtures) -> Result<PathBuf> {
    let dir = root.join("target/qemu/signing-bench");
    if dir.exists() {
        fs::remove_dir_all(&dir)?;
    }
    fs::create_dir_all(&dir)?;
    let key = copy_key(root, &dir)?;
    let out = crate::fixtures::dir(root).join("bench_signed.fbgm");
    sign(fx, &key, &root.join("firmware/model/default.fbgm"), &out, 1, None)?;
    Ok(out)
}

/// A blob signed with the test key (serial `serial`), written beside `model` as
/// `<stem>-signed.fbgm`.
pub fn sign_one(root: &Path, fx: &Fixtures, model: &Path, serial: u64) -> Result<PathBuf> {
    let dir = root.join("target/qemu/signing-one");
    if dir.exists() {
        fs::remove_dir_all(&dir)?;
    }
    fs::create_dir_all(&dir)?;
    let key = copy_key(root, &dir)?;
    let stem = model.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "model".into());
    let out = model.with_file_name(format!("{stem}-signed.fbgm"));
    sign(fx, &key, model, &out, serial, None)?;
    Ok(out)
}
