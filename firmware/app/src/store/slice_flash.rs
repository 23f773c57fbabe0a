//! NOR flash in a byte slice: the store's flash in host tests and in tools that build a store
//! image on the host (e.g. a pre-filled event log for the boot-time bench).

use embedded_storage::nor_flash::{
    check_erase, check_write, ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

use super::MappedFlash;

/// Why [`SliceFlash`] refused an operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SliceFlashError {
    /// Offset or length not on the granularity.
    NotAligned,
    /// Outside the slice.
    OutOfBounds,
    /// A program over bytes not erased since they were last programmed.
    NotErased,
}

impl NorFlashError for SliceFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            SliceFlashError::NotAligned => NorFlashErrorKind::NotAligned,
            SliceFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            SliceFlashError::NotErased => NorFlashErrorKind::Other,
        }
    }
}

impl From<NorFlashErrorKind> for SliceFlashError {
    fn from(k: NorFlashErrorKind) -> Self {
        match k {
            NorFlashErrorKind::NotAligned => SliceFlashError::NotAligned,
            _ => SliceFlashError::OutOfBounds,
        }
    }
}

/// `bytes` as NOR flash with erase units of `ERASE` bytes and write units of `WRITE` bytes,
/// with the semantics of a part with ECC: an erase sets whole units to `0xFF`, a program
/// lands only on erased bytes, once. Counts its erases and programs.
pub struct SliceFlash<'a, const ERASE: usize, const WRITE: usize> {
    bytes: &'a mut [u8],
    erases: u32,
    programs: u32,
}

impl<'a, const ERASE: usize, const WRITE: usize> SliceFlash<'a, ERASE, WRITE> {
    /// Flash over `bytes` as they are (`0xFF` where erased).
    pub fn new(bytes: &'a mut [u8]) -> Self {
        SliceFlash { bytes, erases: 0, programs: 0 }
    }

    /// Erase operations so far.
    pub fn erases(&self) -> u32 {
        self.erases
    }

    /// Program operations so far.
    pub fn programs(&self) -> u32 {
        self.programs
    }
}

impl<const ERASE: usize, const WRITE: usize> ErrorType for SliceFlash<'_, ERASE, WRITE> {
    type Error = SliceFlashError;
}

impl<const ERASE: usize, const WRITE: usize> ReadNorFlash for SliceFlash<'_, ERASE, WRITE> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), SliceFlashError> {
        Ok(crate::staging::read_mapped(self, offset, bytes)?)
    }

    fn capacity(&self) -> usize {
        self.bytes.len()
    }
}

impl<const ERASE: usize, const WRITE: usize> NorFlash for SliceFlash<'_, ERASE, WRITE> {
    const WRITE_SIZE: usize = WRITE;
    const ERASE_SIZE: usize = ERASE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), SliceFlashError> {
        check_erase(self, from, to)?;
        self.erases = self.erases.wrapping_add(1);
        for b in self.bytes.get_mut(from as usize..to as usize).unwrap_or(&mut []) {
            *b = 0xFF;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SliceFlashError> {
        check_write(self, offset, bytes.len())?;
        let at = offset as usize;
        let target = self.bytes.get_mut(at..at + bytes.len()).ok_or(SliceFlashError::OutOfBounds)?;
        if target.iter().any(|&b| b != 0xFF) {
            return Err(SliceFlashError::NotErased);
        }
        self.programs = self.programs.wrapping_add(1);
        target.copy_from_slice(bytes);
        Ok(())
    }
}

impl<const ERASE: usize, const WRITE: usize> MappedFlash for SliceFlash<'_, ERASE, WRITE> {
    fn contents(&self) -> &[u8] {
        self.bytes
    }
}
