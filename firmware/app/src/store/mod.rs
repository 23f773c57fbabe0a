//! The persistent model store: what the device accepted survives resets and power loss.
//!
//! # Layout
//!
//! The store is one region of NOR flash ([`MappedFlash`]: erased, programmed and read in
//! place) of four erase units of `F::ERASE_SIZE` bytes each — **slot A, slot B, log sector 0,
//! log sector 1** — byte for byte as [`format`] describes. Each sector starts with its own
//! erase count. A slot holds one signed model file as received, behind a header (generation,
//! length, digest, serial, key id) and three state words written once each, in this order:
//! COMPLETE (written and read back whole), ACTIVE (a boot candidate), REVOKED (it failed to
//! load). The log ([`log`]) records every accepted update and refusals at their commit.
//!
//! # Boot
//!
//! [`Store::open`] only reads: the sectors' erase counts, the log's totals, the rollback floor
//! (the serial of the last accepted update). [`Store::boot`] then takes the candidate slots —
//! whole header, COMPLETE and ACTIVE, not REVOKED — newest generation first, and loads the
//! first whose serial is at or above the floor, whose signature verifies against the build's
//! policy and whose model loads; else the embedded default. `Status::store` says which.
//!
//! # An update
//!
//! `ModelBegin` makes the **inactive** slot (not the one running) blank — one erase, when it is
//! not blank already, within [`ERASE_BUDGET`] erases between two accepted updates — and the
//! chunks are programmed into it as they arrive ([`crate::staging`]). At the commit the bytes
//! are read back against the transfer CRC and authenticated; only then is anything written
//! that a boot would look at: the slot header (read back), COMPLETE, then ACTIVE — one word,
//! written last — and the model is loaded; a model that does not load is REVOKED. Last, the
//! log records the event.
//!
//! **Power loss.** The running model's slot is never erased or programmed by an update, so a
//! cut at any instruction leaves it a candidate: before the new slot's ACTIVE word is whole
//! the device boots the old model; after, the new one (its serial is at or above the floor,
//! except for a rollback, which boots the old model until its log record is written). A cut
//! between ACTIVE and the log record is repaired at boot: the log is given the missing
//! accepted event. Never neither, never a mix: a slot is booted only whole and verified.
//!
//! **Wear.** Erases: one of the inactive slot per update; a log sector once per
//! `(ERASE_SIZE − 96) / 64` events. Nothing the link sends without a trusted signature
//! reaches the running slot or the log beyond [`REFUSALS_LOGGED`] refusals per accepted
//! update, and erases the inactive slot at most [`ERASE_BUDGET`] times per accepted update.

pub mod format;
pub mod log;
pub mod power_cut;
pub mod slice_flash;

mod counting;
mod update;

use embedded_storage::nor_flash::NorFlash;
use fbg_shared::protocol::{BootSource, Refusals, Rejection, StoreStatus, STORE_SECTORS};
use fbg_shared::Compensator;

pub use self::counting::Counting;
use self::format::{
    has_state, is_blank, sector_erases, sector_header, state_word, EventKind, Record, SlotHeader, ACTIVE, COMPLETE,
    FLAG_RECOVERED, PAYLOAD_AT, REVOKED, UNIT,
};
use self::log::EventLog;
pub use self::power_cut::PowerCut;
pub use self::slice_flash::SliceFlash;
pub use crate::staging::MappedFlash;
use crate::staging::Staging;
use crate::{authenticate, boot, load_blob, Kernel, ModelInfo, Policy, Signer};

/// Erases of the inactive slot allowed between two accepted updates (and after boot): enough
/// for a host to retry a broken transfer a few times, few enough that the link alone cannot
/// wear the slot (every accepted update needs a trusted signature).
pub const ERASE_BUDGET: u32 = 16;

/// Refusals written to the log between two accepted updates (and after boot); further ones
/// are counted in RAM only (`StoreStatus::refusals_unlogged`).
pub const REFUSALS_LOGGED: u32 = 8;

// The counters against the two budgets are bytes.
const _: () = assert!(ERASE_BUDGET < 256 && REFUSALS_LOGGED < 256);

/// An erase count not known (its sector's header is not whole).
const UNKNOWN: u32 = u32::MAX;

/// Slots of the store.
pub const SLOTS: usize = 2;

/// Erase units the store takes: slot A, slot B, log sector 0, log sector 1.
pub const STORE_UNITS: usize = STORE_SECTORS;

/// Why the store cannot work on a flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum StoreError {
    /// Fewer than four erase units.
    TooSmall,
}

/// A slot as its sector reads.
#[derive(Clone, Copy, Debug)]
struct SlotView {
    header: Option<SlotHeader>,
    active: bool,
}

/// The model store over `F` (see the module docs).
pub struct Store<F> {
    flash: Counting<F>,
    /// Erase counts per sector ([`UNKNOWN`]: the sector's header is not whole).
    erases: [u32; STORE_SECTORS],
    log: EventLog,
    /// The slot the running model came from (`None`: the embedded default).
    running: Option<u8>,
    booted: BootSource,
    staging: Staging,
    /// The slot a transfer is being written to.
    receiving: Option<u8>,
    /// Erases of slots by transfers since boot.
    transfer_erases: u32,
    /// Those since the last accepted update, against [`ERASE_BUDGET`].
    erases_unaccepted: u8,
    /// Refusals since the last accepted update, against [`REFUSALS_LOGGED`].
    refusals_since_accept: u8,
    refusals_unlogged: u32,
    boot_time_us: u32,
}

impl<F: MappedFlash> Store<F> {
    /// The store on `flash` (four erase units at least; only the first four are used), taking
    /// updates of at most `limit` bytes (and at most a slot's room). Reads only.
    #[inline(never)]
    pub fn open(flash: F, limit: usize) -> Result<Store<F>, StoreError> {
        const {
            assert!(UNIT.is_multiple_of(F::WRITE_SIZE), "the store's field groups must be whole write units");
            assert!(F::ERASE_SIZE > PAYLOAD_AT + 1024, "a slot must hold a model");
        }
        if flash.capacity() < STORE_SECTORS * F::ERASE_SIZE {
            return Err(StoreError::TooSmall);
        }
        let room = F::ERASE_SIZE - PAYLOAD_AT;
        let mut store = Store {
            flash: Counting::new(flash),
            erases: [UNKNOWN; STORE_SECTORS],
            log: EventLog::default(),
            running: None,
            booted: BootSource::Embedded,
            staging: Staging::new(PAYLOAD_AT, if limit < room { limit } else { room }),
            receiving: None,
            transfer_erases: 0,
            erases_unaccepted: 0,
            refusals_since_accept: 0,
            refusals_unlogged: 0,
            boot_time_us: 0,
        };
        for (i, e) in store.erases.iter_mut().enumerate() {
            *e = sector_erases(store.flash.sector(i)).unwrap_or(UNKNOWN);
        }
        store.log = EventLog::scan([store.flash.sector(2), store.flash.sector(3)]);
        Ok(store)
    }

    /// Load the newest candidate slot at or above the rollback floor that verifies and loads
    /// into `comp`, else the embedded `default` (as [`crate::boot`] does); see the module docs.
    /// A slot the log missed (a cut between its ACTIVE word and its record) is given its
    /// accepted event now.
    #[inline(never)]
    pub fn boot<const K: usize>(
        &mut self,
        kernel: &Kernel<K>,
        policy: &Policy,
        require_signed: bool,
        comp: &mut Compensator<f32, K>,
        default: &[u8],
    ) -> Result<ModelInfo, Rejection> {
        for slot in self.newest_first() {
            if let Some(info) = self.try_slot(kernel, policy, comp, slot) {
                return Ok(info);
            }
        }
        self.boot_embedded(kernel, policy, require_signed, comp, default)
    }

    /// No slot to boot: the embedded `default` ([`crate::boot`]).
    #[inline(never)]
    fn boot_embedded<const K: usize>(
        &mut self,
        kernel: &Kernel<K>,
        policy: &Policy,
        require_signed: bool,
        comp: &mut Compensator<f32, K>,
        default: &[u8],
    ) -> Result<ModelInfo, Rejection> {
        self.running = None;
        self.booted = BootSource::Embedded;
        log!(
            info,
            "no slot to boot at or above the rollback floor {=u64} ({=u32} logged events): the embedded model",
            self.log.totals.floor,
            self.log.event
        );
        boot(kernel, policy, require_signed, comp, default)
    }

    /// The slots, newest generation first.
    #[inline(never)]
    fn newest_first(&self) -> [usize; SLOTS] {
        let generation = |slot| self.view(slot).header.map_or(0, |h| h.generation);
        if generation(1) > generation(0) {
            [1, 0]
        } else {
            [0, 1]
        }
    }

    /// Slot `slot` under `header` booted: say so, and give the log the accepted event it
    /// missed, if any (a failure leaves the log as it was; the slot still boots next time).
    #[inline(never)]
    fn booted_from(&mut self, slot: usize, header: &SlotHeader) {
        self.running = Some(slot as u8);
        self.booted = BootSource::Slot { slot: slot as u8, generation: header.generation };
        if header.generation > self.log.totals.floor_generation {
            let _ = self.append(accepted_record(slot, header, FLAG_RECOVERED));
        }
        log!(
            info,
            "booted slot {=usize} (generation {=u32}): serial {=u64}, crc {=u32:#010x}; rollback floor {=u64}, {=u32} logged events",
            slot,
            header.generation,
            header.serial,
            header.digest,
            self.log.totals.floor,
            self.log.event
        );
    }

    /// Slot `slot` booted into `comp` when it is a candidate at or above the floor whose
    /// signature verifies and whose model loads.
    #[inline(never)]
    fn try_slot<const K: usize>(
        &mut self,
        kernel: &Kernel<K>,
        policy: &Policy,
        comp: &mut Compensator<f32, K>,
        slot: usize,
    ) -> Option<ModelInfo> {
        let (blob_len, h) = self.verified(policy, slot)?;
        let blob = self.flash.sector(slot).get(PAYLOAD_AT..PAYLOAD_AT + blob_len)?;
        let info = load_blob(kernel, comp, blob).ok()?;
        self.booted_from(slot, &h);
        Some(info.signed_by(Some(Signer { serial: h.serial, key_id: h.key_id })))
    }

    /// Slot `slot`'s blob length and header when it is a candidate at or above the floor whose
    /// signature verifies and agrees with its header (serial, key id, digest).
    #[inline(never)]
    fn verified(&self, policy: &Policy, slot: usize) -> Option<(usize, SlotHeader)> {
        let v = self.view(slot);
        let h = v.header.filter(|h| v.active && h.serial >= self.log.totals.floor)?;
        let file = self.flash.sector(slot).get(PAYLOAD_AT..PAYLOAD_AT + h.len as usize)?;
        let (blob, signer) = authenticate(policy, file, None).ok()?;
        let same = signer.serial == h.serial
            && signer.key_id == h.key_id
            && fbg_shared::blob::stored_crc(blob) == Some(h.digest);
        same.then_some((blob.len(), h))
    }

    /// Slot `slot` as its sector reads.
    fn view(&self, slot: usize) -> SlotView {
        let s = self.flash.sector(slot);
        let header = sector_erases(s).and_then(|_| SlotHeader::read(s));
        let active = header.is_some()
            && has_state(s, format::COMPLETE_AT, COMPLETE)
            && has_state(s, format::ACTIVE_AT, ACTIVE)
            && !has_state(s, format::REVOKED_AT, REVOKED);
        SlotView { header, active }
    }

    /// The store's part of the device status.
    pub fn status(&self) -> StoreStatus {
        StoreStatus {
            boot_source: self.booted,
            erases: self.erases.map(|e| if e == UNKNOWN { 0 } else { e }),
            flash_ops: self.flash.ops(),
            rollback_floor: self.log.totals.floor,
            log_events: self.log.event,
            refusals_unlogged: self.refusals_unlogged,
            boot_time_us: self.boot_time_us,
        }
    }

    /// The lifetime totals of the log: updates accepted, refused, and the refusals by reason.
    pub fn totals(&self) -> (u32, u32, Refusals) {
        let t = &self.log.totals;
        let [unsigned, bad_signature, unknown_key, rollback, serial_reused] = t.by_reason;
        (t.accepted, t.refused, Refusals { unsigned, bad_signature, unknown_key, rollback, serial_reused })
    }

    /// The rollback floor.
    pub fn floor(&self) -> u64 {
        self.log.totals.floor
    }

    /// Record the time from reset to serving, µs.
    pub fn set_boot_time_us(&mut self, us: u32) {
        self.boot_time_us = us;
    }

    /// Erases of slots by model transfers since boot.
    pub fn transfer_erases(&self) -> u32 {
        self.transfer_erases
    }

    /// The flash (e.g. for a test to inspect it).
    pub fn flash(&self) -> &F {
        self.flash.inner()
    }

    /// The flash, to change it from outside (tests injecting faults).
    pub fn flash_mut(&mut self) -> &mut F {
        self.flash.inner_mut()
    }

    /// Erase sector `i` and write its header with its erase count, counted before the attempt
    /// (a failing erase still wears the part). A sector whose count was unreadable continues
    /// from the highest count of the others.
    #[inline(never)]
    fn erase_sector(&mut self, i: usize) -> Result<(), ()> {
        let known = self.erases.iter().copied().filter(|&e| e != UNKNOWN).max().unwrap_or(0);
        let count = match self.erases.get(i).copied() {
            Some(e) if e != UNKNOWN => e,
            _ => known,
        }
        .wrapping_add(1)
        .min(UNKNOWN - 1);
        if let Some(e) = self.erases.get_mut(i) {
            *e = count;
        }
        let base = i * F::ERASE_SIZE;
        self.flash.erase(offset(base), offset(base + F::ERASE_SIZE)).map_err(|_| ())?;
        self.program(base, &sector_header(count))
    }

    /// Give blank sector `i` (never written, or erased by a rotation cut before its header)
    /// its header without an erase.
    #[inline(never)]
    fn format_blank(&mut self, i: usize) -> Result<(), ()> {
        let count = self.erases.get(i).copied().filter(|&e| e != UNKNOWN).unwrap_or(0);
        if let Some(e) = self.erases.get_mut(i) {
            *e = count;
        }
        self.program(i * F::ERASE_SIZE, &sector_header(count))
    }

    /// Program `bytes` (whole write units) at store offset `at`, and read them back.
    fn program(&mut self, at: usize, bytes: &[u8]) -> Result<(), ()> {
        self.flash.write(offset(at), bytes).map_err(|_| ())?;
        match self.flash.contents().get(at..at + bytes.len()) {
            Some(back) if back == bytes => Ok(()),
            _ => Err(()),
        }
    }

    /// Program the state word `value` at `at` of slot `slot`.
    fn set_state(&mut self, slot: usize, at: usize, value: u32) -> Result<(), ()> {
        self.program(slot * F::ERASE_SIZE + at, &state_word(value))
    }

    /// Append `rec` (its event number set here) to the log, rotating to the other log sector
    /// when the current one is full.
    #[inline(never)]
    fn append(&mut self, mut rec: Record) -> Result<(), ()> {
        rec.event = self.log.event;
        if !self.log.has_room(F::ERASE_SIZE) {
            let (sector, header) = self.log.next_sector();
            let i = 2 + sector;
            // A sector found blank (a rotation cut before its header) needs no erase.
            let blank = is_blank(self.flash.sector(i));
            if blank {
                self.format_blank(i)?;
            } else {
                self.erase_sector(i)?;
            }
            self.program(i * F::ERASE_SIZE + format::LOG_HEADER_AT, &header.to_bytes())?;
            self.log.rotated(sector, header);
        }
        let (sector, _) = self.log.current.ok_or(())?;
        self.program((2 + sector) * F::ERASE_SIZE + self.log.next, &rec.to_bytes())?;
        self.log.appended(&rec);
        Ok(())
    }
}

/// The log record of an update accepted into `slot` under `header`.
fn accepted_record(slot: usize, header: &SlotHeader, flags: u8) -> Record {
    Record {
        kind: EventKind::Accepted,
        reason: 0,
        flags,
        slot: slot as u8,
        event: 0,
        serial: header.serial,
        key_id: header.key_id,
        digest: header.digest,
        detail: 0,
        generation: header.generation,
    }
}

/// A store offset as `embedded-storage` takes it (saturated: the flash refuses it).
fn offset(at: usize) -> u32 {
    u32::try_from(at).unwrap_or(u32::MAX)
}
