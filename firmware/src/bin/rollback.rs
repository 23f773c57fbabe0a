//! A QEMU test image: the product firmware built with rollbacks accepted (what
//! `FBG_ALLOW_ROLLBACK=1` makes of the product image), so that `cargo xtask qemu` tests the
//! bounded rollback beside the default image, which refuses every rollback, without a second
//! build of the whole firmware.

#![no_std]
#![no_main]

use fbg_firmware::store_flash::StoreFlash;

/// The build's policy, rollbacks accepted.
const POLICY: fbg_firmware_app::Policy = fbg_firmware_app::Policy { allow_rollback: true, ..fbg_firmware::POLICY };

/// The store's flash, as the product's.
/// The store's flash of this image.
type Flash = StoreFlash;

fn store_flash() -> Flash {
    // SAFETY: called once, from `main`: the only driver of the region.
    unsafe { StoreFlash::open() }
}

include!("../product.rs");
