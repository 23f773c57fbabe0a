//! The product firmware on the STM32F405: boot the model store's newest verified model (else
//! the embedded default), then serve the serial link (samples, status, model updates) and
//! drive the alarm output, forever (`fbg_firmware_device::run_product`, as every board's
//! product), on this board's USART, LED and flash store.

#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use fbg_firmware_board::board::{Alarm, Board, LINK_IRQ};
use fbg_firmware_board::serial::Link;
use fbg_firmware_board::store_flash::StoreFlash;
use fbg_firmware_board::{fatal, trust, POLICY};
use fbg_firmware_device::{run_product, BoardDevice};
use stm32f4xx_hal::pac::USART1;

/// The product on the STM32F405.
struct Stm32f405;

impl fbg_firmware_device::Board for Stm32f405 {
    type Link = Link<USART1>;
    type Alarm = Alarm;
    type Flash = StoreFlash;
    const NAME: &'static str = "fbg-board";
    const POLICY: fbg_firmware_app::Policy = POLICY;
    const REQUIRE_SIGNED_DEFAULT: bool = trust::REQUIRE_SIGNED_DEFAULT;
    const TEST_KEY_ONLY: bool = trust::TEST_KEY_ONLY;

    fn bring_up() -> (Link<USART1>, Alarm, StoreFlash) {
        let Board { mut link, alarm, store } = match Board::take() {
            Ok(b) => b,
            Err(e) => {
                defmt::error!("board bring-up failed: {}", e);
                fatal()
            }
        };
        // Sleep between received bytes instead of spinning.
        link.enable_rx_wakeup(LINK_IRQ);
        (link, alarm, store)
    }
    fn device_slot() -> &'static mut MaybeUninit<BoardDevice<Self>> {
        static mut SLOT: MaybeUninit<BoardDevice<Stm32f405>> = MaybeUninit::uninit();
        // SAFETY: called once (`run_product`).
        unsafe { &mut *core::ptr::addr_of_mut!(SLOT) }
    }
    fn fatal() -> ! {
        fatal()
    }
}

#[entry]
fn main() -> ! {
    run_product::<Stm32f405>()
}
