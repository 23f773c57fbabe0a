//! What the store writes in flash, byte for byte (little-endian), and how it is read back.
//!
//! Every sector (one erase unit) starts with a **sector header**; a slot sector then holds a
//! slot header, three state words and the signed model; a log sector a log header and
//! fixed-size event records. Every field group sits in its own [`UNIT`]-byte-aligned place, so
//! that each is programmed exactly once on any part whose write granularity is at most
//! [`UNIT`] bytes (the rest of a group's place is left erased).
//!
//! ```text
//! sector header (every sector), at 0
//!   0  4  magic "FBGs"
//!   4  4  erase count of this sector (since the store was first formatted)
//!   8  4  its bitwise complement (a torn or missing header reads as "count unknown")
//! slot sector
//!   32   40  slot header: magic "FBGm", generation u32, length u32 (the signed file), digest
//!            u32 (the blob's CRC trailer), serial u64, key id [8], reserved u32, CRC-32 of
//!            the 36 bytes before
//!   96   4   COMPLETE word: the model was written and read back whole
//!   128  4   ACTIVE word: written last; from here on the slot is a boot candidate
//!   160  4   REVOKED word: the model failed to load; never a candidate again
//!   192  ..   the signed model file (blob + signature trailer), as received
//! log sector
//!   32   64  log header: magic "FBGl", sector sequence u32, first event u32, totals
//!            (accepted u32, refused u32, refusals by reason 5 × u32), floor u64,
//!            floor generation u32, CRC-32 of the bytes before
//!   96   ..  records of 64 bytes: kind u8, reason u8, flags u8, slot u8, event u32,
//!            serial u64, key id [8], digest u32, detail u32, generation u32, CRC-32 of the 36
//!            bytes before; the rest erased
//! ```

use fbg_shared::protocol::{crc32, RejectReason};
use fbg_shared::signature::KeyId;

/// Alignment of every field group: the largest write granularity a store flash may have
/// ([`crate::staging::MAX_WRITE_SIZE`]).
pub const UNIT: usize = 32;

/// Sector header magic.
pub const SECTOR_MAGIC: [u8; 4] = *b"FBGs";
/// Slot header magic.
pub const SLOT_MAGIC: [u8; 4] = *b"FBGm";
/// Log header magic.
pub const LOG_MAGIC: [u8; 4] = *b"FBGl";

/// Offset of the slot header in a slot sector.
pub const SLOT_HEADER_AT: usize = 32;
/// Offset of the COMPLETE word.
pub const COMPLETE_AT: usize = 96;
/// Offset of the ACTIVE word.
pub const ACTIVE_AT: usize = 128;
/// Offset of the REVOKED word.
pub const REVOKED_AT: usize = 160;
/// Offset of the model file in a slot sector.
pub const PAYLOAD_AT: usize = 192;

/// Offset of the log header in a log sector.
pub const LOG_HEADER_AT: usize = 32;
/// Offset of the first record in a log sector.
pub const RECORDS_AT: usize = 96;
/// Bytes of one event record.
pub const RECORD_LEN: usize = 64;

/// The state words' values (each programmed once over erased flash; any other value, a torn
/// write included, is not the state).
pub const COMPLETE: u32 = 0xC0DE_600D;
/// See [`COMPLETE`].
pub const ACTIVE: u32 = 0xAC71_7E01;
/// See [`COMPLETE`].
pub const REVOKED: u32 = 0x0BAD_0BAD;

fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    let s: [u8; 4] = b.get(at..at + 4)?.try_into().ok()?;
    Some(u32::from_le_bytes(s))
}

fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    let s: [u8; 8] = b.get(at..at + 8)?.try_into().ok()?;
    Some(u64::from_le_bytes(s))
}

fn put(out: &mut [u8], at: usize, bytes: &[u8]) {
    if let Some(d) = out.get_mut(at..at + bytes.len()) {
        d.copy_from_slice(bytes);
    }
}

/// The CRC-32 stored at `at` matches the bytes before it.
fn crc_ok(b: &[u8], at: usize) -> bool {
    match (b.get(..at), u32_at(b, at)) {
        (Some(body), Some(c)) => crc32(body) == c,
        _ => false,
    }
}

fn seal(out: &mut [u8], at: usize) {
    let c = crc32(out.get(..at).unwrap_or(&[]));
    put(out, at, &c.to_le_bytes());
}

/// Whether every byte is erased.
pub fn is_blank(b: &[u8]) -> bool {
    b.iter().all(|&x| x == 0xFF)
}

/// The erase count a sector header records (`None`: no valid header).
pub fn sector_erases(sector: &[u8]) -> Option<u32> {
    let count = u32_at(sector, 4)?;
    (sector.get(..4) == Some(&SECTOR_MAGIC[..]) && u32_at(sector, 8) == Some(!count)).then_some(count)
}

/// A sector header recording `erases`, in a [`UNIT`]-byte place.
pub fn sector_header(erases: u32) -> [u8; UNIT] {
    let mut out = [0xFF; UNIT];
    put(&mut out, 0, &SECTOR_MAGIC);
    put(&mut out, 4, &erases.to_le_bytes());
    put(&mut out, 8, &(!erases).to_le_bytes());
    out
}

/// A state word in a [`UNIT`]-byte place.
pub fn state_word(value: u32) -> [u8; UNIT] {
    let mut out = [0xFF; UNIT];
    put(&mut out, 0, &value.to_le_bytes());
    out
}

/// Whether the state word at `at` of `sector` holds `value`.
pub fn has_state(sector: &[u8], at: usize, value: u32) -> bool {
    u32_at(sector, at) == Some(value)
}

/// A slot's header: which model it holds and when it was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotHeader {
    /// One more than the newest slot's when written: the newest slot has the highest.
    pub generation: u32,
    /// Bytes of the signed model file.
    pub len: u32,
    /// The blob's CRC trailer (its digest; the signature covers it).
    pub digest: u32,
    /// The signature trailer's serial.
    pub serial: u64,
    /// The signer's key id.
    pub key_id: KeyId,
}

impl SlotHeader {
    /// The header in its place (64 bytes, two [`UNIT`]s).
    pub fn to_bytes(&self) -> [u8; 2 * UNIT] {
        let mut out = [0xFF; 2 * UNIT];
        put(&mut out, 0, &SLOT_MAGIC);
        put(&mut out, 4, &self.generation.to_le_bytes());
        put(&mut out, 8, &self.len.to_le_bytes());
        put(&mut out, 12, &self.digest.to_le_bytes());
        put(&mut out, 16, &self.serial.to_le_bytes());
        put(&mut out, 24, &self.key_id.0);
        put(&mut out, 32, &0u32.to_le_bytes());
        seal(&mut out, 36);
        out
    }

    /// The header of a slot sector, when it is whole.
    pub fn read(sector: &[u8]) -> Option<SlotHeader> {
        let b = sector.get(SLOT_HEADER_AT..SLOT_HEADER_AT + 40)?;
        if b.get(..4) != Some(&SLOT_MAGIC[..]) || !crc_ok(b, 36) {
            return None;
        }
        let key: [u8; 8] = b.get(24..32)?.try_into().ok()?;
        Some(SlotHeader {
            generation: u32_at(b, 4)?,
            len: u32_at(b, 8)?,
            digest: u32_at(b, 12)?,
            serial: u64_at(b, 16)?,
            key_id: KeyId(key),
        })
    }
}

/// The running totals of the log: what `Status` reports as the device's lifetime counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Totals {
    /// Updates accepted.
    pub accepted: u32,
    /// Updates refused (at their commit).
    pub refused: u32,
    /// Refusals by reason: unsigned, bad signature, unknown key, rollback, serial reused.
    pub by_reason: [u32; 5],
    /// The rollback floor: the serial of the last accepted update.
    pub floor: u64,
    /// The generation of the slot the last accepted update was written to.
    pub floor_generation: u32,
}

impl Totals {
    /// Index in [`Totals::by_reason`] of a refusal for `reason` (`None`: not a signature
    /// refusal).
    pub fn reason_index(reason: RejectReason) -> Option<usize> {
        match reason {
            RejectReason::Unsigned => Some(0),
            RejectReason::BadSignature => Some(1),
            RejectReason::UnknownKey => Some(2),
            RejectReason::Rollback | RejectReason::RollbackNotPermitted => Some(3),
            RejectReason::SerialReused => Some(4),
            _ => None,
        }
    }

    /// Count one event.
    pub fn apply(&mut self, r: &Record) {
        match r.kind {
            EventKind::Accepted => {
                self.accepted = self.accepted.wrapping_add(1);
                self.floor = r.serial;
                self.floor_generation = r.generation;
            }
            EventKind::Refused => {
                self.refused = self.refused.wrapping_add(1);
                let slot = Totals::reason_index(RejectReason::from_code(r.reason));
                if let Some(c) = slot.and_then(|i| self.by_reason.get_mut(i)) {
                    *c = c.wrapping_add(1);
                }
            }
        }
    }
}

/// A log sector's header: its place in the ring and the totals of every event before it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LogHeader {
    /// Sequence of the sector in the ring: the newest sector has the highest.
    pub sequence: u32,
    /// Number of the sector's first event.
    pub first_event: u32,
    /// Totals of all events before the sector's first.
    pub totals: Totals,
}

impl LogHeader {
    /// The header in its place (64 bytes).
    pub fn to_bytes(&self) -> [u8; 2 * UNIT] {
        let mut out = [0xFF; 2 * UNIT];
        let t = &self.totals;
        put(&mut out, 0, &LOG_MAGIC);
        put(&mut out, 4, &self.sequence.to_le_bytes());
        put(&mut out, 8, &self.first_event.to_le_bytes());
        put(&mut out, 12, &t.accepted.to_le_bytes());
        put(&mut out, 16, &t.refused.to_le_bytes());
        for (i, c) in t.by_reason.iter().enumerate() {
            put(&mut out, 20 + 4 * i, &c.to_le_bytes());
        }
        put(&mut out, 40, &t.floor.to_le_bytes());
        put(&mut out, 48, &t.floor_generation.to_le_bytes());
        seal(&mut out, 52);
        out
    }

    /// The header of a log sector, when it is whole.
    pub fn read(sector: &[u8]) -> Option<LogHeader> {
        let b = sector.get(LOG_HEADER_AT..LOG_HEADER_AT + 56)?;
        if b.get(..4) != Some(&LOG_MAGIC[..]) || !crc_ok(b, 52) {
            return None;
        }
        let mut by_reason = [0u32; 5];
        for (i, c) in by_reason.iter_mut().enumerate() {
            *c = u32_at(b, 20 + 4 * i)?;
        }
        Some(LogHeader {
            sequence: u32_at(b, 4)?,
            first_event: u32_at(b, 8)?,
            totals: Totals {
                accepted: u32_at(b, 12)?,
                refused: u32_at(b, 16)?,
                by_reason,
                floor: u64_at(b, 40)?,
                floor_generation: u32_at(b, 48)?,
            },
        })
    }
}

/// What an event record records.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventKind {
    /// An update was accepted (written to a slot, marked active, loaded).
    Accepted,
    /// An update was refused at its commit.
    Refused,
}

impl EventKind {
    fn code(self) -> u8 {
        match self {
            EventKind::Accepted => 0xA5,
            EventKind::Refused => 0x5A,
        }
    }
}

/// Record flag: an accepted update was a rollback.
pub const FLAG_ROLLBACK: u8 = 1;
/// Record flag: an accepted event written at boot for a slot the log had missed (the power
/// failed between the slot's ACTIVE word and its log record).
pub const FLAG_RECOVERED: u8 = 2;

/// One event of the log.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Record {
    /// What happened.
    pub kind: EventKind,
    /// The refusal's reason code ([`RejectReason::code`]; 0 for an accepted update).
    pub reason: u8,
    /// [`FLAG_ROLLBACK`], [`FLAG_RECOVERED`].
    pub flags: u8,
    /// The slot written (accepted), 0xFF otherwise.
    pub slot: u8,
    /// Event number since the store was formatted.
    pub event: u32,
    /// The update's serial (0 when it had no readable trailer).
    pub serial: u64,
    /// Its signer's key id (zero when none).
    pub key_id: KeyId,
    /// Its blob's CRC trailer (0 when unknown).
    pub digest: u32,
    /// The refusal's detail.
    pub detail: u32,
    /// The generation of the slot written (accepted).
    pub generation: u32,
}

impl Record {
    /// The record in its place.
    pub fn to_bytes(&self) -> [u8; RECORD_LEN] {
        let mut out = [0xFF; RECORD_LEN];
        put(&mut out, 0, &[self.kind.code(), self.reason, self.flags, self.slot]);
        put(&mut out, 4, &self.event.to_le_bytes());
        put(&mut out, 8, &self.serial.to_le_bytes());
        put(&mut out, 16, &self.key_id.0);
        put(&mut out, 24, &self.digest.to_le_bytes());
        put(&mut out, 28, &self.detail.to_le_bytes());
        put(&mut out, 32, &self.generation.to_le_bytes());
        seal(&mut out, 36);
        out
    }

    /// The record in `b` (its [`RECORD_LEN`] bytes), when it is whole.
    pub fn read(b: &[u8]) -> Option<Record> {
        if !crc_ok(b, 36) {
            return None;
        }
        let kind = match *b.first()? {
            0xA5 => EventKind::Accepted,
            0x5A => EventKind::Refused,
            _ => return None,
        };
        let key: [u8; 8] = b.get(16..24)?.try_into().ok()?;
        Some(Record {
            kind,
            reason: *b.get(1)?,
            flags: *b.get(2)?,
            slot: *b.get(3)?,
            event: u32_at(b, 4)?,
            serial: u64_at(b, 8)?,
            key_id: KeyId(key),
            digest: u32_at(b, 24)?,
            detail: u32_at(b, 28)?,
            generation: u32_at(b, 32)?,
        })
    }
}
