//! Signed updates: trusted keys, serials and bounded rollbacks, the embedded model, the
//! verifier.

use super::*;

/// The signature check of an update: unsigned, unknown key, tampered after signing and an
/// older serial are each refused with their reason and counted, the old model answering bit for
/// bit as before; a signed update with a serial at least the running one's is accepted; an
/// older one signed to allow the rollback is accepted where the build allows it.
#[test]
fn updates_must_be_signed_by_a_trusted_key_and_not_roll_back() {
    let mut mem = Mem::new();
    let mut link = mem.link(default_blob());
    let st = link.status().unwrap();
    assert_eq!((st.model_serial, st.model_key_id), (0, None), "the embedded default is unsigned");
    let s = samples(120);
    let other = other_model();
    let v5 = sign(&other, 5);
    assert!(matches!(link.update_model(&v5).unwrap(), UpdateResult::Accepted { .. }));
    let mut running = Compensator::<f32, K>::new(&params(&other)).unwrap();
    assert_serves(&mut link, &mut running, &s[..10], 0);

    let mut tampered = v5.clone();
    tampered[blob::HEADER_LEN + 40] ^= 0x04; // one payload bit
    let mut tampered_fixed_crc = tampered.clone();
    let n = other.len();
    let c = crc32(&tampered_fixed_crc[..n - 4]).to_le_bytes();
    tampered_fixed_crc[n - 4..n].copy_from_slice(&c);
    let mut serial_raised = v5.clone();
    serial_raised[n + 8] = 9; // serial 5 -> 9 without re-signing
    let cases: Vec<(&str, Vec<u8>, RejectReason)> = std::vec![
        ("unsigned", default_blob().to_vec(), RejectReason::Unsigned),
        ("unknown key", sign_with(&stranger(), default_blob(), 6, SignFlags::NONE), RejectReason::UnknownKey),
        ("tampered payload bit", tampered, RejectReason::BadSignature),
        ("tampered, CRC made right again", tampered_fixed_crc, RejectReason::BadSignature),
        ("serial raised after signing", serial_raised, RejectReason::BadSignature),
        ("older serial replayed", sign(default_blob(), 4), RejectReason::Rollback),
    ];
    for (i, (name, bytes, reason)) in cases.iter().enumerate() {
        match link.update_model(bytes).unwrap() {
            UpdateResult::Rejected(r) => assert_eq!(r.reason, *reason, "{name}: {r}"),
            other => panic!("{name}: accepted? {other:?}"),
        }
        let st = link.status().unwrap();
        assert_eq!((st.model_crc, st.model_serial), (blob::stored_crc(&other).unwrap(), 5), "{name}");
        let seq = 10 + 10 * i;
        assert_serves(&mut link, &mut running, &s[seq..seq + 10], seq as u32);
    }
    let st = link.status().unwrap();
    assert_eq!(
        st.refused,
        fbg_shared::protocol::Refusals { unsigned: 1, bad_signature: 3, unknown_key: 1, rollback: 1, serial_reused: 0 }
    );
    assert_eq!((st.updates_accepted, st.updates_rejected), (1, 6));
    assert_eq!(st.last_rejection.map(|r| (r.reason, r.detail)), Some((RejectReason::Rollback, 4)));
    let unknown = Rejection::from(SignatureError::UnknownKey { key_id: trusted(&stranger()).id });
    assert_eq!(unknown.reason, RejectReason::UnknownKey);

    // The same serial again (a re-install) and a newer one are accepted.
    assert!(matches!(link.update_model(&sign(&other, 5)).unwrap(), UpdateResult::Accepted { .. }));
    assert!(matches!(link.update_model(&sign(default_blob(), 7)).unwrap(), UpdateResult::Accepted { .. }));
    // A deliberate downgrade, signed as a rollback of serial 7: accepted by a build that allows it.
    let down = sign_rollback(&other, 2, 7);
    assert!(matches!(link.update_model(&down).unwrap(), UpdateResult::Accepted { .. }));
    let st = link.status().unwrap();
    assert_eq!((st.model_serial, st.updates_accepted), (2, 4));
}

/// Send `bytes` as one update to `dev` (frames fed directly) and return the device's answer
/// to the commit.
pub(super) fn update_direct<F: MappedFlash>(dev: &mut Device<'_, Pin, F, K>, bytes: &[u8]) -> DeviceMsg {
    let mut frame = [0u8; HOST_MAX_FRAME];
    let mut tx = Tx::default();
    let begin = HostMsg::ModelBegin { total_len: bytes.len() as u32, crc32: crc32(bytes) };
    dev.feed(encode_host(&begin, &mut frame).unwrap(), &mut tx).unwrap();
    for (k, chunk) in bytes.chunks(MAX_CHUNK).enumerate() {
        let msg = HostMsg::ModelChunk { offset: (k * MAX_CHUNK) as u32, data: chunk };
        dev.feed(encode_host(&msg, &mut frame).unwrap(), &mut tx).unwrap();
    }
    dev.handle(&HostMsg::ModelCommit)
}

pub(super) fn reason(m: &DeviceMsg) -> Option<RejectReason> {
    match m {
        DeviceMsg::UpdateResult(UpdateResult::Rejected(r)) => Some(r.reason),
        _ => None,
    }
}

/// A rollback names the serial it replaces and is accepted only while that
/// serial runs: no replay after the device moved on (the serial-2 blob after serial 9),
/// none of the same blob twice, no swapping of two models signed with one serial, nothing on a
/// build without rollback, and a version-1 allow-rollback flag grants nothing.
#[test]
fn a_rollback_is_bounded_to_the_serial_it_replaces() {
    let other = other_model();
    let def = default_blob();
    let crc = |b: &[u8]| blob::stored_crc(b).unwrap();
    let run = |serial: u64, b: &[u8]| ModelInfo { serial, crc: crc(b), centres: 0, key_id: None };
    let p = policy();
    let strict = Policy { allow_rollback: false, ..policy() };
    let refused = |policy: &Policy, bytes: &[u8], running: ModelInfo| {
        authenticate(policy, bytes, Some(&running)).map(|(_, s)| s.serial).map_err(|r| r.reason)
    };
    let back = sign_rollback(def, 2, 5);
    // Accepted exactly while serial 5 runs, whatever model that is.
    assert_eq!(refused(&p, &back, run(5, &other)), Ok(2));
    assert_eq!(refused(&p, &back, run(5, def)), Ok(2));
    for running in [9, 6, 4, 3, 2, 0] {
        let got = refused(&p, &back, run(running, &other));
        assert_eq!(got, Err(RejectReason::RollbackNotPermitted), "running serial {running}");
    }
    // Once applied, the device runs serial 2: the same blob again is refused (no replay).
    assert_eq!(refused(&p, &back, run(2, def)), Err(RejectReason::RollbackNotPermitted));
    // A build without rollback refuses it even over serial 5.
    assert_eq!(refused(&strict, &back, run(5, &other)), Err(RejectReason::RollbackNotPermitted));
    let e = authenticate(&strict, &back, Some(&run(5, &other))).unwrap_err();
    assert_eq!(e.detail, 5, "the detail names the serial it may replace");
    // A version-1 allow-rollback flag (older signers): judged as an ordinary update.
    let v1 = sign_with(&lab(), def, 2, SignFlags::ALLOW_ROLLBACK);
    assert_eq!(refused(&p, &v1, run(9, &other)), Err(RejectReason::Rollback));
    assert_eq!(refused(&p, &v1, run(1, &other)), Ok(2));
    // One serial, two models: the running one again is a re-install, the other is refused.
    let a5 = sign(&other, 5);
    let b5 = sign(def, 5);
    assert_eq!(refused(&p, &a5, run(5, &other)), Ok(5));
    assert_eq!(refused(&p, &b5, run(5, &other)), Err(RejectReason::SerialReused));
    assert_eq!(refused(&p, &a5, run(5, def)), Err(RejectReason::SerialReused));
    let e = authenticate(&p, &b5, Some(&run(5, &other))).unwrap_err();
    assert_eq!(e, Rejection { reason: RejectReason::SerialReused, detail: 5 });
    // A rollback that names its own serial is no way around it either.
    assert_eq!(refused(&p, &sign_rollback(def, 5, 5), run(5, &other)), Err(RejectReason::SerialReused));
    // At boot (nothing running) only the signature counts.
    assert_eq!(authenticate(&p, &back, None).map(|(_, s)| s.serial), Ok(2));

    // Through the device: the sequence, counted by reason.
    let mut mem = Mem::new();
    let info = mem.boot(def).unwrap();
    let mut dev = mem.device(info);
    let ok = |m: &DeviceMsg| matches!(m, DeviceMsg::UpdateResult(UpdateResult::Accepted { .. }));
    assert!(ok(&update_direct(&mut dev, &sign(&other, 5))));
    assert_eq!(reason(&update_direct(&mut dev, &b5)), Some(RejectReason::SerialReused), "swap");
    assert!(ok(&update_direct(&mut dev, &back)), "bounded rollback over serial 5");
    assert_eq!(dev.model().serial, 2);
    assert_eq!(reason(&update_direct(&mut dev, &back)), Some(RejectReason::RollbackNotPermitted), "replayed");
    assert!(ok(&update_direct(&mut dev, &sign(&other, 9))));
    assert_eq!(reason(&update_direct(&mut dev, &back)), Some(RejectReason::RollbackNotPermitted), "after 9");
    assert_eq!(reason(&update_direct(&mut dev, &sign(def, 2))), Some(RejectReason::Rollback));
    let st = dev.status();
    assert_eq!((st.model_serial, st.model_crc), (9, crc(&other)));
    assert_eq!((st.refused.rollback, st.refused.serial_reused, st.updates_accepted), (3, 1, 3));
}

/// A build that does not accept rollbacks (the firmware's default) refuses one even over the
/// serial it names.
#[test]
fn a_build_without_rollback_refuses_every_rollback() {
    let mut mem = Mem::new();
    let other = other_model();
    let strict = Policy { allow_rollback: false, ..policy() };
    let info = ModelInfo { serial: 7, ..mem.boot(default_blob()).unwrap() };
    let store = Store::open(&mut mem.flash, STAGE).unwrap();
    let mut dev = Device::new(&mut mem.comp, Kernel::LIBRARY, strict, &mut mem.reader, info, store, Pin::default());
    let r = update_direct(&mut dev, &sign_rollback(&other, 2, 7));
    assert_eq!(reason(&r), Some(RejectReason::RollbackNotPermitted));
    assert_eq!(dev.status().refused.rollback, 1);
    assert_eq!(dev.status().model_serial, 7);
}

/// `ModelBegin` erases only a slot that is not blank, so 1 000 begins cost
/// one erase (the slot starts with garbage); the erases are counted in `Status`; and the link
/// alone cannot erase more than the budget between accepted updates.
#[test]
fn begins_erase_only_a_written_slot_and_within_the_budget() {
    let mut mem = Mem::new();
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    let good = sign(&other_model(), 1);
    let mut frame = [0u8; HOST_MAX_FRAME];
    let mut tx = Tx::default();
    let begin = HostMsg::ModelBegin { total_len: good.len() as u32, crc32: crc32(&good) };
    let begin = encode_host(&begin, &mut frame).unwrap().to_vec();
    for _ in 0..1000 {
        dev.feed(&begin, &mut tx).unwrap();
    }
    assert_eq!(dev.store().flash().erases, 1, "1 000 begins, one erase (the slot held garbage)");
    assert_eq!(dev.status().staging_erases, 1);
    assert_eq!(dev.status().updates_rejected, 0);
    // Data written, then begun again: one more erase, once.
    let chunk = HostMsg::ModelChunk { offset: 0, data: &good[..MAX_CHUNK] };
    dev.feed(encode_host(&chunk, &mut frame).unwrap(), &mut tx).unwrap();
    for _ in 0..1000 {
        dev.feed(&begin, &mut tx).unwrap();
    }
    assert_eq!(dev.status().staging_erases, 2);

    // A transfer that writes and is begun again, over and over: erases stop at the budget.
    let mut rounds = 0;
    let last = loop {
        let mut out = Tx::default();
        dev.feed(&begin, &mut out).unwrap();
        let msgs = fbg_shared_frames(&out.0);
        if let Some(DeviceMsg::UpdateResult(UpdateResult::Rejected(r))) = msgs.last() {
            break *r;
        }
        dev.feed(encode_host(&chunk, &mut frame).unwrap(), &mut tx).unwrap();
        rounds += 1;
        assert!(rounds < 100, "never refused");
    };
    assert_eq!(last, Rejection { reason: RejectReason::EraseLimit, detail: crate::store::ERASE_BUDGET });
    // Every erase since boot counts, the first one (garbage) too.
    assert_eq!(dev.status().staging_erases, crate::store::ERASE_BUDGET);
    assert_eq!(dev.store().flash().erases as u32, crate::store::ERASE_BUDGET);
    // The slot is written, so no whole update can be staged until an accepted update or a
    // restart renews the budget.
    let r = dev.handle(&HostMsg::ModelBegin { total_len: good.len() as u32, crc32: crc32(&good) });
    assert_eq!(reason(&r), Some(RejectReason::EraseLimit));
    assert_eq!(reason(&update_direct(&mut dev, &good)), Some(RejectReason::NoUpdateInProgress));
    drop(dev);
    let info = mem.boot(default_blob()).unwrap();
    let mut dev = mem.device(info);
    let r = update_direct(&mut dev, &good);
    assert!(matches!(r, DeviceMsg::UpdateResult(UpdateResult::Accepted { .. })), "after a restart: {r:?}");
    assert_eq!(dev.status().staging_erases, 1);
}

/// The device messages in `bytes`.
fn fbg_shared_frames(bytes: &[u8]) -> Vec<DeviceMsg> {
    let mut reader = FrameReader::<{ fbg_shared::protocol::DEVICE_MAX_FRAME }>::new();
    let mut out = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        let (ev, r) = reader.feed::<DeviceMsg>(rest);
        rest = r;
        if let Feed::Message(m) = ev {
            out.push(m);
        }
    }
    out
}

/// The embedded default: trusted as part of the image by default (a trailer it carries names
/// its serial and key), or required to be signed by a build option.
#[test]
fn the_embedded_model_is_trusted_or_must_be_signed() {
    let mut mem = Mem::new();
    let info = boot(&Kernel::LIBRARY, &policy(), false, &mut mem.comp, default_blob()).unwrap();
    assert_eq!((info.serial, info.key_id), (0, None));
    let e = boot(&Kernel::LIBRARY, &policy(), true, &mut mem.comp, default_blob()).unwrap_err();
    assert_eq!(e.reason, RejectReason::Unsigned);
    let signed = sign(default_blob(), 3);
    let info = boot(&Kernel::LIBRARY, &policy(), true, &mut mem.comp, &signed).unwrap();
    assert_eq!(
        (info.serial, info.key_id, info.crc),
        (3, Some(trusted(&lab()).id), blob::stored_crc(default_blob()).unwrap())
    );
    let foreign = sign_with(&stranger(), default_blob(), 3, SignFlags::NONE);
    assert_eq!(
        boot(&Kernel::LIBRARY, &policy(), true, &mut mem.comp, &foreign).unwrap_err().reason,
        RejectReason::UnknownKey
    );
    let info = boot(&Kernel::LIBRARY, &policy(), false, &mut mem.comp, &foreign).unwrap();
    assert_eq!(info.serial, 3, "trusted as part of the image, its trailer names it");
}

/// RFC 8032 section 7.1 TEST 1 through the verifier this crate links (fbg-shared's `verify`, the
/// device's code path built for the host; the other vectors are in fbg-shared's tests).
#[test]
fn the_device_verifier_passes_rfc8032_test_1() {
    let hex = |s: &str| -> Vec<u8> {
        (0..s.len()).step_by(2).map(|i| u8::from_str_radix(&s[i..i + 2], 16).unwrap()).collect()
    };
    let pk: [u8; 32] = hex("d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a").try_into().unwrap();
    let sig: [u8; 64] = hex("e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e065224901555fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b").try_into().unwrap();
    assert_eq!(signature::verify_message(&[], &sig, &pk), Ok(()));
    let mut bad = sig;
    bad[0] ^= 1;
    assert_eq!(signature::verify_message(&[], &bad, &pk), Err(SignatureError::BadSignature));
}
