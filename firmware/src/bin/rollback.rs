//! A QEMU test image: the product firmware built with rollbacks accepted (what
//! `FBG_ALLOW_ROLLBACK=1` makes of the product image), so that `cargo xtask qemu` tests the
//! bounded rollback beside the default image, which refuses every rollback, without a second
//! build of the whole firmware.

#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use fbg_firmware::led::FpgaioLed;
use fbg_firmware::product::{self, run_product, Board, BoardDevice};
use fbg_firmware::store_flash::StoreFlash;
use fbg_firmware::uart::CmsdkUart;
use fbg_firmware::{exit_failure, trust};

/// The product on the MPS2 board with rollbacks accepted.
struct Rollback;

impl Board for Rollback {
    type Link = CmsdkUart;
    type Alarm = FpgaioLed;
    type Flash = StoreFlash;
    const NAME: &'static str = product::NAME;
    const POLICY: fbg_firmware_app::Policy = fbg_firmware_app::Policy { allow_rollback: true, ..fbg_firmware::POLICY };
    const REQUIRE_SIGNED_DEFAULT: bool = trust::REQUIRE_SIGNED_DEFAULT;
    const TEST_KEY_ONLY: bool = trust::TEST_KEY_ONLY;

    fn start_clock() {
        product::start_clock()
    }
    fn elapsed_us() -> Option<u32> {
        product::elapsed_us()
    }
    fn bring_up() -> (CmsdkUart, FpgaioLed, StoreFlash) {
        let (link, alarm) = product::link_and_alarm();
        // SAFETY: called once (`run_product`): the only driver of the region.
        (link, alarm, unsafe { StoreFlash::open() })
    }
    fn device_slot() -> &'static mut MaybeUninit<BoardDevice<Self>> {
        static mut SLOT: MaybeUninit<BoardDevice<Rollback>> = MaybeUninit::uninit();
        // SAFETY: called once (`run_product`).
        unsafe { &mut *core::ptr::addr_of_mut!(SLOT) }
    }
    fn fatal() -> ! {
        exit_failure()
    }
}

#[entry]
fn main() -> ! {
    run_product::<Rollback>()
}
