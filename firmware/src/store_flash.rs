//! The flash of the persistent model store: the `STORE` region of the top-level `memory.x`
//! (outside the image, so the linker never places code or data there), driven as NOR flash
//! through the `embedded-storage` traits the store takes ([`fbg_firmware_app::MappedFlash`]).
//!
//! On QEMU's `mps2-an386` the flash of `memory.x` is the board's SSRAM at `0x0`, which the CPU
//! can write: erasing and programming are volatile stores here. On a real part they are the
//! flash controller's sector erase and program sequences (unlock, erase the sector or program
//! the word, wait for completion, check its error flags, lock), and [`ERASE_SIZE`] and
//! [`WRITE_SIZE`] are the part's. Reading is the same on both: the flash is memory-mapped, so
//! the store checks and decodes a slot in place, with no copy in RAM.
//!
//! The driver enforces what the hardware would: an erase sets every byte of whole erase units
//! to `0xFF`; a write must start and end on the write granularity and lands only on erased
//! bytes (writing a byte that is not `0xFF` is [`FlashError::NotErased`], as a part with ECC
//! refuses it), and every written unit is read back. A missing erase is then an error on QEMU
//! as on a board, instead of silently overwriting a slot or the log.
//!
//! **Persistence under QEMU.** The emulated board's memory starts afresh with every run (and
//! QEMU's RAM at `0x0` reads zero, which is not erased flash), so the region is backed by a
//! file on the host, through semihosting file I/O: [`StoreFlash::open`] loads the file
//! [`FILE`] of QEMU's working directory into the region when it exists with the region's
//! length, and otherwise sets the region erased (a factory-fresh part) and creates the file
//! with it. Every erase and program then writes the bytes it changed through to the file (seek
//! and write) before it returns, so the file is the emulated part's non-volatile flash: killing
//! QEMU at any instant is a power cut, and the next run finds what a device that lost power
//! there would find. Deleting the file is a fresh device. The test harness gives every
//! persistent run its own working directory (`xtask`, `target/qemu/<test>/`).
//!
//! A host file that cannot be opened, read or written is a flash that does not work: a
//! warning is logged, the region reads erased (so the device boots its embedded model) and
//! every erase and program fails with [`FlashError::HostFile`] without touching the region
//! (the store refuses the update that needed it), so the file is never overwritten by a run
//! that could not read it, and nothing panics.

use core::ptr::{addr_of, read_volatile, write_volatile};

use embedded_storage::nor_flash::{
    check_erase, check_write, ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use fbg_firmware_app::MappedFlash;
use semihosting::fs::File;
use semihosting::io::{Read, Seek, SeekFrom, Write};

/// Erase granularity, bytes: one sector of the store (slot A, slot B, log 0, log 1).
pub const ERASE_SIZE: usize = 16 * 1024;
/// Write granularity, bytes (one 32-bit flash word).
pub const WRITE_SIZE: usize = 4;

/// The host file that keeps the region across QEMU runs, in QEMU's working directory.
pub const FILE: &core::ffi::CStr = c"fbg-flash.bin";

extern "C" {
    /// First byte of the `STORE` region (`memory.x`).
    static __store_start: u8;
    /// One past its last byte.
    static __store_end: u8;
}

/// Why the flash refused an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlashError {
    /// Offset or length not on the write (erase) granularity.
    NotAligned,
    /// Outside the region.
    OutOfBounds,
    /// A write over bytes that were not erased since they were last written.
    NotErased,
    /// A written unit did not read back as written.
    Verify,
    /// The host file behind the region (QEMU) could not be opened, read or written.
    HostFile,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            FlashError::NotErased | FlashError::Verify | FlashError::HostFile => NorFlashErrorKind::Other,
        }
    }
}

impl From<NorFlashErrorKind> for FlashError {
    fn from(k: NorFlashErrorKind) -> Self {
        match k {
            NorFlashErrorKind::NotAligned => FlashError::NotAligned,
            _ => FlashError::OutOfBounds,
        }
    }
}

/// Where the region's bytes persist.
enum Backing {
    /// The host file, open for reading and writing.
    File(File),
    /// Nowhere: the region lives as long as the run (test images that check the driver).
    Volatile,
    /// The host file failed: every erase and program fails.
    Broken,
}

/// The `STORE` flash region as NOR flash (its bounds are the linker's symbols).
pub struct StoreFlash {
    backing: Backing,
}

impl StoreFlash {
    /// The store's flash, persistent across QEMU runs: the region loaded from [`FILE`], or
    /// erased and the file created (see the module's documentation).
    ///
    /// # Safety
    ///
    /// At most one `StoreFlash` may exist: it is the only code that touches the region.
    pub unsafe fn open() -> StoreFlash {
        let mut flash = StoreFlash { backing: Backing::Broken };
        let len = flash.capacity();
        let existing = File::options().read(true).write(true).open(FILE);
        if let Ok(mut file) = existing {
            let same_length = file.metadata().map(|m| m.len() == len as u64).unwrap_or(false);
            if same_length {
                // SAFETY: the region is `len` bytes of writable memory that only this driver
                // touches, and no other borrow of it exists yet.
                let region = unsafe { core::slice::from_raw_parts_mut(flash.base(), len) };
                match file.read_exact(region) {
                    Ok(()) => {
                        flash.backing = Backing::File(file);
                        defmt::info!("store flash: {=usize} B loaded from the host file fbg-flash.bin", len);
                    }
                    Err(_) => {
                        flash.fill_erased();
                        defmt::warn!("store flash: the host file fbg-flash.bin could not be read; the flash is unusable this run");
                    }
                }
                return flash;
            }
            defmt::warn!(
                "store flash: the host file fbg-flash.bin is not {=usize} B long; starting from an erased part",
                len
            );
        }
        flash.fill_erased();
        let created = File::options().read(true).write(true).create(true).truncate(true).open(FILE);
        match created {
            Ok(mut file) => match write_all(&mut file, flash.contents()) {
                true => {
                    flash.backing = Backing::File(file);
                    defmt::info!("store flash: a fresh (erased) part, saved to the host file fbg-flash.bin");
                }
                false => defmt::warn!(
                    "store flash: the host file fbg-flash.bin could not be written; the flash is unusable this run"
                ),
            },
            Err(_) => defmt::warn!(
                "store flash: the host file fbg-flash.bin could not be created; the flash is unusable this run"
            ),
        }
        flash
    }

    /// The store's flash for the length of one run only, erased (test images that check the
    /// driver and must not touch a device's file).
    ///
    /// # Safety
    ///
    /// As [`StoreFlash::open`].
    pub unsafe fn volatile() -> StoreFlash {
        let mut flash = StoreFlash { backing: Backing::Volatile };
        flash.fill_erased();
        flash
    }

    /// First byte of the region.
    fn base(&self) -> *mut u8 {
        // Only the address of the linker symbol is taken, never its contents.
        addr_of!(__store_start) as *mut u8
    }

    /// Region offset `at` as an address (the callers checked it against the length).
    fn at(&self, at: usize) -> *mut u8 {
        self.base().wrapping_add(at)
    }

    /// Every byte of the region erased, in memory only.
    fn fill_erased(&mut self) {
        for a in 0..self.capacity() {
            // SAFETY: inside the region, which only this driver touches.
            unsafe { write_volatile(self.at(a), 0xFF) };
        }
    }

    /// Whether the region may change (its backing works).
    fn writable(&self) -> Result<(), FlashError> {
        match self.backing {
            Backing::Broken => Err(FlashError::HostFile),
            Backing::File(_) | Backing::Volatile => Ok(()),
        }
    }

    /// Write bytes `from..to` of the region through to the host file (nothing when volatile).
    /// A failure leaves the file behind the region: it is marked broken, so that no later
    /// operation pretends to persist.
    fn persist(&mut self, from: usize, to: usize) -> Result<(), FlashError> {
        let base = self.base();
        let Backing::File(file) = &mut self.backing else {
            return Ok(());
        };
        // SAFETY: `from..to` is inside the region (checked by the caller), which only this
        // driver writes, through `&mut self`.
        let bytes = unsafe { core::slice::from_raw_parts(base.wrapping_add(from), to.saturating_sub(from)) };
        let done = file.seek(SeekFrom::Start(from as u64)).is_ok() && write_all(file, bytes);
        if !done {
            defmt::warn!("store flash: writing bytes {=usize}..{=usize} to the host file failed", from, to);
            self.backing = Backing::Broken;
            return Err(FlashError::HostFile);
        }
        Ok(())
    }
}

impl ErrorType for StoreFlash {
    type Error = FlashError;
}

impl ReadNorFlash for StoreFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        Ok(fbg_firmware_app::staging::read_mapped(self, offset, bytes)?)
    }

    fn capacity(&self) -> usize {
        (addr_of!(__store_end) as usize).saturating_sub(addr_of!(__store_start) as usize)
    }
}

impl NorFlash for StoreFlash {
    const WRITE_SIZE: usize = WRITE_SIZE;
    const ERASE_SIZE: usize = ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        check_erase(self, from, to)?;
        self.writable()?;
        for a in from as usize..to as usize {
            // SAFETY: inside the region (checked above), which only this driver touches.
            unsafe { write_volatile(self.at(a), 0xFF) };
        }
        self.persist(from as usize, to as usize)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        check_write(self, offset, bytes.len())?;
        self.writable()?;
        let start = offset as usize;
        // Every target byte must be erased before any is programmed.
        for a in start..start + bytes.len() {
            // SAFETY: inside the region (checked above).
            if unsafe { read_volatile(self.at(a)) } != 0xFF {
                return Err(FlashError::NotErased);
            }
        }
        for (a, &b) in (start..).zip(bytes) {
            // SAFETY: inside the region (checked above), which only this driver touches.
            unsafe { write_volatile(self.at(a), b) };
            // SAFETY: as above.
            if unsafe { read_volatile(self.at(a)) } != b {
                // What did land is the flash's state now: keep the file in step with it.
                self.persist(start, a + 1)?;
                return Err(FlashError::Verify);
            }
        }
        self.persist(start, start + bytes.len())
    }
}

impl MappedFlash for StoreFlash {
    fn contents(&self) -> &[u8] {
        // SAFETY: the region is `capacity` readable bytes of memory-mapped flash that only this
        // driver writes, through `&mut self`: no write happens while this borrow lives.
        unsafe { core::slice::from_raw_parts(self.base(), self.capacity()) }
    }
}

/// Write all of `bytes` to `file` (whether it all went): semihosting's `write_all` without its
/// panic path, which would link `core::fmt` into the image.
fn write_all(file: &mut File, mut bytes: &[u8]) -> bool {
    while !bytes.is_empty() {
        match file.write(bytes) {
            Ok(n) if n > 0 => bytes = bytes.get(n..).unwrap_or(&[]),
            _ => return false,
        }
    }
    true
}
