//! The persistent model store: what a device accepted survives a reset (model, serial,
//! counters, rollback floor); a power cut at any flash operation of an update boots the old or
//! the new model, whole; wear stays within the documented rotation.

use std::string::String;

use super::signing::{reason, update_direct};
use super::*;
use crate::store::format::{PAYLOAD_AT, RECORDS_AT, RECORD_LEN};
use crate::store::{PowerCut, Store, ERASE_BUDGET, REFUSALS_LOGGED};
use fbg_shared::protocol::BootSource;

const E: usize = 8192;

/// One device's RAM (lost at every reset) over a flash that is kept.
struct Ram {
    comp: std::boxed::Box<Compensator<f32, K>>,
    reader: std::boxed::Box<FrameReader<HOST_MAX_FRAME>>,
}

impl Ram {
    fn new() -> Self {
        Ram { comp: std::boxed::Box::new(unloaded()), reader: std::boxed::Box::new(FrameReader::new()) }
    }

    /// Power on over `flash`: open the store, boot, serve.
    fn boot<F: MappedFlash>(&mut self, flash: F) -> Device<'_, Pin, F, K> {
        let mut store = Store::open(flash, STAGE).unwrap();
        let info = store.boot(&Kernel::LIBRARY, &policy(), false, &mut self.comp, default_blob()).unwrap();
        Device::new(&mut self.comp, Kernel::LIBRARY, policy(), &mut self.reader, info, store, Pin::default())
    }
}

fn accepted(m: &DeviceMsg) -> bool {
    matches!(m, DeviceMsg::UpdateResult(UpdateResult::Accepted { .. }))
}

/// The answers of `dev` to `s` from a fresh stream state, bit for bit.
fn answers<F: MappedFlash>(dev: &mut Device<'_, Pin, F, K>, s: &[Sample<f32>]) -> Vec<String> {
    let _ = dev.handle(&HostMsg::ResetStream { nonce: 1, clock: fbg_shared::StreamClock::Calibration });
    s.iter()
        .enumerate()
        .map(|(i, x)| match dev.handle(&HostMsg::Sample { seq: i as u32, sample: *x }) {
            DeviceMsg::Estimate(e) => format!("{:?} {:?} {:?}", e.values, e.band, e.flags),
            other => panic!("{other:?}"),
        })
        .collect()
}

/// What a fresh device answers with `blob_bytes` loaded (the reference of a model).
fn reference(blob_bytes: &[u8], s: &[Sample<f32>]) -> Vec<String> {
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    let mut ram = Ram::new();
    let mut dev = ram.boot(&mut flash);
    if blob_bytes != default_blob() {
        assert!(accepted(&update_direct(&mut dev, &sign(blob_bytes, 1))));
    }
    answers(&mut dev, s)
}

#[test]
fn an_accepted_update_survives_a_reset_with_its_serial_counters_and_floor() {
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    let s = samples(30);
    let other = other_model();
    let mut ram = Ram::new();
    let before = {
        let mut dev = ram.boot(&mut flash);
        assert_eq!(dev.status().store.boot_source, BootSource::Embedded, "garbage flash: the embedded model");
        assert!(accepted(&update_direct(&mut dev, &sign(&other, 5))));
        let st = dev.status();
        assert_eq!((st.model_serial, st.updates_accepted, st.store.rollback_floor), (5, 1, 5));
        answers(&mut dev, &s)
    };
    assert_eq!(before, reference(&other, &s));
    assert_ne!(before, reference(default_blob(), &s), "the two models must differ for the test to prove anything");

    // Reset: everything in RAM is gone.
    let mut ram = Ram::new();
    let mut dev = ram.boot(&mut flash);
    let st = dev.status();
    assert!(matches!(st.store.boot_source, BootSource::Slot { generation: 1, .. }), "{:?}", st.store);
    assert_eq!((st.model_serial, st.model_crc), (5, blob::stored_crc(&other).unwrap()));
    assert_eq!(st.model_key_id, Some(trusted(&lab()).id));
    assert_eq!((st.updates_accepted, st.updates_rejected, st.store.rollback_floor), (1, 0, 5));
    assert_eq!(answers(&mut dev, &s), before, "the same model, bit for bit");
    // An older serial replayed after the reset: refused, and the refusal is logged.
    assert_eq!(reason(&update_direct(&mut dev, &sign(default_blob(), 3))), Some(RejectReason::Rollback));
    assert_eq!(dev.status().model_serial, 5);
    drop(dev);
    let mut ram = Ram::new();
    let dev = ram.boot(&mut flash);
    let st = dev.status();
    assert_eq!((st.updates_accepted, st.updates_rejected, st.refused.rollback), (1, 1, 1), "from the log");
    assert_eq!(st.store.log_events, 2);
}

/// The flash of a device that accepted `old` (serial 3) and was reset.
fn with_old_model(old: &[u8]) -> Slot {
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    let mut ram = Ram::new();
    let mut dev = ram.boot(&mut flash);
    assert!(accepted(&update_direct(&mut dev, &sign(old, 3))));
    drop(dev);
    flash
}

/// Update `flash` to `new` (serial 5) with the power cut in flash operation `cut_at`; then
/// power on: the model that boots (serial), the answers, and whether the update was
/// acknowledged before the cut.
fn cut_update(flash: &mut Slot, new: &[u8], cut_at: u32, s: &[Sample<f32>]) -> (u64, Vec<String>, bool) {
    let mut ram = Ram::new();
    let acknowledged = {
        let mut dev = ram.boot(PowerCut::new(&mut *flash, cut_at, || {}));
        accepted(&update_direct(&mut dev, &sign(new, 5)))
    };
    let mut ram = Ram::new();
    let mut dev = ram.boot(&mut *flash);
    let st = dev.status();
    assert!(
        matches!(st.store.boot_source, BootSource::Slot { .. }),
        "cut at {cut_at}: booted {:?}: neither the old nor the new model",
        st.store.boot_source
    );
    (st.model_serial, answers(&mut dev, s), acknowledged)
}

/// The torture, exhaustively on the host: the power cut in every flash operation of an
/// update (the erase of the inactive slot, its erase count, every program of the payload, the
/// header, COMPLETE, ACTIVE, the log record); each restart boots the old or the new model
/// whole, the new one from the ACTIVE word on, and never a model the host was told was refused.
#[test]
fn a_power_cut_anywhere_in_an_update_boots_the_old_or_the_new_model() {
    let s = samples(12);
    let (old, new) = (default_blob().to_vec(), other_model());
    let (want_old, want_new) = (reference(&old, &s), reference(&new, &s));
    // The operations of one clean update.
    let total_ops = {
        let mut flash = with_old_model(&old);
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        let before = dev.status().store.flash_ops;
        assert!(accepted(&update_direct(&mut dev, &sign(&new, 5))));
        let st = dev.status();
        st.store.flash_ops - before
    };
    assert!(total_ops > 100, "an update is {total_ops} operations");
    let mut first_new = None;
    for cut in 1..=total_ops + 1 {
        let mut flash = with_old_model(&old);
        let (serial, got, acknowledged) = cut_update(&mut flash, &new, cut, &s);
        match serial {
            3 => {
                assert_eq!(got, want_old, "cut at {cut}: the old model, whole");
                assert!(first_new.is_none(), "cut at {cut}: old again after new from {first_new:?}");
            }
            5 => {
                assert_eq!(got, want_new, "cut at {cut}: the new model, whole");
                first_new.get_or_insert(cut);
            }
            other => panic!("cut at {cut}: serial {other}"),
        }
        assert!(!acknowledged || serial == 5 || cut > total_ops, "cut at {cut}: acknowledged, yet the old model boots");
        if cut > total_ops {
            assert!(acknowledged && serial == 5, "no cut: the update goes through");
        }
        // The boot after the cut repaired the log: a second reset agrees, and the lifetime
        // count of accepted updates says which model runs.
        let mut ram = Ram::new();
        let dev = ram.boot(&mut flash);
        let st = dev.status();
        assert_eq!(st.model_serial, serial, "cut at {cut}: the second boot differs");
        assert_eq!(st.updates_accepted, if serial == 5 { 2 } else { 1 }, "cut at {cut}");
    }
    // The new model boots from its ACTIVE word on: the last two operations are ACTIVE and the
    // log record (a cut in the ACTIVE program may leave the word whole, as half of its unit
    // holds it, or not).
    let first_new = first_new.expect("the new model boots once the update is done");
    assert!((total_ops - 1..=total_ops).contains(&first_new), "new from cut {first_new} of {total_ops}");
}

/// A rollback (allowed by the test policy, signed to replace serial 5) cut anywhere: its slot
/// is below the floor until its log record lowers it, so it boots only once that record is
/// whole; before, the old model does — never the embedded one.
#[test]
fn a_power_cut_anywhere_in_a_rollback_boots_the_old_or_the_rollback() {
    let s = samples(12);
    let (old, back) = (other_model(), default_blob().to_vec());
    let fresh = || {
        let mut flash = Slot::new(crate::store::STORE_UNITS);
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        assert!(accepted(&update_direct(&mut dev, &sign(&old, 5))));
        drop(dev);
        flash
    };
    let rollback = sign_rollback(&back, 4, 5);
    let total_ops = {
        let mut flash = fresh();
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        let before = dev.status().store.flash_ops;
        assert!(accepted(&update_direct(&mut dev, &rollback)));
        dev.status().store.flash_ops - before
    };
    let (want_old, want_back) = (reference(&old, &s), reference(&back, &s));
    for cut in 1..=total_ops {
        let mut flash = fresh();
        {
            let mut ram = Ram::new();
            let mut dev = ram.boot(PowerCut::new(&mut flash, cut, || {}));
            let _ = update_direct(&mut dev, &rollback);
        }
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        let st = dev.status();
        assert!(matches!(st.store.boot_source, BootSource::Slot { .. }), "cut at {cut}: {:?}", st.store);
        let got = answers(&mut dev, &s);
        match st.model_serial {
            5 => assert_eq!(got, want_old, "cut at {cut}"),
            4 => {
                assert_eq!(got, want_back, "cut at {cut}");
                assert_eq!(cut, total_ops, "cut at {cut}: the rollback boots before its log record");
            }
            other => panic!("cut at {cut}: serial {other}"),
        }
    }
}

/// A power cut while the log rotates to its other sector (its erase, its header) loses no
/// count: the totals of the full sector are read again and the rotation is redone.
#[test]
fn a_power_cut_in_a_log_rotation_loses_no_count() {
    let per_sector = (E - RECORDS_AT) / RECORD_LEN;
    let other = other_model();
    let file = sign(&other, 5);
    // Fill the first log sector but for one record: the next update's record rotates.
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    {
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        for _ in 0..per_sector {
            assert!(accepted(&update_direct(&mut dev, &file)));
        }
        assert_eq!(dev.status().store.log_events as usize, per_sector);
    }
    let filled = flash.mem.clone();
    let ops = {
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        let before = dev.status().store.flash_ops;
        assert!(accepted(&update_direct(&mut dev, &file)));
        dev.status().store.flash_ops - before
    };
    // The rotation is the update's last operations: erase, sector header, log header, record.
    for back in 0..5 {
        flash.mem.copy_from_slice(&filled);
        let cut = ops - back;
        let mut ram = Ram::new();
        {
            let mut dev = ram.boot(PowerCut::new(&mut flash, cut, || {}));
            let _ = update_direct(&mut dev, &file);
        }
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        let st = dev.status();
        assert_eq!(st.model_serial, 5);
        let logged = per_sector as u32 + u32::from(back == 0);
        assert!(st.updates_accepted >= per_sector as u32, "cut {back} from the end: {}", st.updates_accepted);
        assert!(st.updates_accepted <= logged + 1, "cut {back} from the end: {}", st.updates_accepted);
        // And the log goes on.
        assert!(accepted(&update_direct(&mut dev, &file)));
        assert_eq!(dev.status().updates_accepted, st.updates_accepted + 1);
    }
}

/// The wear loop: 1 000 updates. The slots alternate (one erase each per two
/// updates), the log rotates through its two sectors (one erase per `(E − 96) / 64` records),
/// and the lifetime counters carried across the rotations are exact after a reset.
#[test]
fn a_thousand_updates_wear_within_the_rotation() {
    const N: u32 = 1000;
    let per_sector = ((E - RECORDS_AT) / RECORD_LEN) as u32;
    let file = sign(&other_model(), 5);
    // A factory-fresh part, so that the counts start at zero.
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    flash.mem.fill(0xFF);
    {
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        for i in 0..N {
            let before = dev.store().flash().erases;
            assert!(accepted(&update_direct(&mut dev, &file)), "update {i}");
            let erased = dev.store().flash().erases - before;
            assert!(erased <= 2, "update {i}: {erased} erases");
        }
    }
    let mut ram = Ram::new();
    let dev = ram.boot(&mut flash);
    let st = dev.status();
    assert_eq!((st.updates_accepted, st.store.log_events), (N, N));
    let [a, b, l0, l1] = st.store.erases;
    // Each slot is written every other update, erased before each but its first.
    assert!(a.abs_diff(N / 2) <= 1 && b.abs_diff(N / 2) <= 1, "slots {a}, {b}");
    // Each rotation erases one log sector, alternately (the first use of each needs none).
    let rotations = (N - 1) / per_sector;
    assert_eq!(l0 + l1 + 1, rotations, "log sectors {l0}, {l1} for {rotations} rotations");
    assert!(l0.abs_diff(l1) <= 1, "log sectors {l0}, {l1}");
    assert_eq!(dev.store().flash().erases as u32, a + b + l0 + l1, "every erase counted in its sector");
}

/// Refusals are logged up to the budget per accepted update, the rest counted in RAM only;
/// the logged ones survive a reset with their reasons.
#[test]
fn refusals_are_logged_within_the_budget() {
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    let unsigned = other_model();
    {
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        // More than the log takes, fewer than the erase budget allows transfers.
        const N: u32 = 12;
        const _: () = assert!(REFUSALS_LOGGED < N && N <= ERASE_BUDGET);
        for _ in 0..N {
            assert_eq!(reason(&update_direct(&mut dev, &unsigned)), Some(RejectReason::Unsigned));
        }
        let st = dev.status();
        assert_eq!((st.updates_rejected, st.refused.unsigned), (N, N));
        assert_eq!(st.store.refusals_unlogged, N - REFUSALS_LOGGED);
        assert_eq!(st.store.log_events, REFUSALS_LOGGED);
        // The slot held refused bytes every time (garbage the first): erased before each.
        assert_eq!(st.staging_erases, N);
    }
    let mut ram = Ram::new();
    let dev = ram.boot(&mut flash);
    let st = dev.status();
    assert_eq!((st.updates_rejected, st.refused.unsigned), (REFUSALS_LOGGED, REFUSALS_LOGGED));
    assert_eq!(st.store.boot_source, BootSource::Embedded);
}

/// A newest slot that no longer verifies (one flipped bit) is passed over; the older slot is
/// below the floor, so the embedded model boots — and the floor still holds: an update below
/// it is refused, one at it is accepted.
#[test]
fn a_corrupted_slot_falls_back_without_lowering_the_floor() {
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    let other = other_model();
    {
        let mut ram = Ram::new();
        let mut dev = ram.boot(&mut flash);
        assert!(accepted(&update_direct(&mut dev, &sign(default_blob(), 3))));
        assert!(accepted(&update_direct(&mut dev, &sign(&other, 5))));
        assert!(matches!(dev.status().store.boot_source, BootSource::Embedded));
    }
    // Slot B (the second update) loses a bit of its model.
    flash.mem[E + PAYLOAD_AT + 100] ^= 0x10;
    let mut ram = Ram::new();
    let mut dev = ram.boot(&mut flash);
    let st = dev.status();
    assert_eq!(st.store.boot_source, BootSource::Embedded, "slot A's serial 3 is below the floor 5");
    assert_eq!((st.model_serial, st.store.rollback_floor), (0, 5));
    assert_eq!(reason(&update_direct(&mut dev, &sign(&other, 4))), Some(RejectReason::Rollback));
    assert!(accepted(&update_direct(&mut dev, &sign(&other, 5))));
    drop(dev);
    let mut ram = Ram::new();
    let dev = ram.boot(&mut flash);
    assert_eq!(dev.status().model_serial, 5);
}

/// A factory-fresh part (all erased): the first update erases nothing but what it needs.
#[test]
fn a_fresh_part_boots_the_embedded_model_and_takes_an_update() {
    let mut flash = Slot::new(crate::store::STORE_UNITS);
    flash.mem.fill(0xFF);
    let mut ram = Ram::new();
    let mut dev = ram.boot(&mut flash);
    assert_eq!(dev.status().store, fbg_shared::protocol::StoreStatus::default());
    assert!(accepted(&update_direct(&mut dev, &sign(&other_model(), 1))));
    assert_eq!(dev.status().store.erases, [0; 4], "blank sectors need no erase");
    assert_eq!(dev.store().flash().erases, 0);
}
