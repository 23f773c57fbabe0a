//! The MPS2 board's part of the product ([`fbg_firmware_device::Board`]): bring-up of the
//! CMSDK UART (receive wake-up on) and the FPGA IO LED, SysTick as the boot clock, the fatal
//! path. Each product image of this board (`fbg-firmware`, the QEMU test images `rollback`
//! and `torture`) is a `Board` of its own that adds its policy, its store flash and the static
//! its device lives in.

use crate::counters::{systick_elapsed, systick_now, systick_start, ticks_to_us};
use crate::led::FpgaioLed;
use crate::uart::{CmsdkUart, Uart0Rx, MPS2_PCLK_HZ, UART0_BASE};

pub use fbg_firmware_device::{run_product, Board, BoardDevice};

/// Link speed on hardware (QEMU ignores it).
const BAUD: u32 = 115_200;

/// The name the product images log.
pub const NAME: &str = "fbg-firmware";

/// Start SysTick free-running on the core clock (the boot clock).
pub fn start_clock() {
    let Some(mut cp) = cortex_m::Peripherals::take() else { crate::exit_failure() };
    systick_start(&mut cp.SYST);
    // The start of boot, for `elapsed_us`.
    BOOT_START.store(systick_now(), core::sync::atomic::Ordering::Relaxed);
}

static BOOT_START: core::sync::atomic::AtomicU32 = core::sync::atomic::AtomicU32::new(0);

/// Microseconds since [`start_clock`] (SysTick: under QEMU's `-icount` emulated time).
pub fn elapsed_us() -> Option<u32> {
    let start = BOOT_START.load(core::sync::atomic::Ordering::Relaxed);
    Some(ticks_to_us(systick_elapsed(start, systick_now())))
}

/// UART0 (receive wake-up on) and LED0 of the MPS2 board, once.
pub fn link_and_alarm() -> (CmsdkUart, FpgaioLed) {
    // SAFETY: UART0 and LED0 of the MPS2 board, each driven only by the product, which calls
    // this once (`Board::bring_up`).
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, BAUD);
    // Sleep between received bytes instead of spinning.
    uart.enable_rx_wakeup(Uart0Rx);
    // SAFETY: as above.
    let alarm = unsafe { FpgaioLed::new(0) };
    (uart, alarm)
}
