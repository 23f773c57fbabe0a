//! The alarm output: an `embedded-hal` 1.0 `OutputPin` on one LED of the MPS2 FPGA IO block.
//!
//! FPGAIO is at `0x4002_8000`; its LED register (offset 0) drives the user LEDs, one bit each.
//! On a real interrogator the same pin type would wrap the alarm relay's GPIO.

use core::convert::Infallible;
use core::ptr::{read_volatile, write_volatile};

use embedded_hal::digital::{ErrorType, OutputPin, StatefulOutputPin};

/// Base address of the MPS2 FPGA IO block.
pub const FPGAIO_BASE: usize = 0x4002_8000;
/// Offset of the LED register.
pub const FPGAIO_LED: usize = 0x00;

/// One LED bit of the FPGA IO LED register.
pub struct FpgaioLed {
    mask: u32,
}

impl FpgaioLed {
    /// The LED at `bit` (0 or 1 on the MPS2).
    ///
    /// # Safety
    /// Only one `FpgaioLed` may exist per bit; the register is read-modify-written without a
    /// lock, so all LED pins must be driven from the same context.
    pub const unsafe fn new(bit: u8) -> Self {
        FpgaioLed { mask: 1 << (bit & 31) }
    }

    fn reg() -> *mut u32 {
        (FPGAIO_BASE + FPGAIO_LED) as *mut u32
    }

    fn read() -> u32 {
        // SAFETY: the FPGAIO LED register exists on this board (`new`'s contract).
        unsafe { read_volatile(Self::reg()) }
    }

    fn write(v: u32) {
        // SAFETY: as in `read`.
        unsafe { write_volatile(Self::reg(), v) }
    }
}

impl ErrorType for FpgaioLed {
    type Error = Infallible;
}

impl OutputPin for FpgaioLed {
    fn set_high(&mut self) -> Result<(), Infallible> {
        Self::write(Self::read() | self.mask);
        Ok(())
    }

    fn set_low(&mut self) -> Result<(), Infallible> {
        Self::write(Self::read() & !self.mask);
        Ok(())
    }
}

impl StatefulOutputPin for FpgaioLed {
    fn is_set_high(&mut self) -> Result<bool, Infallible> {
        Ok(Self::read() & self.mask != 0)
    }

    fn is_set_low(&mut self) -> Result<bool, Infallible> {
        Ok(Self::read() & self.mask == 0)
    }
}
