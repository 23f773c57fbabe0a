//! The product firmware on the MPS2 board: boot the newest model of the persistent store (or
//! the embedded default), then serve the serial link (samples, status, model updates) and
//! drive the alarm output, forever (`fbg_firmware_device::run_product`).

#![no_std]
#![no_main]

use cortex_m_rt::entry;
use fbg_firmware::product::run_product;
use fbg_firmware::store_flash::StoreFlash;

// The store's flash is the `STORE` region, kept across QEMU runs in its host file.
fbg_firmware::mps2_board!(
    Mps2,
    policy: fbg_firmware::POLICY,
    // SAFETY: opened once (`Board::bring_up`): the only driver of the region.
    flash: StoreFlash = unsafe { StoreFlash::open() }
);

#[entry]
fn main() -> ! {
    run_product::<Mps2>()
}
