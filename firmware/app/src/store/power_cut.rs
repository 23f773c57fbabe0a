//! A power cut at a chosen flash operation: the torture tests' way to stop an update at any
//! point of its erases and programs.
//!
//! [`PowerCut`] wraps the store's flash and counts every erase and program. The operation
//! numbered `cut_at` (1 for the first) is done only in part — an erase leaves the first half of its
//! range erased and the second programmed to zero (an erase pre-programs every bit first), a program writes the first half of its
//! bytes (whole write units) — as when the supply fails in the middle of it; then `on_cut` runs
//! (the emulator's test image ends the run there, a board would lose power), and every later
//! erase or program fails without touching the flash, so that what the flash holds is exactly
//! what a device that lost power at that instant would find at its next boot.

use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash};

use super::MappedFlash;

/// An error of the wrapped flash, or the power being gone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CutError<E> {
    /// The wrapped flash refused the operation.
    Flash(E),
    /// The power was cut at or before this operation.
    PowerLost,
}

impl<E: NorFlashError> NorFlashError for CutError<E> {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            CutError::Flash(e) => e.kind(),
            CutError::PowerLost => NorFlashErrorKind::Other,
        }
    }
}

/// `F` with its power cut in its `cut_at`-th erase or program (never with 0).
pub struct PowerCut<F> {
    flash: F,
    /// Operations done so far (erases and programs, the cut one included).
    ops: u32,
    /// The operation the power fails in (0: never).
    cut_at: u32,
    on_cut: fn(),
}

impl<F: MappedFlash> PowerCut<F> {
    /// `flash` losing power in its `cut_at`-th erase or program (0: never), then calling `on_cut`.
    pub fn new(flash: F, cut_at: u32, on_cut: fn()) -> Self {
        PowerCut { flash, ops: 0, cut_at, on_cut }
    }

    /// Erases and programs so far (the cut one included).
    pub fn ops(&self) -> u32 {
        self.ops
    }

    /// Whether the power is gone.
    pub fn is_cut(&self) -> bool {
        self.cut_at != 0 && self.ops >= self.cut_at
    }

    /// The wrapped flash.
    pub fn into_inner(self) -> F {
        self.flash
    }

    /// Count one operation: `Ok(true)` to do it whole, `Ok(false)` to do it in part (the cut),
    /// `Err` when the power is already gone.
    fn tick(&mut self) -> Result<bool, CutError<F::Error>> {
        if self.is_cut() {
            return Err(CutError::PowerLost);
        }
        self.ops = self.ops.saturating_add(1);
        Ok(!self.is_cut())
    }
}

impl<F: MappedFlash> ErrorType for PowerCut<F> {
    type Error = CutError<F::Error>;
}

impl<F: MappedFlash> ReadNorFlash for PowerCut<F> {
    const READ_SIZE: usize = F::READ_SIZE;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.flash.read(offset, bytes).map_err(CutError::Flash)
    }

    fn capacity(&self) -> usize {
        self.flash.capacity()
    }
}

impl<F: MappedFlash> NorFlash for PowerCut<F> {
    const WRITE_SIZE: usize = F::WRITE_SIZE;
    const ERASE_SIZE: usize = F::ERASE_SIZE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if self.tick()? {
            return self.flash.erase(from, to).map_err(CutError::Flash);
        }
        // An erase first programs every bit to 0, then erases: cut in the middle, the range
        // reads erased in its first half and programmed to zero in the second (neither the old
        // contents nor erased flash).
        let _ = self.flash.erase(from, to);
        let zeros = [0u8; 64];
        let unit = (zeros.len() / F::WRITE_SIZE).max(1) * F::WRITE_SIZE;
        let mut at = from as usize + half_units(to.saturating_sub(from) as usize, F::WRITE_SIZE);
        while at < to as usize {
            let n = unit.min(to as usize - at);
            let _ = self.flash.write(at as u32, zeros.get(..n).unwrap_or(&[]));
            at += n;
        }
        (self.on_cut)();
        Err(CutError::PowerLost)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        if self.tick()? {
            return self.flash.write(offset, bytes).map_err(CutError::Flash);
        }
        let half = half_units(bytes.len(), F::WRITE_SIZE);
        if half > 0 {
            let _ = self.flash.write(offset, bytes.get(..half).unwrap_or(&[]));
        }
        (self.on_cut)();
        Err(CutError::PowerLost)
    }
}

impl<F: MappedFlash> MappedFlash for PowerCut<F> {
    fn contents(&self) -> &[u8] {
        self.flash.contents()
    }
}

/// Half of `len` bytes, rounded down to whole units of `unit` bytes.
fn half_units(len: usize, unit: usize) -> usize {
    (len / 2) / unit.max(1) * unit.max(1)
}
