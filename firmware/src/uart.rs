//! Driver of the ARM CMSDK APB UART (UART0 of the MPS2 at `0x4000_4000`), with the
//! `embedded-io` traits so the application logic stays hardware-independent.
//!
//! Registers (CMSDK APB UART TRM):
//!
//! | offset | name | use |
//! |---|---|---|
//! | 0x00 | DATA | bits 7:0, received / to transmit |
//! | 0x04 | STATE | bit 0 TX buffer full, bit 1 RX buffer full, bit 2 TX overrun, bit 3 RX overrun (write 1 to clear) |
//! | 0x08 | CTRL | bit 0 TX enable, bit 1 RX enable, bits 2..5 interrupt enables |
//! | 0x0C | INTSTATUS / INTCLEAR | bit 0 TX, bit 1 RX, bit 2 TX overrun, bit 3 RX overrun (write 1 to clear) |
//! | 0x10 | BAUDDIV | baud divider, at least 16 |
//!
//! The UART has a one-byte buffer each way and no FIFO. QEMU applies back-pressure on its
//! character backend (a TCP socket waits while the RX buffer is full), so no byte is lost in
//! emulation; on hardware, the lock-step protocol keeps the host from overrunning the buffer
//! while the device computes, and RX overruns are counted ([`CmsdkUart::rx_overruns`]).

use core::convert::Infallible;
use core::ptr::{read_volatile, write_volatile};

use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};
use fbg_firmware_device::link::{read_available, ByteReceiver};

/// Base address of UART0 on the MPS2 AN385/AN386 (QEMU `mps2-an386` serial0).
pub const UART0_BASE: usize = 0x4000_4000;
/// APB clock of the MPS2 FPGA images (25 MHz).
pub const MPS2_PCLK_HZ: u32 = 25_000_000;

const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTSTATUS: usize = 0x0C;
const BAUDDIV: usize = 0x10;

const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const STATE_TX_OVERRUN: u32 = 1 << 2;
const STATE_RX_OVERRUN: u32 = 1 << 3;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_RX_INT_EN: u32 = 1 << 3;
const INT_RX: u32 = 1 << 1;

/// NVIC line of the UART0 receive interrupt on the MPS2 AN385/AN386 (QEMU `mps2-an386`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Uart0Rx;

impl Uart0Rx {
    /// Its line number.
    pub const LINE: u16 = 0;
}

// SAFETY: 0 is a valid external interrupt number of this board (UART0 RX).
unsafe impl cortex_m::interrupt::InterruptNumber for Uart0Rx {
    fn number(self) -> u16 {
        Self::LINE
    }
}

/// One CMSDK APB UART.
pub struct CmsdkUart {
    base: usize,
    rx_overruns: u32,
    /// Sleep with `wfi` while waiting for a byte (see [`CmsdkUart::enable_rx_wakeup`]).
    rx_wakeup: Option<u16>,
}

/// The NVIC line number as the `InterruptNumber` trait wants it.
#[derive(Clone, Copy)]
struct Line(u16);

// SAFETY: only built from the number of an `InterruptNumber` the caller vouched for.
unsafe impl cortex_m::interrupt::InterruptNumber for Line {
    fn number(self) -> u16 {
        self.0
    }
}

impl CmsdkUart {
    /// Take the UART at `base`.
    ///
    /// # Safety
    /// `base` must be the address of a CMSDK APB UART and this must be its only driver.
    pub const unsafe fn new(base: usize) -> Self {
        CmsdkUart { base, rx_overruns: 0, rx_wakeup: None }
    }

    /// Set the baud rate from the APB clock and enable transmitter and receiver, interrupts
    /// off (see [`CmsdkUart::enable_rx_wakeup`] to sleep while waiting).
    pub fn init(&mut self, pclk_hz: u32, baud: u32) {
        let div = pclk_hz.checked_div(baud).unwrap_or(16).clamp(16, 0x000F_FFFF);
        self.write_reg(CTRL, 0);
        self.write_reg(BAUDDIV, div);
        self.write_reg(STATE, STATE_TX_OVERRUN | STATE_RX_OVERRUN);
        self.write_reg(INTSTATUS, 0xF);
        self.write_reg(CTRL, CTRL_TX_EN | CTRL_RX_EN);
    }

    /// Sleep (`wfi`) instead of spinning while a read waits for data: the UART's receive
    /// interrupt is enabled and unmasked in the NVIC as a wake-up event only, and PRIMASK is set
    /// so that no handler runs (a pending interrupt wakes `wfi` even when masked by PRIMASK,
    /// ARMv7-M). `irq` is this UART's receive interrupt line. Call once, before serving.
    pub fn enable_rx_wakeup<I: cortex_m::interrupt::InterruptNumber>(&mut self, irq: I) {
        cortex_m::interrupt::disable();
        let line = irq.number();
        self.write_reg(INTSTATUS, INT_RX);
        cortex_m::peripheral::NVIC::unpend(Line(line));
        self.write_reg(CTRL, self.read_reg(CTRL) | CTRL_RX_INT_EN);
        // SAFETY: PRIMASK is set above, so unmasking cannot run a handler; the line only wakes
        // `wfi`.
        unsafe { cortex_m::peripheral::NVIC::unmask(Line(line)) };
        self.rx_wakeup = Some(line);
    }

    /// Received bytes lost because the RX buffer was full (hardware only; QEMU never loses).
    pub fn rx_overruns(&self) -> u32 {
        self.rx_overruns
    }

    /// Queue `byte` for transmission if the TX buffer has room.
    pub fn try_write_byte(&mut self, byte: u8) -> bool {
        if self.read_reg(STATE) & STATE_TX_FULL != 0 {
            return false;
        }
        self.write_reg(DATA, byte as u32);
        true
    }

    fn read_reg(&self, off: usize) -> u32 {
        // SAFETY: `new`'s contract: `base + off` is a register of this UART.
        unsafe { read_volatile((self.base + off) as *const u32) }
    }

    fn write_reg(&mut self, off: usize, v: u32) {
        // SAFETY: as in `read_reg`; we are its only driver.
        unsafe { write_volatile((self.base + off) as *mut u32, v) }
    }
}

impl ErrorType for CmsdkUart {
    type Error = Infallible;
}

impl ByteReceiver for CmsdkUart {
    /// A received byte, if one is waiting.
    fn try_read_byte(&mut self) -> Option<u8> {
        let state = self.read_reg(STATE);
        if state & STATE_RX_OVERRUN != 0 {
            self.rx_overruns = self.rx_overruns.wrapping_add(1);
            self.write_reg(STATE, STATE_RX_OVERRUN);
        }
        if state & STATE_RX_FULL != 0 {
            Some((self.read_reg(DATA) & 0xFF) as u8)
        } else {
            None
        }
    }

    /// Wait for the next event: sleep when wake-ups are enabled, spin otherwise.
    fn idle(&mut self) {
        match self.rx_wakeup {
            Some(line) => {
                // Clear the previous wake-up, then sleep only if nothing arrived meanwhile (a
                // byte arriving after this check pends the interrupt, and `wfi` returns at once).
                self.write_reg(INTSTATUS, INT_RX);
                cortex_m::peripheral::NVIC::unpend(Line(line));
                if self.read_reg(STATE) & STATE_RX_FULL == 0 {
                    cortex_m::asm::wfi();
                }
            }
            None => core::hint::spin_loop(),
        }
    }
}

impl Read for CmsdkUart {
    /// Block until at least one byte arrived, then return what is there without blocking.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        Ok(read_available(self, buf))
    }
}

impl ReadReady for CmsdkUart {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.read_reg(STATE) & STATE_RX_FULL != 0)
    }
}

impl Write for CmsdkUart {
    /// Block until the first byte is queued, then queue what fits without blocking.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let mut n = 0;
        for &b in buf {
            while !self.try_write_byte(b) {
                if n > 0 {
                    return Ok(n);
                }
                core::hint::spin_loop();
            }
            n += 1;
        }
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        while self.read_reg(STATE) & STATE_TX_FULL != 0 {
            core::hint::spin_loop();
        }
        Ok(())
    }
}

impl WriteReady for CmsdkUart {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.read_reg(STATE) & STATE_TX_FULL == 0)
    }
}
