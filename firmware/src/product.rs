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

/// A product image of this board: `struct $name`, a [`Board`] with the trust policy `$policy`
/// and its model store on `$flash` (`$open` opens it, called once from `Board::bring_up`).
/// The images differ only there (the product, the rollback image, the power-cut image); each
/// adds its `#[entry]` calling `run_product::<$name>()`.
#[macro_export]
macro_rules! mps2_board {
    ($name:ident, policy: $policy:expr, flash: $flash:ty = $open:expr) => {
        /// The product on the MPS2 board (`fbg_firmware::mps2_board!`).
        struct $name;

        impl $crate::product::Board for $name {
            type Link = $crate::uart::CmsdkUart;
            type Alarm = $crate::led::FpgaioLed;
            type Flash = $flash;
            const NAME: &'static str = $crate::product::NAME;
            const POLICY: fbg_firmware_app::Policy = $policy;
            const REQUIRE_SIGNED_DEFAULT: bool = $crate::trust::REQUIRE_SIGNED_DEFAULT;
            const TEST_KEY_ONLY: bool = $crate::trust::TEST_KEY_ONLY;

            fn start_clock() {
                $crate::product::start_clock()
            }
            fn elapsed_us() -> Option<u32> {
                $crate::product::elapsed_us()
            }
            fn bring_up() -> ($crate::uart::CmsdkUart, $crate::led::FpgaioLed, $flash) {
                let (link, alarm) = $crate::product::link_and_alarm();
                (link, alarm, $open)
            }
            fn device_slot() -> &'static mut core::mem::MaybeUninit<$crate::product::BoardDevice<Self>> {
                static mut SLOT: core::mem::MaybeUninit<$crate::product::BoardDevice<$name>> =
                    core::mem::MaybeUninit::uninit();
                // SAFETY: called once (`run_product`).
                unsafe { &mut *core::ptr::addr_of_mut!(SLOT) }
            }
            fn fatal() -> ! {
                $crate::exit_failure()
            }
        }
    };
}
