//! The staging slot of model updates: a region of the flash set apart for it (`STAGING` in the
//! top-level `memory.x`, outside the image, so the linker never places code or data there),
//! driven as NOR flash through the `embedded-storage` traits the application takes
//! ([`fbg_firmware_app::staging`]).
//!
//! On QEMU's `mps2-an386` the flash of `memory.x` is the board's SSRAM at `0x0`, which the CPU
//! can write: erasing and programming are volatile stores here. On a real part they are the
//! flash controller's sector erase and program sequences (unlock, erase the sector or program
//! the word, wait for completion, check its error flags, lock); the slot then is a whole
//! sector (or pages) of the part, and [`ERASE_SIZE`]/[`WRITE_SIZE`] are the part's. Reading is
//! the same on both: the flash is memory-mapped, so the application checks and decodes the
//! staged blob in place ([`fbg_firmware_app::MappedFlash`]), with no copy in RAM.
//!
//! The driver enforces what the hardware would: an erase sets every byte of whole erase units
//! to `0xFF`; a write must start and end on the write granularity and lands only on erased
//! bytes (writing a byte that is not `0xFF` is [`SlotError::NotErased`], as a part with ECC
//! refuses it), and every written unit is read back. A missing erase is then an error on QEMU
//! as on a board, instead of silently overwriting the previous update.

use core::ptr::{addr_of, read_volatile, write_volatile};

use embedded_storage::nor_flash::{
    check_erase, check_read, check_write, ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use fbg_firmware_app::MappedFlash;

/// Erase granularity of the slot, bytes (the emulated part's flash page).
pub const ERASE_SIZE: usize = 4096;
/// Write granularity of the slot, bytes (one 32-bit flash word).
pub const WRITE_SIZE: usize = 4;

extern "C" {
    /// First byte of the `STAGING` region (`memory.x`).
    static __staging_start: u8;
    /// One past its last byte.
    static __staging_end: u8;
}

/// Why the slot refused an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotError {
    /// Offset or length not on the write (erase) granularity.
    NotAligned,
    /// Outside the slot.
    OutOfBounds,
    /// A write over bytes that were not erased since they were last written.
    NotErased,
    /// A written unit did not read back as written.
    Verify,
}

impl NorFlashError for SlotError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            SlotError::NotAligned => NorFlashErrorKind::NotAligned,
            SlotError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            SlotError::NotErased | SlotError::Verify => NorFlashErrorKind::Other,
        }
    }
}

impl From<NorFlashErrorKind> for SlotError {
    fn from(k: NorFlashErrorKind) -> Self {
        match k {
            NorFlashErrorKind::NotAligned => SlotError::NotAligned,
            _ => SlotError::OutOfBounds,
        }
    }
}

/// The `STAGING` flash region as NOR flash (no field: its bounds are the linker's symbols).
pub struct FlashSlot {
    _only_through_new: (),
}

impl FlashSlot {
    /// The slot of `memory.x`.
    ///
    /// # Safety
    ///
    /// At most one `FlashSlot` may exist: it is the only code that touches the region.
    pub unsafe fn new() -> FlashSlot {
        FlashSlot { _only_through_new: () }
    }

    /// First byte of the slot.
    fn base(&self) -> *mut u8 {
        // Only the address of the linker symbol is taken, never its contents.
        addr_of!(__staging_start) as *mut u8
    }

    /// Slot offset `at` as an address (the callers checked it against the length).
    fn at(&self, at: usize) -> *mut u8 {
        self.base().wrapping_add(at)
    }
}

impl ErrorType for FlashSlot {
    type Error = SlotError;
}

impl ReadNorFlash for FlashSlot {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), SlotError> {
        check_read(self, offset, bytes.len())?;
        let from = self.contents().get(offset as usize..).unwrap_or(&[]);
        for (d, &s) in bytes.iter_mut().zip(from) {
            *d = s;
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        (addr_of!(__staging_end) as usize).saturating_sub(addr_of!(__staging_start) as usize)
    }
}

impl NorFlash for FlashSlot {
    const WRITE_SIZE: usize = WRITE_SIZE;
    const ERASE_SIZE: usize = ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), SlotError> {
        check_erase(self, from, to)?;
        for a in from as usize..to as usize {
            // SAFETY: inside the slot (checked above), which only this driver touches.
            unsafe { write_volatile(self.at(a), 0xFF) };
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SlotError> {
        check_write(self, offset, bytes.len())?;
        let start = offset as usize;
        // Every target byte must be erased before any is programmed.
        for a in start..start + bytes.len() {
            // SAFETY: inside the slot (checked above).
            if unsafe { read_volatile(self.at(a)) } != 0xFF {
                return Err(SlotError::NotErased);
            }
        }
        for (a, &b) in (start..).zip(bytes) {
            // SAFETY: inside the slot (checked above), which only this driver touches.
            unsafe { write_volatile(self.at(a), b) };
            // SAFETY: as above.
            if unsafe { read_volatile(self.at(a)) } != b {
                return Err(SlotError::Verify);
            }
        }
        Ok(())
    }
}

impl MappedFlash for FlashSlot {
    fn contents(&self) -> &[u8] {
        // SAFETY: the slot is `len` readable bytes of memory-mapped flash that only this
        // driver writes, through `&mut self`: no write happens while this borrow lives.
        unsafe { core::slice::from_raw_parts(self.base(), self.capacity()) }
    }
}
