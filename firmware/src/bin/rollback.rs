//! A QEMU test image: the product firmware built with rollbacks accepted (what
//! `FBG_ALLOW_ROLLBACK=1` makes of the product image), so that `cargo xtask qemu` tests the
//! bounded rollback beside the default image, which refuses every rollback, without a second
//! build of the whole firmware.

#![no_std]
#![no_main]

use cortex_m_rt::entry;
use fbg_firmware::product::run_product;
use fbg_firmware::store_flash::StoreFlash;

fbg_firmware::mps2_board!(
    Rollback,
    policy: fbg_firmware_app::Policy { allow_rollback: true, ..fbg_firmware::POLICY },
    // SAFETY: opened once (`Board::bring_up`): the only driver of the region.
    flash: StoreFlash = unsafe { StoreFlash::open() }
);

#[entry]
fn main() -> ! {
    run_product::<Rollback>()
}
