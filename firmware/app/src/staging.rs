//! A model update staged in a slot of NOR flash, not in RAM: what a real interrogator does with
//! an incoming image. `ModelBegin` makes the erase units the announced length needs blank,
//! every `ModelChunk` is programmed at the flash's write granularity as it arrives, and the commit reads the staged bytes back in place (the slot is memory-mapped:
//! [`MappedFlash`]) for the transfer CRC, the signature and the decode. The running model is
//! never touched by any of it: only a fully checked blob is folded into it.
//!
//! The slot is any `embedded-storage` [`NorFlash`] with NOR semantics: an erase sets bytes to
//! `0xFF`, a write only clears bits and must start and end on the write granularity, and a
//! byte is written once between erases. Chunks of any length and alignment are accepted: bytes
//! are collected in a buffer of one write unit ([`MAX_WRITE_SIZE`] bytes at most), programmed
//! when the unit is complete, and the last partial unit is padded with `0xFF` (the erased
//! value) at the commit.
//!
//! **Erases.** Nothing of a transfer is authenticated before its commit, so the link must not
//! be able to wear the flash out. `ModelBegin` erases only when the units it needs are not
//! already blank (a blank check of the mapped bytes): begins without data in between erase
//! nothing, however many. And the slot is erased at most [`ERASE_BUDGET`] times between two
//! accepted (authenticated) updates: beyond, a begin that would erase is refused
//! ([`RejectReason::EraseLimit`]) until an update is accepted or the device restarts. Every
//! erase is counted ([`Staging::erases`], reported in `Status::staging_erases`).

use embedded_storage::nor_flash::NorFlash;
use fbg_shared::blob;
use fbg_shared::protocol::{crc32, RejectReason, Rejection};

/// The largest write granularity ([`NorFlash::WRITE_SIZE`], bytes) a slot may have: the
/// pending partial unit is buffered in an array of this length (32 bytes covers the flash
/// words of common Cortex-M parts, from single bytes to 256-bit lines).
pub const MAX_WRITE_SIZE: usize = 32;

/// A [`NorFlash`] whose contents the CPU reads in place (memory-mapped flash, or memory in a
/// host test): the staged blob is checked and decoded straight from it, without a copy in RAM.
pub trait MappedFlash: NorFlash {
    /// The whole slot as the CPU reads it: [`capacity`](embedded_storage::nor_flash::ReadNorFlash::capacity)
    /// bytes, as last erased and written.
    fn contents(&self) -> &[u8];
}

/// Erases of the slot allowed between two accepted updates (and after boot): enough for a
/// host to retry a broken transfer a few times, few enough that the link alone cannot wear the
/// slot (every accepted update needs a trusted signature).
pub const ERASE_BUDGET: u32 = 16;

/// A write unit of erased flash: the padding after the last byte of a transfer.
const ERASED: [u8; MAX_WRITE_SIZE] = [0xFF; MAX_WRITE_SIZE];

/// A model transfer in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Transfer {
    Idle,
    /// `total` bytes announced with their CRC-32 `crc`; `received` bytes accepted so far, all
    /// of them in flash except the last `received % WRITE_SIZE`, which wait in the buffer.
    Receiving {
        total: usize,
        crc: u32,
        received: usize,
    },
}

/// The staging slot of model updates: a flash slot and the transfer being written into it.
pub struct Staging<F> {
    flash: F,
    /// Longest transfer accepted, bytes (at most the slot's capacity).
    limit: usize,
    transfer: Transfer,
    /// The received bytes of the write unit not yet complete (its first `received % WRITE_SIZE`).
    pending: [u8; MAX_WRITE_SIZE],
    /// Erases since boot.
    erases: u32,
    /// Erases since the last accepted update (or boot), against [`ERASE_BUDGET`].
    erases_unaccepted: u32,
}

impl<F: MappedFlash> Staging<F> {
    /// Stage updates in `flash`, refusing any transfer longer than `limit` bytes or than the
    /// slot (whichever is smaller).
    #[inline(always)]
    pub fn new(flash: F, limit: usize) -> Self {
        const {
            assert!(F::WRITE_SIZE > 0 && F::WRITE_SIZE <= MAX_WRITE_SIZE, "write granularity beyond MAX_WRITE_SIZE");
            assert!(F::ERASE_SIZE > 0, "erase granularity of zero");
        }
        let limit = if limit < flash.capacity() { limit } else { flash.capacity() };
        Staging {
            flash,
            limit,
            transfer: Transfer::Idle,
            pending: [0; MAX_WRITE_SIZE],
            erases: 0,
            erases_unaccepted: 0,
        }
    }

    /// Erase operations on the slot since boot.
    pub fn erases(&self) -> u32 {
        self.erases
    }

    /// An update staged here was authenticated and accepted: the erase budget is renewed.
    pub fn accepted(&mut self) {
        self.erases_unaccepted = 0;
    }

    /// Longest transfer accepted, bytes.
    pub fn limit(&self) -> usize {
        self.limit
    }

    /// The flash slot (e.g. for a test to inspect what was written).
    pub fn flash(&self) -> &F {
        &self.flash
    }

    /// Forget the transfer in progress (after any refusal); the slot keeps its bytes until the
    /// next transfer erases them.
    pub fn abort(&mut self) {
        self.transfer = Transfer::Idle;
    }

    /// Start a transfer of `total` bytes whose CRC-32 is `crc`: checked against the limit and
    /// the shortest blob, then the erase units it needs are erased unless they are blank
    /// already (and within the erase budget). Any earlier transfer is forgotten.
    pub fn begin(&mut self, total: usize, crc: u32) -> Result<(), Rejection> {
        self.transfer = Transfer::Idle;
        let detail = u32::try_from(total).unwrap_or(u32::MAX);
        if total > self.limit {
            return Err(Rejection { reason: RejectReason::TooLarge, detail });
        }
        if total < blob::HEADER_LEN + blob::CRC_LEN {
            return Err(Rejection { reason: RejectReason::Truncated, detail });
        }
        let end = total.div_ceil(F::ERASE_SIZE).saturating_mul(F::ERASE_SIZE);
        let blank = self.flash.contents().get(..end).is_some_and(|b| b.iter().all(|&x| x == 0xFF));
        if !blank {
            if self.erases_unaccepted >= ERASE_BUDGET {
                return Err(Rejection { reason: RejectReason::EraseLimit, detail: ERASE_BUDGET });
            }
            // Counted before the attempt: a failing erase still stresses the part.
            self.erases = self.erases.wrapping_add(1);
            self.erases_unaccepted = self.erases_unaccepted.saturating_add(1);
            self.flash.erase(0, offset(end)).map_err(|_| storage(0))?;
        }
        self.transfer = Transfer::Receiving { total, crc, received: 0 };
        Ok(())
    }

    /// Append a chunk that starts at byte `at` of the transfer; returns the bytes received so
    /// far.
    pub fn chunk(&mut self, at: u32, data: &[u8]) -> Result<usize, Rejection> {
        let Transfer::Receiving { total, crc, received } = self.transfer else {
            return Err(Rejection::new(RejectReason::NoUpdateInProgress));
        };
        if at as usize != received {
            let detail = u32::try_from(received).unwrap_or(u32::MAX);
            return Err(Rejection { reason: RejectReason::OutOfOrder, detail });
        }
        let end = received.saturating_add(data.len());
        if end > total {
            return Err(Rejection { reason: RejectReason::Overrun, detail: at });
        }
        self.program(received, data)?;
        self.transfer = Transfer::Receiving { total, crc, received: end };
        Ok(end)
    }

    /// Write `data`, which follows the `received` bytes already accepted, one write unit at a
    /// time: each byte goes to its place in the pending unit, and a unit is programmed once
    /// its last byte arrived.
    fn program(&mut self, received: usize, data: &[u8]) -> Result<(), Rejection> {
        let w = F::WRITE_SIZE;
        for (at, &b) in (received..).zip(data) {
            let i = at % w;
            if let Some(p) = self.pending.get_mut(i) {
                *p = b;
            }
            if i + 1 == w {
                let unit = at + 1 - w;
                let bytes = self.pending.get(..w).unwrap_or(&[]);
                self.flash.write(offset(unit), bytes).map_err(|_| storage(unit))?;
            }
        }
        Ok(())
    }

    /// End the transfer: when every announced byte arrived, write the last partial unit
    /// (padded with the erased value), read the staged bytes back and check them against the
    /// announced CRC. Returns the staged bytes, in place in the slot.
    pub fn finish(&mut self) -> Result<&[u8], Rejection> {
        let Transfer::Receiving { total, crc, received } = self.transfer else {
            return Err(Rejection::new(RejectReason::NoUpdateInProgress));
        };
        self.transfer = Transfer::Idle;
        if received != total {
            let detail = u32::try_from(received).unwrap_or(u32::MAX);
            return Err(Rejection { reason: RejectReason::Incomplete, detail });
        }
        // The last unit, completed with the erased value (nothing when the length is whole units).
        let fill = total % F::WRITE_SIZE;
        if fill != 0 {
            self.program(total, ERASED.get(..F::WRITE_SIZE - fill).unwrap_or(&[]))?;
        }
        match self.flash.contents().get(..total) {
            Some(staged) if crc32(staged) == crc => Ok(staged),
            Some(_) => Err(Rejection::new(RejectReason::TransferCrc)),
            None => Err(Rejection::new(RejectReason::TooLarge)),
        }
    }
}

/// A slot offset as `embedded-storage` takes it (offsets are below the slot's capacity, which
/// the limit bounds; saturated, the flash refuses it as out of bounds).
fn offset(at: usize) -> u32 {
    u32::try_from(at).unwrap_or(u32::MAX)
}

/// The refusal of a failed erase or write at slot offset `at`.
fn storage(at: usize) -> Rejection {
    Rejection { reason: RejectReason::Storage, detail: offset(at) }
}

impl<T: MappedFlash> MappedFlash for &mut T {
    fn contents(&self) -> &[u8] {
        T::contents(self)
    }
}
