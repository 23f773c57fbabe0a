//! The link's USART as `embedded-io` 0.7 `Read`/`Write`, the traits the application takes.
//!
//! `stm32f4xx-hal` 0.23 implements `embedded-io` 0.6 (and only `Write`), so this thin adapter
//! drives the HAL's receiver and transmitter through their `embedded-hal-nb` byte traits
//! instead. Receive errors (overrun, framing, noise, parity) drop the byte and are counted
//! ([`Link::rx_errors`]): the link's framing (COBS, CRC-32) drops the frame they corrupt, as
//! it does any other, so the error type stays `Infallible` and serving never stops on one.

use core::convert::Infallible;

use cortex_m::peripheral::NVIC;
use embedded_hal_nb::serial::{Read as NbRead, Write as NbWrite};
use embedded_io::{ErrorType, Read, ReadReady, Write, WriteReady};
use fbg_firmware_device::link::{read_available, ByteReceiver};
use stm32f4xx_hal::pac::Interrupt;
use stm32f4xx_hal::serial::{Instance, Rx, RxISR, RxListen, Tx};

/// One USART of the HAL, split, as a byte stream.
pub struct Link<U: Instance> {
    tx: Tx<U>,
    rx: Rx<U>,
    rx_errors: u32,
    /// Sleep with `wfi` while waiting for a byte (see [`Link::enable_rx_wakeup`]).
    rx_wakeup: Option<Interrupt>,
}

impl<U: Instance> Link<U> {
    /// The stream over the HAL's transmitter and receiver of one USART.
    pub fn new(tx: Tx<U>, rx: Rx<U>) -> Self {
        Link { tx, rx, rx_errors: 0, rx_wakeup: None }
    }

    /// Sleep (`wfi`) instead of spinning while a read waits for data: the USART's
    /// receive-not-empty interrupt is enabled and unmasked in the NVIC as a wake-up event
    /// only, with PRIMASK set so that no handler runs (a pending interrupt wakes `wfi` even
    /// when masked by PRIMASK, ARMv7-M). `line` is this USART's interrupt. Call once, before
    /// serving.
    pub fn enable_rx_wakeup(&mut self, line: Interrupt) {
        cortex_m::interrupt::disable();
        NVIC::unpend(line);
        self.rx.listen();
        // SAFETY: PRIMASK is set above, so unmasking cannot run a handler; the line only
        // wakes `wfi`.
        unsafe { NVIC::unmask(line) };
        self.rx_wakeup = Some(line);
    }

    /// Received bytes dropped for a receive error (overrun, framing, noise, parity).
    pub fn rx_errors(&self) -> u32 {
        self.rx_errors
    }
}

impl<U: Instance> ErrorType for Link<U> {
    type Error = Infallible;
}

impl<U: Instance> ByteReceiver for Link<U> {
    /// A received byte, if one is waiting.
    fn try_read_byte(&mut self) -> Option<u8> {
        match self.rx.read() {
            Ok(b) => Some(b),
            Err(nb::Error::WouldBlock) => None,
            Err(nb::Error::Other(_)) => {
                self.rx_errors = self.rx_errors.wrapping_add(1);
                None
            }
        }
    }

    /// Wait for the next event: sleep when wake-ups are enabled, spin otherwise.
    fn idle(&mut self) {
        match self.rx_wakeup {
            Some(line) => {
                // Clear the previous wake-up, then sleep only if nothing arrived meanwhile (a
                // byte arriving after this check pends the interrupt, and `wfi` returns at once).
                NVIC::unpend(line);
                if !self.rx.is_rx_not_empty() {
                    cortex_m::asm::wfi();
                }
            }
            None => core::hint::spin_loop(),
        }
    }
}

impl<U: Instance> Read for Link<U> {
    /// Block until at least one byte arrived, then return what is there without blocking.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        Ok(read_available(self, buf))
    }
}

impl<U: Instance> ReadReady for Link<U> {
    fn read_ready(&mut self) -> Result<bool, Infallible> {
        Ok(self.rx.is_rx_not_empty())
    }
}

impl<U: Instance> Write for Link<U> {
    /// Block until the first byte is queued, then queue what fits without blocking.
    fn write(&mut self, buf: &[u8]) -> Result<usize, Infallible> {
        let mut n = 0;
        for &b in buf {
            loop {
                match self.tx.write(b) {
                    Ok(()) => break,
                    Err(_) if n > 0 => return Ok(n),
                    Err(_) => core::hint::spin_loop(),
                }
            }
            n += 1;
        }
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        while self.tx.flush().is_err() {
            core::hint::spin_loop();
        }
        Ok(())
    }
}

impl<U: Instance> WriteReady for Link<U> {
    fn write_ready(&mut self) -> Result<bool, Infallible> {
        Ok(stm32f4xx_hal::serial::TxISR::is_tx_empty(&self.tx))
    }
}
