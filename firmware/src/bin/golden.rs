//! Golden-vector test image: for every record of the pack embedded at build time
//! (`FBG_GOLDEN_PACK`, read with `fbg_shared::golden::records`: a model blob and its samples), loads the model the way
//! the product does (a fresh stream state each time) and compensates the samples, sending
//! every estimate as a protocol `Estimate` frame on UART0, numbered across the records; the
//! host compares them with its f64 answers. Exits through semihosting (success after the last
//! sample, failure if a model is refused or the pack is malformed).
//!
//! First it runs the RFC 8032 Ed25519 test vectors (section 7.1, TEST 1, 2, 3 and SHA(abc)) through
//! the signature verifier as this target builds it (`salty` with its Cortex-M4 assembly, which the
//! host build of the same code does not use): each must verify, and must fail with one bit of its
//! signature flipped; anything else ends the run with failure. Then it checks the model store's
//! flash driver on the target (`fbg_firmware::store_flash`, without its host file): four sectors
//! each large enough for the longest update, an erase sets `0xFF`, a write lands and reads back, a
//! second write over written bytes and unaligned or out-of-bounds operations are refused.

#![no_std]
#![no_main]

use cortex_m_rt::entry;
use fbg_firmware::rfc8032::VECTORS;
use fbg_firmware::store_flash::{FlashError, StoreFlash, ERASE_SIZE};
use fbg_firmware::uart::{CmsdkUart, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, exit_success, stack, K};
use fbg_firmware_app::unloaded;
use fbg_firmware_device::golden::{check_store_flash, compensate_pack, Refusals};
use fbg_shared::Compensator;

static PACK: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/golden_pack.bin"));

/// The RFC 8032 vectors through the device's verifier; exits with failure on a mismatch.
fn check_rfc8032() {
    use fbg_shared::signature::verify_message;
    for (i, (pk, msg, sig)) in VECTORS.iter().enumerate() {
        let good = verify_message(msg, sig, pk).is_ok();
        let mut bad = *sig;
        if let Some(b) = bad.get_mut(i * 7 + 3) {
            *b ^= 0x20;
        }
        let refused = verify_message(msg, &bad, pk).is_err();
        if !(good && refused) {
            defmt::error!(
                "RFC 8032 TEST {=usize}: verifies {=bool}, flipped bit refused {=bool}",
                i + 1,
                good,
                refused
            );
            exit_failure()
        }
    }
    defmt::info!("golden: RFC 8032 TEST 1-3 and SHA(abc) pass through the device's Ed25519 verifier");
}

#[entry]
fn main() -> ! {
    static mut MODEL: Compensator<f32, K> = unloaded();

    // SAFETY: UART0 of the MPS2 board, driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, 115_200);
    check_rfc8032();
    // SAFETY: the only driver of the region in this image. Volatile: the golden run must not
    // create or change a device's flash file.
    let mut flash = unsafe { StoreFlash::volatile() };
    let refusals = Refusals {
        not_erased: FlashError::NotErased,
        not_aligned: FlashError::NotAligned,
        out_of_bounds: FlashError::OutOfBounds,
    };
    check_store_flash(&mut flash, 4, ERASE_SIZE, refusals, exit_failure);
    let n = compensate_pack(PACK, MODEL, &mut uart, exit_failure);
    defmt::info!("golden: {=u32} samples compensated, stack peak {=u32} B", n, stack::peak_bytes());
    exit_success()
}
