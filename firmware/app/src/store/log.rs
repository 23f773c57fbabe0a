//! The event log: an append-only ring of two sectors of fixed-size records, one per accepted
//! or refused update, from which the device's lifetime counters and its rollback floor are
//! derived at boot.
//!
//! Records are appended in the newest log sector until it is full; then the other sector is
//! erased and becomes the newest, its header carrying the totals of every event before it (so
//! that erasing the oldest records loses no count). Each sector is erased once per rotation:
//! the wear is spread over both, and a sector of `E` bytes takes `(E − 96) / 64` records
//! between two of its erases.
//!
//! A record is one program operation with its own CRC: a record torn by a power cut is skipped
//! at the next scan (its event is lost, never misread), and appending resumes after it.

use super::format::{is_blank, sector_erases, LogHeader, Record, Totals, RECORDS_AT, RECORD_LEN};

/// The log as scanned at boot and kept up to date since: where the next record goes and the
/// totals of every event so far.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EventLog {
    /// The log sector (0 or 1) appended to, with its sequence; `None` before the first event
    /// (or when no log sector has a whole header).
    pub current: Option<(usize, u32)>,
    /// Offset of the next record in the current sector.
    pub next: usize,
    /// Number of the next event.
    pub event: u32,
    /// Totals of every event so far.
    pub totals: Totals,
}

impl EventLog {
    /// Scan the two log sectors (`sectors[i]` is log sector `i`, each a whole erase unit):
    /// the newest sector with a whole header, then its records up to the first erased one.
    pub fn scan(sectors: [&[u8]; 2]) -> EventLog {
        let mut newest: Option<(usize, LogHeader)> = None;
        for (i, s) in sectors.iter().enumerate() {
            let Some(h) = sector_erases(s).and_then(|_| LogHeader::read(s)) else {
                continue;
            };
            // Sequence numbers are compared on the wrapping circle (two sectors are never
            // more than one apart).
            let newer = newest.is_none_or(|(_, n)| (h.sequence.wrapping_sub(n.sequence) as i32) > 0);
            if newer {
                newest = Some((i, h));
            }
        }
        let Some((i, h)) = newest else {
            return EventLog::default();
        };
        let mut log =
            EventLog { current: Some((i, h.sequence)), next: RECORDS_AT, event: h.first_event, totals: h.totals };
        let sector = sectors.get(i).copied().unwrap_or(&[]);
        while let Some(bytes) = sector.get(log.next..log.next + RECORD_LEN) {
            if is_blank(bytes) {
                break;
            }
            // A torn record is skipped; the next goes after it.
            if let Some(r) = Record::read(bytes) {
                log.totals.apply(&r);
                log.event = r.event.wrapping_add(1);
            }
            log.next += RECORD_LEN;
        }
        log
    }

    /// Whether a record fits in the current sector of `sector_len` bytes.
    pub fn has_room(&self, sector_len: usize) -> bool {
        self.current.is_some() && self.next + RECORD_LEN <= sector_len
    }

    /// The header of the sector the next rotation starts: the other sector (the first when
    /// there is none), the next sequence, the totals so far.
    pub fn next_sector(&self) -> (usize, LogHeader) {
        let (i, sequence) = match self.current {
            None => (0, 0),
            Some((c, sequence)) => (1 - c.min(1), sequence.wrapping_add(1)),
        };
        (i, LogHeader { sequence, first_event: self.event, totals: self.totals })
    }

    /// A rotation into `sector` with `header` was written.
    pub fn rotated(&mut self, sector: usize, header: LogHeader) {
        self.current = Some((sector, header.sequence));
        self.next = RECORDS_AT;
    }

    /// `r` was written at the next place.
    pub fn appended(&mut self, r: &Record) {
        self.totals.apply(r);
        self.event = r.event.wrapping_add(1);
        self.next += RECORD_LEN;
    }
}
