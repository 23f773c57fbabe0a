//! The product firmware: boot the newest model of the persistent store (or the embedded
//! default), then serve the serial link (samples, status, model updates) and drive the alarm
//! output, forever.

#![no_std]
#![no_main]

use fbg_firmware::store_flash::StoreFlash;
use fbg_firmware::POLICY;

/// The store's flash: the `STORE` region, kept across QEMU runs in its host file.
/// The store's flash of this image.
type Flash = StoreFlash;

fn store_flash() -> Flash {
    // SAFETY: called once, from `main`: the only driver of the region.
    unsafe { StoreFlash::open() }
}

include!("product.rs");
