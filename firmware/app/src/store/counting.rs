//! The store's flash with its erase and program operations counted (`StoreStatus::flash_ops`),
//! and its sectors as slices.

use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};

use super::MappedFlash;

/// `F`, counting every erase and program passed to it.
pub struct Counting<F> {
    flash: F,
    ops: u32,
}

impl<F: MappedFlash> Counting<F> {
    /// `flash`, nothing counted yet.
    pub fn new(flash: F) -> Self {
        Counting { flash, ops: 0 }
    }

    /// Erases and programs so far (failed ones included).
    pub fn ops(&self) -> u32 {
        self.ops
    }

    /// The flash.
    pub fn inner(&self) -> &F {
        &self.flash
    }

    /// The flash, mutable.
    pub fn inner_mut(&mut self) -> &mut F {
        &mut self.flash
    }

    /// Sector `i` (erase unit `i`) as the CPU reads it (empty beyond the flash).
    pub fn sector(&self, i: usize) -> &[u8] {
        let e = F::ERASE_SIZE;
        self.flash.contents().get(i * e..(i + 1) * e).unwrap_or(&[])
    }
}

impl<F: MappedFlash> ErrorType for Counting<F> {
    type Error = F::Error;
}

impl<F: MappedFlash> ReadNorFlash for Counting<F> {
    const READ_SIZE: usize = F::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), F::Error> {
        self.flash.read(offset, bytes)
    }

    fn capacity(&self) -> usize {
        self.flash.capacity()
    }
}

impl<F: MappedFlash> NorFlash for Counting<F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), F::Error> {
        self.ops = self.ops.wrapping_add(1);
        self.flash.erase(from, to)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), F::Error> {
        self.ops = self.ops.wrapping_add(1);
        self.flash.write(offset, bytes)
    }
}

impl<F: MappedFlash> MappedFlash for Counting<F> {
    fn contents(&self) -> &[u8] {
        self.flash.contents()
    }
}
