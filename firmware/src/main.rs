//! The product firmware on the MPS2 board: boot the newest model of the persistent store (or
//! the embedded default), then serve the serial link (samples, status, model updates) and
//! drive the alarm output, forever (`fbg_firmware_device::run_product`).

#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use fbg_firmware::led::FpgaioLed;
use fbg_firmware::product::{self, run_product, Board, BoardDevice};
use fbg_firmware::store_flash::StoreFlash;
use fbg_firmware::uart::CmsdkUart;
use fbg_firmware::{exit_failure, trust, POLICY};

/// The product on the MPS2 board, its store's flash the `STORE` region, kept across QEMU runs
/// in its host file.
struct Mps2;

impl Board for Mps2 {
    type Link = CmsdkUart;
    type Alarm = FpgaioLed;
    type Flash = StoreFlash;
    const NAME: &'static str = product::NAME;
    const POLICY: fbg_firmware_app::Policy = POLICY;
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
        static mut SLOT: MaybeUninit<BoardDevice<Mps2>> = MaybeUninit::uninit();
        // SAFETY: called once (`run_product`).
        unsafe { &mut *core::ptr::addr_of_mut!(SLOT) }
    }
    fn fatal() -> ! {
        exit_failure()
    }
}

#[entry]
fn main() -> ! {
    run_product::<Mps2>()
}
