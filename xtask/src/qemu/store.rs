//! The persistent model store under QEMU: every device here keeps its flash in
//! its own directory's `fbg-flash.bin` across power cycles (`firmware::emulator`).
//!
//! - persistence: an accepted update survives a power cycle with its serial, digest, lifetime
//!   counters and rollback floor, and answers bit for bit as before; a replayed older serial
//!   is refused after the cycle, and the refusal counters survive the next one;
//! - power-loss torture: one clean update counted in flash operations, then the same update
//!   cut by the `torture` image at operations spread over all of it (the erase and header of
//!   the inactive slot, the payload, densely over the commit: slot header, COMPLETE, ACTIVE,
//!   log record); after each cut the product image must boot a whole model, the old or the
//!   new, never the embedded default and never a mix, answering bit for bit like a clean
//!   device running it;
//! - wear: many updates in a row; the slots' erases alternate, the log's sectors rotate within
//!   their bound, and no update erases more than twice.

use std::fs;
use std::path::Path;
use std::time::Instant;

use anyhow::{bail, ensure, Context, Result};
use fbg_shared::blob::stored_crc;
use fbg_shared::protocol::{BootSource, RejectReason, Status, UpdateResult};
use fbg_shared::Sample;

use super::expect_rejected;
use super::signed::answers;
use crate::firmware::emulator::{device_dir, fresh_device, FLASH_FILE};
use crate::firmware::session::LinkSession;
use crate::firmware::{self, Bins};
use crate::fixtures::{self, Fixtures};
use crate::signing::SignedFixtures;
use crate::targets::{STORE_LOG_RECORDS_PER_SECTOR, TARGET_ERASES_PER_UPDATE};

/// Exit code of the `torture` image when its power was cut (`firmware/src/bin/torture.rs`).
const CUT_EXIT: i32 = 3;
/// Power cuts of the torture test under `--all` (the 50) and in `cargo xtask test`.
const CUTS_ALL: usize = 50;
const CUTS_SAMPLED: usize = 10;
/// Updates of the wear test under `--all` (the 1 000) and in `cargo xtask test`
/// (enough to rotate the log once: more than a log sector's records).
const WEAR_ALL: usize = 1000;
const WEAR_SAMPLED: usize = 300;

/// Answers of a model to the test's samples, bit for bit.
type Answers = Vec<([u32; 6], String)>;

/// What a clean device answers with each model, and the identity of each.
struct Reference {
    samples: Vec<Sample<f32>>,
    /// Serial 3 (the default model signed), from a device that accepted it and was cycled.
    old: Answers,
    old_crc: Option<u32>,
    /// Serial 5 (the update model), from the persistence test's device.
    new: Answers,
    new_crc: Option<u32>,
}

/// Every store test; `all`: the long forms (every torture cut, 1 000 updates of wear).
pub(super) fn store_tests(
    root: &Path,
    qemu: &Path,
    bins: &Bins,
    fx: &Fixtures,
    sfx: &SignedFixtures,
    all: bool,
) -> Result<()> {
    let started = Instant::now();
    let mut reference = persistence_test(root, qemu, bins, fx, sfx)?;
    eprintln!("xtask: store: persistence test took {:.1} s", started.elapsed().as_secs_f64());
    let t = Instant::now();
    torture_test(root, qemu, bins, sfx, &mut reference, all)?;
    eprintln!("xtask: store: torture test took {:.1} s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    wear_test(root, qemu, bins, sfx, if all { WEAR_ALL } else { WEAR_SAMPLED })?;
    eprintln!("xtask: store: wear test took {:.1} s", t.elapsed().as_secs_f64());
    eprintln!(
        "xtask: store tests ({}) passed in {:.1} s",
        if all { "--all" } else { "sampled" },
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `r` accepted (`what` names the update in the messages).
fn expect_accepted(r: UpdateResult, what: &str) -> Result<()> {
    ensure!(matches!(r, UpdateResult::Accepted { .. }), "{what}: expected it accepted, got {r:?}");
    Ok(())
}

/// Update → power cycle → the device serves the new model bit for bit with its serial,
/// counters and floor; a replayed older serial is refused after the cycle, and the refusal
/// survives the next. Returns the clean answers of serial 5 (and the digests of both) for the
/// torture test.
fn persistence_test(root: &Path, qemu: &Path, bins: &Bins, fx: &Fixtures, sfx: &SignedFixtures) -> Result<Reference> {
    let default = fs::read(firmware::dir(root).join("model/default.fbgm"))?;
    let new = fs::read(&sfx.new)?;
    let new_crc = stored_crc(fbg_shared::container::strip(&new));
    let samples: Vec<_> = fixtures::read_inputs(&fx.golden_inputs)?.into_iter().take(40).collect();
    let mut s = LinkSession::start(root, qemu, &bins.product, "store-persist")?;
    let st = s.link()?.status()?;
    ensure!(
        st.store.boot_source == BootSource::Embedded && st.model_serial == 0 && st.store.log_events == 0,
        "a fresh device must boot its embedded model with an empty log: {:?}",
        st.store
    );
    let embedded = answers(&mut s, &samples)?;

    expect_accepted(s.link()?.update_model(&new)?, "serial 5 on a fresh device")?;
    let before = answers(&mut s, &samples)?;
    ensure!(before != embedded, "the update model answers like the default one; the test would prove nothing");

    s.power_cycle(&bins.product, &[], &[])?;
    let st = s.link()?.status()?;
    ensure!(
        matches!(st.store.boot_source, BootSource::Slot { .. })
            && (st.model_serial, Some(st.model_crc)) == (5, new_crc)
            && st.updates_accepted == 1
            && st.store.rollback_floor == 5,
        "after a power cycle the device must boot serial 5 from a slot with 1 update accepted and floor 5: \
         serial {}, crc {:#x}, accepted {}, {:?}",
        st.model_serial,
        st.model_crc,
        st.updates_accepted,
        st.store
    );
    ensure!(answers(&mut s, &samples)? == before, "after the power cycle serial 5 answers differently");
    eprintln!(
        "xtask: store: serial 5 survived a power cycle ({:?}, floor {}, {} log events), answering bit for bit as before",
        st.store.boot_source, st.store.rollback_floor, st.store.log_events
    );

    expect_rejected(
        s.link()?.update_model(&fs::read(&sfx.old)?)?,
        RejectReason::Rollback,
        "serial 3 replayed after the power cycle",
    )?;
    s.power_cycle(&bins.product, &[], &[])?;
    let st = s.link()?.status()?;
    ensure!(
        (st.model_serial, st.updates_accepted, st.updates_rejected, st.refused.rollback) == (5, 1, 1, 1),
        "after a second power cycle: serial {}, accepted {}, refused {}, rollback refusals {} \
         (expected 5, 1, 1, 1: the counters come from the log)",
        st.model_serial,
        st.updates_accepted,
        st.updates_rejected,
        st.refused.rollback
    );
    ensure!(answers(&mut s, &samples)? == before, "after the second power cycle serial 5 answers differently");
    eprintln!("xtask: store: the rollback refusal and the counters survived the next power cycle");
    s.disconnect()?;
    s.check_alive()?;
    Ok(Reference { samples, old: Vec::new(), old_crc: stored_crc(&default), new: before, new_crc })
}

/// The cut points of an update of `ops` flash operations: the first (the erase of the inactive
/// slot, its sector header), every one of the last twelve (padding, slot header, COMPLETE,
/// ACTIVE, the log record and what precedes them), and the rest evenly over the payload, `n`
/// in all (fewer when the update has fewer operations).
pub(crate) fn cut_points(ops: u32, n: usize) -> Vec<u32> {
    let mut points: Vec<u32> = (1..=ops.min(4)).collect();
    points.extend(ops.saturating_sub(11).max(1)..=ops);
    points.sort_unstable();
    points.dedup();
    let (lo, hi) = (5u32, ops.saturating_sub(12));
    let room = n.saturating_sub(points.len());
    if hi >= lo && room > 0 {
        let span = f64::from(hi - lo);
        for i in 0..room {
            let at = lo + (span * i as f64 / (room.max(2) - 1) as f64).round() as u32;
            points.push(at.min(hi));
        }
    }
    points.sort_unstable();
    points.dedup();
    points
}

/// `n` of `points` spread evenly, the first and the last among them.
fn sample(points: &[u32], n: usize) -> Vec<u32> {
    if points.len() <= n || n < 2 {
        return points.to_vec();
    }
    let mut out: Vec<u32> =
        (0..n).map(|i| points[(i * (points.len() - 1) + (n - 1) / 2) / (n - 1)]).collect::<Vec<_>>();
    out.dedup();
    out
}

/// A device with serial 1 then serial 3 accepted and power-cycled: the old model in a slot,
/// and the other slot written too, so that the next update starts with the erase a device in
/// service needs (a factory-blank slot needs none).
fn old_device(root: &Path, qemu: &Path, bins: &Bins, sfx: &SignedFixtures, name: &str) -> Result<LinkSession> {
    let mut s = LinkSession::start(root, qemu, &bins.product, name)?;
    expect_accepted(s.link()?.update_model(&fs::read(&sfx.update)?)?, "serial 1 on a fresh device")?;
    expect_accepted(s.link()?.update_model(&fs::read(&sfx.old)?)?, "serial 3 over serial 1")?;
    s.power_cycle(&bins.product, &[], &[])?;
    let st = s.link()?.status()?;
    ensure!(
        matches!(st.store.boot_source, BootSource::Slot { .. }) && st.model_serial == 3,
        "serial 3 did not boot from its slot: serial {}, {:?}",
        st.model_serial,
        st.store
    );
    Ok(s)
}

/// The update of serial 5 over serial 3, cut at power points spread over it; each restart
/// must boot a whole model (the old or the new) answering like a clean device.
fn torture_test(
    root: &Path,
    qemu: &Path,
    bins: &Bins,
    sfx: &SignedFixtures,
    reference: &mut Reference,
    all: bool,
) -> Result<()> {
    let new = fs::read(&sfx.new)?;
    // The clean update, counted, on a clean device running serial 3 (whose answers are the
    // old model's reference).
    let mut s = old_device(root, qemu, bins, sfx, "store-torture")?;
    reference.old = answers(&mut s, &reference.samples)?;
    ensure!(reference.old != reference.new, "serials 3 and 5 answer alike; the torture test would prove nothing");
    let before = s.link()?.status()?.store;
    expect_accepted(s.link()?.update_model(&new)?, "serial 5 (clean run)")?;
    let after = s.link()?.status()?.store;
    let ops = after.flash_ops - before.flash_ops;
    let erases: u32 = after.erases.iter().sum::<u32>() - before.erases.iter().sum::<u32>();
    ensure!(ops > 12, "one update took only {ops} flash operations; the store does not program what it receives");
    ensure!(erases >= 1, "the update did not erase the inactive slot, which held serial 1");
    ensure!(
        erases <= TARGET_ERASES_PER_UPDATE,
        "one update erased {erases} sectors (at most {TARGET_ERASES_PER_UPDATE})"
    );
    eprintln!("xtask: store: one update of {} B: {ops} flash operations, {erases} erase(s)", new.len());
    s.disconnect()?;
    drop(s);

    // The device before the update, made once: its flash file is copied for every cut.
    let dir = device_dir(root, "store-torture")?;
    let mut s = old_device(root, qemu, bins, sfx, "store-torture")?;
    s.disconnect()?;
    s.qemu.kill();
    drop(s);
    let snapshot = dir.join("serial-3.bin");
    fs::copy(dir.join(FLASH_FILE), &snapshot).context("saving the flash of the device running serial 3")?;

    let every = cut_points(ops, CUTS_ALL);
    ensure!(every.len() >= CUTS_ALL, "only {} distinct cut points in an update of {ops} operations", every.len());
    let cuts = if all { every.clone() } else { sample(&every, CUTS_SAMPLED) };
    eprintln!("xtask: store: {} power cuts at operations {cuts:?} of {ops}", cuts.len());
    let (mut booted_old, mut booted_new) = (Vec::new(), Vec::new());
    let started = Instant::now();
    for &cut in &cuts {
        fresh_device(&dir)?;
        fs::copy(&snapshot, dir.join(FLASH_FILE))?;
        let arg = format!("cut={cut}");
        let mut s = LinkSession::resume(root, qemu, &bins.torture, "store-torture", &[&arg])?;
        // The link drops when the power is cut; the answer, if any, does not matter.
        let answer = s.link()?.update_model(&new);
        let status = s.qemu.wait(std::time::Duration::from_secs(60))?;
        if status.code() != Some(CUT_EXIT) {
            s.qemu.show_log();
            bail!("cut at operation {cut}: the torture image ended with {status} (answer {answer:?}), not the cut's exit code {CUT_EXIT}");
        }
        s.power_cycle(&bins.product, &[], &[])?;
        let st = s.link()?.status()?;
        let got = answers(&mut s, &reference.samples)?;
        let whole = check_whole(&st, &got, reference)
            .with_context(|| format!("after a power cut at operation {cut} of {ops}"))?;
        if whole == 3 {
            booted_old.push(cut);
            // The interrupted update leaves nothing in the way of the next one.
            expect_accepted(s.link()?.update_model(&new)?, &format!("serial 5 again after the cut at {cut}"))?;
        } else {
            booted_new.push(cut);
        }
        s.disconnect()?;
        s.check_alive()?;
    }
    let per_cut = started.elapsed().as_secs_f64() / cuts.len() as f64;
    eprintln!(
        "xtask: store: {} power cuts: {} booted the old model (serial 3; cuts {booted_old:?}), {} the new (serial 5; cuts {booted_new:?}), none neither or a mix; {per_cut:.2} s per cut",
        cuts.len(),
        booted_old.len(),
        booted_new.len()
    );
    Ok(())
}

/// The device after a cut runs the old model (serial 3) or the new (serial 5) from a slot,
/// whole: its digest, floor and answers those of a clean device running it. Returns the serial.
fn check_whole(st: &Status, got: &Answers, r: &Reference) -> Result<u64> {
    ensure!(
        matches!(st.store.boot_source, BootSource::Slot { .. }),
        "the device booted {:?} (serial {}): neither the old model nor the new",
        st.store.boot_source,
        st.model_serial
    );
    let (crc, want) = match st.model_serial {
        3 => (r.old_crc, &r.old),
        5 => (r.new_crc, &r.new),
        other => bail!("the device runs serial {other}, neither 3 nor 5"),
    };
    ensure!(Some(st.model_crc) == crc, "serial {} with digest {:#x}, not its model's", st.model_serial, st.model_crc);
    ensure!(
        st.store.rollback_floor == st.model_serial,
        "serial {} runs under rollback floor {}",
        st.model_serial,
        st.store.rollback_floor
    );
    ensure!(
        got == want,
        "serial {} does not answer bit for bit like a clean device running it (a mix)",
        st.model_serial
    );
    Ok(st.model_serial)
}

/// `n` updates in a row (serial 5, then the same signed file again: a re-install), each
/// counted; the slots' erases alternate, the log's sectors stay within their rotation.
fn wear_test(root: &Path, qemu: &Path, bins: &Bins, sfx: &SignedFixtures, n: usize) -> Result<()> {
    let new = fs::read(&sfx.new)?;
    let mut s = LinkSession::start(root, qemu, &bins.product, "store-wear")?;
    let started = Instant::now();
    let mut prev = s.link()?.status()?.store;
    let (mut max_erases, mut max_ops) = (0u32, 0u32);
    for i in 0..n {
        expect_accepted(s.link()?.update_model(&new)?, &format!("update {} of {n}", i + 1))?;
        let st = s.link()?.status()?.store;
        let erases = st.erases.iter().sum::<u32>() - prev.erases.iter().sum::<u32>();
        ensure!(
            erases <= TARGET_ERASES_PER_UPDATE,
            "update {} erased {erases} sectors (at most {TARGET_ERASES_PER_UPDATE})",
            i + 1
        );
        max_erases = max_erases.max(erases);
        max_ops = max_ops.max(st.flash_ops - prev.flash_ops);
        prev = st;
    }
    let secs = started.elapsed().as_secs_f64();
    s.power_cycle(&bins.product, &[], &[])?;
    let st = s.link()?.status()?;
    let [a, b, l0, l1] = st.store.erases;
    // One erase of the inactive slot per update, but none for the first update into each
    // factory-blank slot: the slots share them within one.
    ensure!(
        (n as u32).saturating_sub(2) <= a + b && a + b <= n as u32 && a.abs_diff(b) <= 1,
        "after {n} updates the slots were erased {a} and {b} times (≈ {} each: they must alternate)",
        n / 2
    );
    // Each log sector is erased once per rotation onto it; one rotation per sector of records.
    let events = st.store.log_events;
    let rotations = events / STORE_LOG_RECORDS_PER_SECTOR + 1;
    ensure!(
        l0 + l1 <= rotations + 1 && l0.abs_diff(l1) <= 1,
        "after {events} log events the log sectors were erased {l0} and {l1} times (bound: {} in all, within one of each other)",
        rotations + 1
    );
    ensure!(
        st.updates_accepted as usize == n && st.model_serial == 5,
        "after {n} updates and a power cycle: {} accepted, serial {}",
        st.updates_accepted,
        st.model_serial
    );
    eprintln!(
        "xtask: store: wear: {n} updates in {secs:.1} s ({:.0} ms each); erases per sector A {a}, B {b}, log 0 {l0}, log 1 {l1} \
         ({events} log events); at most {max_erases} erase(s) and {max_ops} flash operations per update",
        secs * 1000.0 / n as f64
    );
    s.disconnect()?;
    s.check_alive()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cut_points_cover_the_start_the_payload_and_every_commit_step() {
        let p = cut_points(330, CUTS_ALL);
        assert_eq!(p.len(), CUTS_ALL, "{p:?}");
        assert!(p.starts_with(&[1, 2, 3, 4]), "{p:?}");
        assert!(p.ends_with(&(319..=330).collect::<Vec<_>>()), "{p:?}");
        assert!(p.windows(2).all(|w| w[0] < w[1]));
        let s = sample(&p, CUTS_SAMPLED);
        assert_eq!(s.len(), CUTS_SAMPLED, "{s:?}");
        assert_eq!((s[0], s[s.len() - 1]), (1, 330));
        assert_eq!(cut_points(20, CUTS_ALL), (1..=20).collect::<Vec<_>>());
    }
}
