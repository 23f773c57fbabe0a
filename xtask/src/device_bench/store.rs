//! The model store's figures: the flash operations and erases of one update, and
//! the boot time with an empty and with a full event log.
//!
//! On the product image over the link, on its own device directory (`target/qemu/bench-store/`,
//! factory-fresh first). The log is filled the way a device in service fills it: accepted
//! updates (the same signed model re-installed) and, between two of them, the refusals the
//! store writes to the log ([`REFUSALS_LOGGED`] unsigned models), until both log sectors are
//! full ([`FULL_LOG`] records: the next event would erase the older sector); one more update
//! then rotates the log, the worst case of erases per update. Boot times are
//! `Status::store.boot_time_us` — SysTick from the start of `main` to serving — after a power
//! cycle under `qemu-system-arm -icount shift=0`, where emulated time is one nanosecond per
//! instruction: a boot time of t µs is 1 000 t instructions (on a part at f MHz, about
//! 1 000 t / f µs at one instruction per cycle). It includes loading the flash file (one
//! semihosting call, which a part does not make) and, from a slot, the signature check of the
//! model there.

use std::fs;
use std::path::Path;

use anyhow::{ensure, Result};
use fbg_shared::protocol::{BootSource, StoreStatus, UpdateResult};

use crate::firmware::session::LinkSession;
use crate::firmware::Bins;
use crate::signing::SignedFixtures;
use crate::targets::{STORE_LOG_RECORDS_PER_SECTOR, TARGET_BOOT_US, TARGET_ERASES_PER_UPDATE};

/// Both log sectors full: the most records a boot scans.
pub const FULL_LOG: u32 = 2 * STORE_LOG_RECORDS_PER_SECTOR;
/// Refusals the store logs between two accepted updates (`fbg_firmware_app::store::REFUSALS_LOGGED`).
const REFUSALS_LOGGED: u32 = 8;

/// What the store bench measured.
#[derive(Clone, Debug, Default)]
pub struct StoreBench {
    /// Bytes of the signed model of the updates.
    pub update_bytes: u64,
    /// Flash operations (erases and programs) of one accepted update, the most seen.
    pub ops_per_update: u32,
    /// Erases of one accepted update, the most seen.
    pub erases_per_update: u32,
    /// Accepted updates measured.
    pub updates: u32,
    /// Boot time with a factory-fresh store (the embedded model), µs of emulated time.
    pub boot_us_empty: u32,
    /// Boot time with [`FULL_LOG`] records in the log and the model in a slot, µs of emulated
    /// time.
    pub boot_us_full_log: u32,
    /// Boot time with the model in a slot and one record in the log, µs of emulated time.
    pub boot_us_one_record: u32,
    /// Log records at that boot.
    pub log_events: u32,
    /// Erases of the update whose record rotated the full log.
    pub rotation_erases: u32,
    /// Erases per sector at the end (slot A, slot B, log 0, log 1); refused transfers erase
    /// the inactive slot too.
    pub erases: [u32; 4],
}

/// Status after a power cycle under `-icount shift=0`.
fn timed_boot(s: &mut LinkSession, bins: &Bins) -> Result<StoreStatus> {
    s.power_cycle(&bins.product, &[], &["-icount", "shift=0"])?;
    Ok(s.link()?.status()?.store)
}

/// Fill the log of a fresh device to [`FULL_LOG`] records and time its boots (see the module).
pub fn measure(root: &Path, q: &Path, bins: &Bins, sfx: &SignedFixtures) -> Result<StoreBench> {
    crate::cmd::step("store: flash operations per update, boot time with a full event log (-icount)");
    let signed = fs::read(&sfx.update)?;
    let unsigned = fbg_shared::container::strip(&signed).to_vec();
    let mut s = LinkSession::start(root, q, &bins.product, "bench-store")?;
    let empty = timed_boot(&mut s, bins)?;
    ensure!(empty.boot_source == BootSource::Embedded, "a fresh device booted {:?}", empty.boot_source);

    let mut b =
        StoreBench { update_bytes: signed.len() as u64, boot_us_empty: empty.boot_time_us, ..Default::default() };
    // The same boot from a slot with one record in the log: the difference is the log's.
    let r = s.link()?.update_model(&signed)?;
    ensure!(matches!(r, UpdateResult::Accepted { .. }), "the first update: {r:?}");
    let short = timed_boot(&mut s, bins)?;
    ensure!(short.log_events == 1, "one update, {} log events", short.log_events);
    b.boot_us_one_record = short.boot_time_us;
    let mut st = s.link()?.status()?.store;
    while st.log_events < FULL_LOG {
        let r = s.link()?.update_model(&signed)?;
        ensure!(matches!(r, UpdateResult::Accepted { .. }), "update {}: {r:?}", b.updates + 1);
        let after = s.link()?.status()?.store;
        b.updates += 1;
        b.ops_per_update = b.ops_per_update.max(after.flash_ops - st.flash_ops);
        b.erases_per_update = b.erases_per_update.max(after.erases.iter().sum::<u32>() - st.erases.iter().sum::<u32>());
        st = after;
        let refusals = REFUSALS_LOGGED.min(FULL_LOG - st.log_events);
        for _ in 0..refusals {
            let r = s.link()?.update_model(&unsigned)?;
            ensure!(matches!(r, UpdateResult::Rejected(_)), "an unsigned model was not refused: {r:?}");
        }
        st = s.link()?.status()?.store;
    }
    ensure!(
        st.log_events == FULL_LOG && st.refusals_unlogged == 0,
        "the fill left {} log events ({} refusals unlogged), expected {FULL_LOG}",
        st.log_events,
        st.refusals_unlogged
    );
    let full = timed_boot(&mut s, bins)?;
    ensure!(
        matches!(full.boot_source, BootSource::Slot { .. }) && full.log_events == FULL_LOG,
        "after the fill the device booted {:?} with {} log events",
        full.boot_source,
        full.log_events
    );
    b.boot_us_full_log = full.boot_time_us;
    b.log_events = full.log_events;
    // The worst update: its record rotates the full log onto the older sector, which it erases
    // besides the inactive slot.
    let before = s.link()?.status()?.store;
    let r = s.link()?.update_model(&signed)?;
    ensure!(matches!(r, UpdateResult::Accepted { .. }), "the update after the fill: {r:?}");
    let after = s.link()?.status()?.store;
    b.updates += 1;
    b.ops_per_update = b.ops_per_update.max(after.flash_ops - before.flash_ops);
    b.rotation_erases = after.erases.iter().sum::<u32>() - before.erases.iter().sum::<u32>();
    b.erases_per_update = b.erases_per_update.max(b.rotation_erases);
    b.erases = after.erases;
    s.disconnect()?;
    s.check_alive()?;
    Ok(b)
}

/// Print the figures against their targets.
pub fn print(b: &StoreBench) {
    println!("model store (product image; {} accepted updates of a {} B signed model):", b.updates, b.update_bytes);
    println!(
        "  one update       {:>7} flash operations, {} erase(s) at most, {} when its record rotates the log (target ≤ {TARGET_ERASES_PER_UPDATE}: {})",
        b.ops_per_update,
        b.erases_per_update,
        b.rotation_erases,
        super::verdict(b.erases_per_update <= TARGET_ERASES_PER_UPDATE)
    );
    println!(
        "  boot to serving  {:>7} µs emulated with a full log ({} records, model from a slot; target ≤ {} ms: {}); {} µs with one record; {} µs factory-fresh (embedded model)",
        b.boot_us_full_log,
        b.log_events,
        TARGET_BOOT_US / 1000,
        super::verdict(b.boot_us_full_log <= TARGET_BOOT_US),
        b.boot_us_one_record,
        b.boot_us_empty
    );
    let [a, bb, l0, l1] = b.erases;
    println!(
        "  erases per sector at the end: slot A {a}, slot B {bb}, log 0 {l0}, log 1 {l1} (refused transfers erase the inactive slot too)"
    );
}
