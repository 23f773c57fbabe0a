//! Signed model updates on the product image (accepted, refused with their reasons, the audit
//! trail) and the bounded rollback on the `rollback` image.

use std::fs;
use std::path::Path;
use std::process::{Command, Stdio};

use anyhow::{ensure, Context, Result};
use fbg_shared::blob::stored_crc;
use fbg_shared::protocol::{DeviceMsg, RejectReason, UpdateResult};

use super::expect_rejected;
use crate::firmware::session::LinkSession;
use crate::firmware::{self, Bins};
use crate::fixtures::{self, Fixtures};
use crate::signing::SignedFixtures;

/// The answers of the running model to `samples` from a fresh stream state, as bit patterns
/// (values, band) and flags, to compare bit for bit.
pub(super) fn answers(s: &mut LinkSession, samples: &[fbg_shared::Sample<f32>]) -> Result<Vec<([u32; 6], String)>> {
    s.link()?.reset_stream(0xA11, fbg_shared::StreamClock::Calibration)?;
    samples
        .iter()
        .enumerate()
        .map(|(i, x)| {
            let e = s.link()?.compensate(i as u32, x)?;
            let v = e.values.iter().chain(e.band.iter()).map(|f| f.to_bits()).collect::<Vec<_>>();
            Ok(([v[0], v[1], v[2], v[3], v[4], v[5]], format!("{:?}", e.flags)))
        })
        .collect()
}

pub(super) fn signed_update_test(
    root: &Path,
    qemu: &Path,
    bins: &Bins,
    fx: &Fixtures,
    sfx: &SignedFixtures,
) -> Result<()> {
    let default = fs::read(firmware::dir(root).join("model/default.fbgm"))?;
    let new = fs::read(&sfx.new)?;
    let new_blob = fbg_shared::container::strip(&new).to_vec();
    let test_key: [u8; 32] =
        fs::read(&sfx.test_pub)?.try_into().map_err(|_| anyhow::anyhow!("the test public key is not 32 bytes"))?;
    let test_id = fbg_shared::signature::key_id(&test_key);
    let samples: Vec<_> = fixtures::read_inputs(&fx.golden_inputs)?.into_iter().take(40).collect();
    let mut s = LinkSession::start(root, qemu, &bins.product, "signed")?;
    let st = s.link()?.status()?;
    ensure!(st.model_serial == 0 && st.model_key_id.is_none(), "the embedded model should read as unsigned: {st:?}");
    let embedded = answers(&mut s, &samples)?;

    // Accepted: the default model signed with serial 3 (the same model, so the same answers),
    // then the update model with serial 5.
    let accepted = |s: &mut LinkSession, path: &Path, serial: u64, crc: Option<u32>| -> Result<()> {
        let r = s.link()?.update_model(&fs::read(path)?)?;
        ensure!(matches!(r, UpdateResult::Accepted { .. }), "{}: {r:?}", path.display());
        let st = s.link()?.status()?;
        ensure!(
            (st.model_serial, st.model_key_id, Some(st.model_crc)) == (serial, Some(test_id), crc),
            "after accepting {}: serial {}, key {:?}, crc {:#x}",
            path.display(),
            st.model_serial,
            st.model_key_id,
            st.model_crc
        );
        eprintln!("xtask: signed: {} accepted (serial {serial}, key {test_id})", path.display());
        Ok(())
    };
    accepted(&mut s, &sfx.old, 3, stored_crc(&default))?;
    ensure!(
        answers(&mut s, &samples)? == embedded,
        "the default model signed answers differently from the embedded one"
    );
    accepted(&mut s, &sfx.new, 5, stored_crc(&new_blob))?;
    let running = answers(&mut s, &samples)?;
    ensure!(running != embedded, "the update model answers like the default one; the test would prove nothing");

    // Refused, each with its reason, the running model untouched.
    let mut tampered = new.clone();
    tampered[fbg_shared::blob::HEADER_LEN + 40] ^= 0x04; // one payload bit
    let cases: [(&str, Vec<u8>, RejectReason); 6] = [
        ("unsigned", new_blob.clone(), RejectReason::Unsigned),
        ("unknown key", fs::read(&sfx.stranger)?, RejectReason::UnknownKey),
        ("tampered after signing (one payload bit)", tampered, RejectReason::BadSignature),
        ("older serial replayed (3 < 5)", fs::read(&sfx.old)?, RejectReason::Rollback),
        ("another model under the running serial 5 (a swap)", fs::read(&sfx.swap)?, RejectReason::SerialReused),
        ("a rollback of serial 5, on the default build", fs::read(&sfx.rollback)?, RejectReason::RollbackNotPermitted),
    ];
    for (what, bytes, reason) in &cases {
        expect_rejected(s.link()?.update_model(bytes)?, *reason, what)?;
        let st = s.link()?.status()?;
        ensure!(
            (st.model_serial, Some(st.model_crc)) == (5, stored_crc(&new_blob)),
            "{what}: the active model changed (serial {}, crc {:#x})",
            st.model_serial,
            st.model_crc
        );
        ensure!(
            answers(&mut s, &samples)? == running,
            "{what}: the running model no longer answers bit for bit as before"
        );
    }
    let st = s.link()?.status()?;
    let want =
        fbg_shared::protocol::Refusals { unsigned: 1, bad_signature: 1, unknown_key: 1, rollback: 2, serial_reused: 1 };
    ensure!(st.refused == want, "refusals by reason {:?}, expected {want:?}", st.refused);
    ensure!(
        (st.updates_accepted, st.updates_rejected) == (2, 6),
        "accepted/refused {:?}",
        (st.updates_accepted, st.updates_rejected)
    );
    eprintln!("xtask: signed: every bad update refused with its reason; the running model answered bit for bit as before each time");

    let (before, erases) = staging_erases(&mut s, &new, st.staging_erases)?;

    // The audit trail through the CLI.
    s.disconnect()?;
    let out = Command::new(&fx.trainer)
        .args(["device", "status", "--port", &s.port.to_string()])
        .stdin(Stdio::null())
        .output()
        .context("running fbg-trainer device status")?;
    let text = String::from_utf8_lossy(&out.stdout);
    ensure!(out.status.success(), "fbg-trainer device status failed: {}", String::from_utf8_lossy(&out.stderr));
    for needle in [
        format!("serial 5, signed by key {test_id}"),
        "2 accepted, 6 refused (1 unsigned, 1 bad signature, 1 unknown key, 2 rollback, 1 serial reused, 0 other)"
            .to_string(),
        format!("staging slot: {} erases since boot", before + erases),
    ] {
        ensure!(text.contains(&needle), "`fbg-trainer device status` does not say `{needle}`:\n{text}");
    }
    eprint!("xtask: signed: fbg-trainer device status:\n{text}");
    s.connect()?;
    s.disconnect()?;
    s.check_alive()?;
    Ok(())
}

/// On the `rollback` image (the product with rollbacks accepted): the
/// rollback signed to replace serial 5 is refused over serial 3, accepted over serial 5,
/// refused when replayed over itself (serial 4 now runs) and after the device moved on to
/// serial 9; the swap is refused there too.
pub(super) fn rollback_test(root: &Path, qemu: &Path, bins: &Bins, sfx: &SignedFixtures) -> Result<()> {
    let default = fs::read(firmware::dir(root).join("model/default.fbgm"))?;
    let new = fs::read(&sfx.new)?;
    let new_crc = stored_crc(fbg_shared::container::strip(&new));
    let rollback = fs::read(&sfx.rollback)?;
    let mut s = LinkSession::start(root, qemu, &bins.rollback, "rollback")?;
    let step = |s: &mut LinkSession, what: &str, path: &Path, want: Option<RejectReason>, after: (u64, Option<u32>)| {
        let r = s.link()?.update_model(&fs::read(path)?)?;
        match want {
            None => ensure!(matches!(r, UpdateResult::Accepted { .. }), "{what}: {r:?}"),
            Some(reason) => expect_rejected(r, reason, what)?,
        }
        let st = s.link()?.status()?;
        ensure!(
            (st.model_serial, Some(st.model_crc)) == after,
            "{what}: running serial {}, crc {:#x}, expected {after:?}",
            st.model_serial,
            st.model_crc
        );
        eprintln!("xtask: rollback: {what}: {}", if want.is_none() { "accepted" } else { "refused" });
        Ok(())
    };
    step(&mut s, "serial 3", &sfx.old, None, (3, stored_crc(&default)))?;
    step(
        &mut s,
        "the rollback over serial 3",
        &sfx.rollback,
        Some(RejectReason::RollbackNotPermitted),
        (3, stored_crc(&default)),
    )?;
    step(&mut s, "serial 5", &sfx.new, None, (5, new_crc))?;
    step(&mut s, "another model under serial 5", &sfx.swap, Some(RejectReason::SerialReused), (5, new_crc))?;
    step(&mut s, "the rollback over serial 5", &sfx.rollback, None, (4, stored_crc(&default)))?;
    step(
        &mut s,
        "the rollback replayed over itself",
        &sfx.rollback,
        Some(RejectReason::RollbackNotPermitted),
        (4, stored_crc(&default)),
    )?;
    step(&mut s, "serial 9", &sfx.later, None, (9, new_crc))?;
    step(
        &mut s,
        "the rollback after the device moved on",
        &sfx.rollback,
        Some(RejectReason::RollbackNotPermitted),
        (9, new_crc),
    )?;
    let st = s.link()?.status()?;
    ensure!(
        (st.updates_accepted, st.updates_rejected, st.refused.rollback, st.refused.serial_reused) == (4, 4, 3, 1),
        "after the rollback test: {st:?}"
    );
    ensure!(rollback.len() == fbg_shared::container::strip(&rollback).len() + fbg_shared::signature::TRAILER_V2_LEN);
    s.disconnect()?;
    s.check_alive()?;
    Ok(())
}

/// Begins without data erase nothing (at most the one a written slot needs):
/// 1 000 `ModelBegin` frames for `new` after `before` erases since boot. Returns `before` and the
/// erases they caused.
fn staging_erases(s: &mut LinkSession, new: &[u8], before: u32) -> Result<(u32, u32)> {
    let begin = fbg_shared::protocol::HostMsg::ModelBegin {
        total_len: new.len() as u32,
        crc32: fbg_shared::protocol::crc32(new),
    };
    for i in 0..1000 {
        let r = s.link()?.request(&begin)?;
        ensure!(matches!(r, DeviceMsg::UpdateProgress { received: 0 }), "ModelBegin {i}: {r:?}");
    }
    let erases = s.link()?.status()?.staging_erases - before;
    ensure!(erases <= 1, "1 000 ModelBegin frames erased the staging slot {erases} times");
    eprintln!(
        "xtask: signed: 1 000 ModelBegin frames, {erases} staging erase(s) (slot erases since boot: {})",
        before + erases
    );
    Ok((before, erases))
}
