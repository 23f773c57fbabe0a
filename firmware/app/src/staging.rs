//! A model update received into NOR flash, not RAM: what a real interrogator does with an
//! incoming image. The store ([`crate::store`]) makes its inactive slot blank at `ModelBegin`;
//! every `ModelChunk` is programmed there at the flash's write granularity as it arrives, and
//! the commit reads the staged bytes back in place (the flash is memory-mapped:
//! [`MappedFlash`]) for the transfer CRC, the signature and the decode. The running model is
//! never touched by any of it: only a fully checked blob is folded into it.
//!
//! The flash is any `embedded-storage` [`NorFlash`] with NOR semantics: an erase sets bytes to
//! `0xFF`, a write only clears bits and must start and end on the write granularity, and a
//! byte is written once between erases. Chunks of any length and alignment are accepted: bytes
//! are collected in a buffer of one write unit ([`MAX_WRITE_SIZE`] bytes at most), programmed
//! when the unit is complete, and the last partial unit is padded with `0xFF` (the erased
//! value) at the commit. Erasing, and its budget, are the store's.

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

/// [`ReadNorFlash::read`](embedded_storage::nor_flash::ReadNorFlash::read) of a
/// [`MappedFlash`]: `bytes.len()` bytes from `offset`, copied from its
/// [`contents`](MappedFlash::contents) once the range is checked (`check_read`); every driver
/// of a memory-mapped store reads this way.
pub fn read_mapped<F: MappedFlash>(
    flash: &F,
    offset: u32,
    bytes: &mut [u8],
) -> Result<(), embedded_storage::nor_flash::NorFlashErrorKind> {
    embedded_storage::nor_flash::check_read(flash, offset, bytes.len())?;
    let from = flash.contents().get(offset as usize..).unwrap_or(&[]);
    for (d, &s) in bytes.iter_mut().zip(from) {
        *d = s;
    }
    Ok(())
}

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

/// A model transfer into a window of NOR flash: where it goes, how far it got, and the write
/// unit not yet complete. The flash is the caller's (the store's), lent to every call; so is
/// making the window blank before a transfer begins.
pub struct Staging {
    /// Offset of the window in the flash.
    base: usize,
    /// Longest transfer accepted, bytes (at most the window).
    limit: usize,
    transfer: Transfer,
    /// The received bytes of the write unit not yet complete (its first `received % WRITE_SIZE`).
    pending: [u8; MAX_WRITE_SIZE],
}

impl Staging {
    /// No transfer; the window at flash offset `base`, taking transfers of at most `limit` bytes.
    pub const fn new(base: usize, limit: usize) -> Self {
        Staging { base, limit, transfer: Transfer::Idle, pending: [0; MAX_WRITE_SIZE] }
    }

    /// Longest transfer accepted, bytes.
    pub fn limit(&self) -> usize {
        self.limit
    }

    /// Offset of the window in the flash.
    pub fn base(&self) -> usize {
        self.base
    }

    /// The length of the transfer in progress, as announced.
    pub fn announced(&self) -> Option<usize> {
        match self.transfer {
            Transfer::Idle => None,
            Transfer::Receiving { total, .. } => Some(total),
        }
    }

    /// Whether a transfer is in progress.
    pub fn is_receiving(&self) -> bool {
        self.transfer != Transfer::Idle
    }

    /// Forget the transfer in progress (after any refusal); the window keeps its bytes until
    /// the next transfer has it made blank.
    pub fn abort(&mut self) {
        self.transfer = Transfer::Idle;
    }

    /// Check a transfer of `total` bytes whose CRC-32 is `crc` against the limit and the
    /// shortest blob, before anything is erased. Any earlier transfer is forgotten.
    pub fn check(&mut self, total: usize) -> Result<(), Rejection> {
        self.transfer = Transfer::Idle;
        let detail = u32::try_from(total).unwrap_or(u32::MAX);
        if total > self.limit {
            return Err(Rejection { reason: RejectReason::TooLarge, detail });
        }
        if total < blob::HEADER_LEN + blob::CRC_LEN {
            return Err(Rejection { reason: RejectReason::Truncated, detail });
        }
        Ok(())
    }

    /// Start a transfer of `total` bytes whose CRC-32 is `crc` into the window at `base`, which
    /// the caller made blank (after [`Staging::check`]).
    pub fn begin(&mut self, base: usize, total: usize, crc: u32) {
        self.base = base;
        self.transfer = Transfer::Receiving { total, crc, received: 0 };
    }

    /// Append a chunk that starts at byte `at` of the transfer; returns the bytes received so
    /// far.
    pub fn chunk<F: NorFlash>(&mut self, flash: &mut F, at: u32, data: &[u8]) -> Result<usize, Rejection> {
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
        self.program(flash, received, data)?;
        self.transfer = Transfer::Receiving { total, crc, received: end };
        Ok(end)
    }

    /// Write `data`, which follows the `received` bytes already accepted, one write unit at a
    /// time: each byte goes to its place in the pending unit, and a unit is programmed once
    /// its last byte arrived.
    fn program<F: NorFlash>(&mut self, flash: &mut F, received: usize, data: &[u8]) -> Result<(), Rejection> {
        let w = F::WRITE_SIZE;
        for (at, &b) in (received..).zip(data) {
            let i = at % w;
            if let Some(p) = self.pending.get_mut(i) {
                *p = b;
            }
            if i + 1 == w {
                let unit = at + 1 - w;
                let bytes = self.pending.get(..w).unwrap_or(&[]);
                let at = self.base + unit;
                flash.write(offset(at), bytes).map_err(|_| storage(unit))?;
            }
        }
        Ok(())
    }

    /// End the transfer: when every announced byte arrived, write the last partial unit
    /// (padded with the erased value), read the staged bytes back and check them against the
    /// announced CRC. Returns their length; they stay in place at the window's offset.
    pub fn finish<F: MappedFlash>(&mut self, flash: &mut F) -> Result<usize, Rejection> {
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
            self.program(flash, total, ERASED.get(..F::WRITE_SIZE - fill).unwrap_or(&[]))?;
        }
        match flash.contents().get(self.base..self.base + total) {
            Some(staged) if crc32(staged) == crc => Ok(total),
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
