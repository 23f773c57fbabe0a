//! The model store's flash: sectors 5–8 of the STM32F405 (`STORE` of `memory.x`, four 128 KiB
//! erase units at `0x0802_0000..0x0810_0000`, outside the image, so the linker never places
//! code or data there), driven as NOR flash through the `embedded-storage` traits the
//! application takes, and read in place ([`fbg_firmware_app::MappedFlash`]).
//!
//! On the part, erasing and programming are the flash controller's sequences (RM0090 §3.6):
//! unlock (`KEYR`), sector erase (`SER`, `SNB`, `STRT`) or word programming (`PG`, `PSIZE` =
//! x32), wait while `BSY`, check the error flags, lock again; the ART data cache is reset after
//! each, since it may hold the bytes from before. The CPU stalls while the single bank is busy
//! (no code runs from RAM): nothing else runs meanwhile, and a sector erase stalls it for as
//! long as the erase takes. In the `emulator` build (QEMU's flash is ROM, its flash controller
//! unmodelled) the store is RAM (`memory-emulator.x`), erased and programmed with stores, in
//! four 16 KiB units.
//!
//! On both the driver enforces what the hardware would: an erase sets every byte of whole
//! erase units to `0xFF`; a write must start and end on the write granularity and lands only on
//! erased bytes ([`StoreError::NotErased`] otherwise, as the part refuses to program a word
//! twice), and every written word is read back ([`StoreError::Verify`]). A missing erase is
//! then an error in the emulator as on the part.

use core::ptr::{addr_of, read_volatile};

use embedded_storage::nor_flash::{
    check_erase, check_write, ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use fbg_firmware_app::MappedFlash;

/// Erase granularity of the store: one flash sector of 128 KiB (sectors 5–8 of the part).
#[cfg(not(feature = "emulator"))]
pub const ERASE_SIZE: usize = 128 * 1024;
/// Erase granularity of the store: 16 KiB units of RAM in the emulator (the store keeps its
/// shape of four equal units in the 64 KiB QEMU maps beyond the part's SRAM).
#[cfg(feature = "emulator")]
pub const ERASE_SIZE: usize = 16 * 1024;
/// Write granularity of the store, bytes (one 32-bit word, `PSIZE` = x32).
pub const WRITE_SIZE: usize = 4;
/// Erase units of the store (slot A, slot B, log 0, log 1).
pub const UNITS: usize = 4;
/// The flash sector of the store's first unit (on the part).
pub const FIRST_SECTOR: u8 = 5;

extern "C" {
    /// First byte of the `STORE` region (`memory.x`).
    static __store_start: u8;
    /// One past its last byte.
    static __store_end: u8;
}

/// Why the store refused an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum StoreError {
    /// Offset or length not on the write (erase) granularity.
    NotAligned,
    /// Outside the store.
    OutOfBounds,
    /// A write over bytes that were not erased since they were last written.
    NotErased,
    /// A written word did not read back as written.
    Verify,
    /// The flash controller reported an error (its `SR` error bits).
    Controller(u32),
}

impl NorFlashError for StoreError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            StoreError::NotAligned => NorFlashErrorKind::NotAligned,
            StoreError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            StoreError::NotErased | StoreError::Verify | StoreError::Controller(_) => NorFlashErrorKind::Other,
        }
    }
}

impl From<NorFlashErrorKind> for StoreError {
    fn from(k: NorFlashErrorKind) -> Self {
        match k {
            NorFlashErrorKind::NotAligned => StoreError::NotAligned,
            _ => StoreError::OutOfBounds,
        }
    }
}

/// The `STORE` region as NOR flash.
pub struct StoreFlash {
    /// The flash controller (unused in the emulator, which has none).
    #[cfg_attr(feature = "emulator", allow(dead_code))]
    flash: stm32f4xx_hal::pac::FLASH,
}

impl StoreFlash {
    /// The store of `memory.x`, programmed through `flash`.
    pub fn new(flash: stm32f4xx_hal::pac::FLASH) -> StoreFlash {
        StoreFlash { flash }
    }

    /// First byte of the store.
    fn base(&self) -> *mut u8 {
        // Only the address of the linker symbol is taken, never its contents.
        addr_of!(__store_start) as *mut u8
    }

    /// Store offset `at` as an address (the callers checked it against the capacity).
    fn at(&self, at: usize) -> *mut u8 {
        self.base().wrapping_add(at)
    }
}

impl ErrorType for StoreFlash {
    type Error = StoreError;
}

impl ReadNorFlash for StoreFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), StoreError> {
        Ok(fbg_firmware_app::staging::read_mapped(self, offset, bytes)?)
    }

    fn capacity(&self) -> usize {
        (addr_of!(__store_end) as usize).saturating_sub(addr_of!(__store_start) as usize)
    }
}

impl NorFlash for StoreFlash {
    const WRITE_SIZE: usize = WRITE_SIZE;
    const ERASE_SIZE: usize = ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), StoreError> {
        check_erase(self, from, to)?;
        let mut unit = from as usize / ERASE_SIZE;
        while unit < to as usize / ERASE_SIZE {
            self.erase_unit(unit)?;
            unit += 1;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), StoreError> {
        check_write(self, offset, bytes.len())?;
        let start = offset as usize;
        // Every target byte must be erased before any is programmed.
        for a in start..start + bytes.len() {
            // SAFETY: inside the store (checked above).
            if unsafe { read_volatile(self.at(a)) } != 0xFF {
                return Err(StoreError::NotErased);
            }
        }
        for (i, w) in bytes.chunks_exact(WRITE_SIZE).enumerate() {
            let word = u32::from_le_bytes([
                w.first().copied().unwrap_or(0xFF),
                w.get(1).copied().unwrap_or(0xFF),
                w.get(2).copied().unwrap_or(0xFF),
                w.get(3).copied().unwrap_or(0xFF),
            ]);
            let at = start + i * WRITE_SIZE;
            self.program_word(at, word)?;
            // SAFETY: word-aligned (check_write), inside the store.
            if unsafe { read_volatile(self.at(at) as *const u32) } != word {
                return Err(StoreError::Verify);
            }
        }
        Ok(())
    }
}

#[cfg(not(feature = "emulator"))]
mod controller {
    //! The flash controller's sequences (RM0090 §3.6, STM32F405).

    use super::{StoreError, StoreFlash, FIRST_SECTOR};

    const KEY1: u32 = 0x4567_0123;
    const KEY2: u32 = 0xCDEF_89AB;
    /// `SR` error bits: PGSERR, PGPERR, PGAERR, WRPERR, OPERR.
    const SR_ERRORS: u32 = 0b1111_0010;
    /// `SR` end of operation (write 1 to clear).
    const SR_EOP: u32 = 1;
    /// `CR.PSIZE` = x32 (2 at bits 9:8): words, at the part's 2.7–3.6 V.
    const PSIZE_X32: u8 = 0b10;

    impl StoreFlash {
        /// Unlock the controller, wait until idle and clear stale flags.
        fn unlock(&mut self) {
            let f = &self.flash;
            if f.cr().read().lock().bit_is_set() {
                // SAFETY: the documented key sequence; any value is valid for KEYR.
                f.keyr().write(|w| unsafe { w.key().bits(KEY1) });
                // SAFETY: as above.
                f.keyr().write(|w| unsafe { w.key().bits(KEY2) });
            }
            self.wait_idle();
            // SAFETY: writing 1 clears these flags; the other bits are reserved or read-only.
            self.flash.sr().write(|w| unsafe { w.bits(SR_ERRORS | SR_EOP) });
        }

        /// Clear the operation bits and lock the controller again.
        fn lock(&mut self) {
            self.flash.cr().modify(|_, w| w.ser().clear_bit().pg().clear_bit().lock().set_bit());
        }

        fn wait_idle(&self) {
            while self.flash.sr().read().bsy().bit_is_set() {
                core::hint::spin_loop();
            }
        }

        /// The error flags of the last operation, as an error.
        fn result(&self) -> Result<(), StoreError> {
            let e = self.flash.sr().read().bits() & SR_ERRORS;
            if e == 0 {
                Ok(())
            } else {
                Err(StoreError::Controller(e))
            }
        }

        /// Reset the ART data cache: it may hold what a sector held before it changed.
        fn flush_data_cache(&mut self) {
            let acr = &self.flash.acr();
            if acr.read().dcen().bit_is_set() {
                acr.modify(|_, w| w.dcen().clear_bit());
                acr.modify(|_, w| w.dcrst().set_bit());
                acr.modify(|_, w| w.dcrst().clear_bit().dcen().set_bit());
            }
        }

        /// Erase unit `unit` of the store (sector `FIRST_SECTOR + unit`).
        pub(super) fn erase_unit(&mut self, unit: usize) -> Result<(), StoreError> {
            let sector = FIRST_SECTOR.saturating_add(u8::try_from(unit).map_err(|_| StoreError::OutOfBounds)?);
            self.unlock();
            // SAFETY: SNB is a sector of the store (the caller checked the unit), PSIZE a valid
            // parallelism.
            self.flash.cr().modify(|_, w| unsafe {
                w.pg().clear_bit().ser().set_bit().snb().bits(sector).psize().bits(PSIZE_X32)
            });
            self.flash.cr().modify(|_, w| w.strt().set_bit());
            self.wait_idle();
            let r = self.result();
            self.lock();
            self.flush_data_cache();
            r
        }

        /// Program the word at store offset `at` (word-aligned, erased, inside the store).
        pub(super) fn program_word(&mut self, at: usize, word: u32) -> Result<(), StoreError> {
            self.unlock();
            // SAFETY: PSIZE x32, programming on.
            self.flash.cr().modify(|_, w| unsafe { w.ser().clear_bit().psize().bits(PSIZE_X32).pg().set_bit() });
            // SAFETY: a word-aligned address of the store, which only this driver writes.
            unsafe { core::ptr::write_volatile(self.at(at) as *mut u32, word) };
            cortex_m::asm::dsb();
            self.wait_idle();
            let r = self.result();
            self.lock();
            self.flush_data_cache();
            r
        }
    }
}

#[cfg(feature = "emulator")]
mod ram {
    //! The emulator's store: RAM, erased and programmed with stores.

    use core::ptr::write_volatile;

    use super::{StoreError, StoreFlash, ERASE_SIZE};

    impl StoreFlash {
        /// Erase unit `unit` of the store: every byte `0xFF`.
        pub(super) fn erase_unit(&mut self, unit: usize) -> Result<(), StoreError> {
            let from = unit * ERASE_SIZE;
            for a in from..from + ERASE_SIZE {
                // SAFETY: inside the store (the caller checked the unit), which only this
                // driver touches.
                unsafe { write_volatile(self.at(a), 0xFF) };
            }
            Ok(())
        }

        /// Program the word at store offset `at` (word-aligned, erased, inside the store).
        pub(super) fn program_word(&mut self, at: usize, word: u32) -> Result<(), StoreError> {
            // SAFETY: a word-aligned address of the store, which only this driver writes.
            unsafe { write_volatile(self.at(at) as *mut u32, word) };
            Ok(())
        }
    }
}

impl MappedFlash for StoreFlash {
    fn contents(&self) -> &[u8] {
        // SAFETY: the store is `capacity` readable bytes of memory-mapped flash (RAM in the
        // emulator) that only this driver writes, through `&mut self`: no write happens while
        // this borrow lives.
        unsafe { core::slice::from_raw_parts(self.base(), self.capacity()) }
    }
}
