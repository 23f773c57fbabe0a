//! Golden-vector test image: for every record of the pack embedded at build time
//! (`FBG_GOLDEN_PACK`, read with `fbg_shared::golden::records`: a model blob and its samples), loads the model the way
//! the product does (a fresh stream state each time) and compensates the samples, sending
//! every estimate as a protocol `Estimate` frame on UART0, numbered across the records; the
//! host compares them with its f64 answers. Exits through semihosting (success after the last
//! sample, failure if a model is refused or the pack is malformed).
//!
//! First it runs the RFC 8032 Ed25519 test vectors (section 7.1, TEST 1–3) through the
//! signature verifier as this target builds it (`salty` with its Cortex-M4 assembly, which the
//! host build of the same code does not use): each must verify, and must fail with one bit of
//! its signature flipped; anything else ends the run with failure. Then it checks the model
//! store's flash driver on the target (`fbg_firmware::store_flash`, without its host file):
//! four sectors each large enough for the longest update, an erase sets `0xFF`, a write lands
//! and reads back, a second write over written bytes and unaligned or out-of-bounds operations
//! are refused.

#![no_std]
#![no_main]

use cortex_m_rt::entry;
use embedded_io::Write;
use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
use fbg_firmware::store_flash::{FlashError, StoreFlash, ERASE_SIZE};
use fbg_firmware::uart::{CmsdkUart, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, exit_success, stack, step, K, KERNEL, STAGING_LEN};
use fbg_firmware_app::{load_blob, unloaded, MappedFlash};
use fbg_shared::protocol::{encode_device, DeviceEstimate, DeviceMsg, DEVICE_MAX_FRAME};
use fbg_shared::Compensator;

static PACK: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/golden_pack.bin"));

/// RFC 8032, section 7.1, TEST 1–3: (public key, message, signature).
static RFC8032: [([u8; 32], &[u8], [u8; 64]); 3] = [
    (
        hex32("d75a980182b10ab7d54bfed3c964073a0ee172f3daa62325af021a68f707511a"),
        &[],
        hex64(concat!(
            "e5564300c360ac729086e2cc806e828a84877f1eb8e5d974d873e06522490155",
            "5fb8821590a33bacc61e39701cf9b46bd25bf5f0595bbe24655141438e7a100b"
        )),
    ),
    (
        hex32("3d4017c3e843895a92b70aa74d1b7ebc9c982ccf2ec4968cc0cd55f12af4660c"),
        &[0x72],
        hex64(concat!(
            "92a009a9f0d4cab8720e820b5f642540a2b27b5416503f8fb3762223ebdb69da",
            "085ac1e43e15996e458f3613d0f11d8c387b2eaeb4302aeeb00d291612bb0c00"
        )),
    ),
    (
        hex32("fc51cd8e6218a1a38da47ed00230f0580816ed13ba3303ac5deb911548908025"),
        &[0xaf, 0x82],
        hex64(concat!(
            "6291d657deec24024827e69c3abe01a30ce548a284743a445e3680d7db5ac3ac",
            "18ff9b538d16f290ae67f760984dc6594a7c15e9716ed28dc027beceea1ec40a"
        )),
    ),
];

// Only evaluated at compile time (the test-vector constants): a bad literal fails the build.
#[allow(clippy::panic)]
const fn nibble(c: u8) -> u8 {
    match c {
        b'0'..=b'9' => c - b'0',
        b'a'..=b'f' => c - b'a' + 10,
        _ => panic!("not a hex digit"),
    }
}

// Only evaluated at compile time, like `nibble`.
#[allow(clippy::indexing_slicing)]
const fn hex<const N: usize>(s: &str) -> [u8; N] {
    let b = s.as_bytes();
    assert!(b.len() == 2 * N, "wrong hex length");
    let mut out = [0u8; N];
    let mut i = 0;
    while i < N {
        out[i] = nibble(b[2 * i]) << 4 | nibble(b[2 * i + 1]);
        i += 1;
    }
    out
}

const fn hex32(s: &str) -> [u8; 32] {
    hex(s)
}

const fn hex64(s: &str) -> [u8; 64] {
    hex(s)
}

/// The RFC 8032 vectors through the device's verifier; exits with failure on a mismatch.
fn check_rfc8032() {
    use fbg_shared::signature::verify_message;
    for (i, (pk, msg, sig)) in RFC8032.iter().enumerate() {
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
    defmt::info!("golden: RFC 8032 TEST 1-3 pass through the device's Ed25519 verifier");
}

/// The store flash's NOR semantics on the target; exits with failure on any surprise.
fn check_store_flash() {
    // SAFETY: the only driver of the region in this image. Volatile: the golden run must not
    // create or change a device's flash file.
    let mut flash = unsafe { StoreFlash::volatile() };
    let e = ERASE_SIZE as u32;
    let word = [0x12, 0x34, 0x56, 0x78];
    let mut back = [0u8; 4];
    let checks = [
        ERASE_SIZE >= STAGING_LEN && flash.capacity() == 4 * ERASE_SIZE,
        flash.erase(0, e).is_ok(),
        flash.contents().get(..ERASE_SIZE).is_some_and(|b| b.iter().all(|&x| x == 0xFF)),
        flash.write(8, &word).is_ok(),
        flash.read(8, &mut back).is_ok() && back == word,
        flash.contents().get(8..12) == Some(&word[..]),
        flash.write(8, &word) == Err(FlashError::NotErased),
        flash.write(2, &word) == Err(FlashError::NotAligned),
        flash.write(8, &word[..3]) == Err(FlashError::NotAligned),
        flash.erase(0, e / 2) == Err(FlashError::NotAligned),
        flash.erase(0, flash.capacity() as u32 + e) == Err(FlashError::OutOfBounds),
        flash.erase(0, e).is_ok() && flash.write(8, &word).is_ok(),
        flash.erase(0, e).is_ok(),
    ];
    if let Some(i) = checks.iter().position(|ok| !ok) {
        defmt::error!("store flash: check {=usize} failed", i);
        exit_failure()
    }
    defmt::info!("golden: the store flash ({=usize} B) behaves as NOR flash", flash.capacity());
}

#[entry]
fn main() -> ! {
    static mut MODEL: Compensator<f32, K> = unloaded();

    // SAFETY: UART0 of the MPS2 board, driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, 115_200);
    check_rfc8032();
    check_store_flash();
    if PACK.is_empty() {
        defmt::error!("golden pack missing (FBG_GOLDEN_PACK)");
        exit_failure()
    }
    let mut n = 0u32;
    for (i, rec) in fbg_shared::golden::records(PACK).enumerate() {
        let Some(rec) = rec else {
            defmt::error!("golden pack malformed at record {=usize}", i);
            exit_failure()
        };
        if let Err(r) = load_blob(&KERNEL, MODEL, rec.blob) {
            defmt::error!("golden model {=usize} rejected: {} (detail {=u32})", i, r.reason, r.detail);
            exit_failure()
        }
        for s in rec.iter() {
            let e = step(MODEL, &s);
            let msg = DeviceMsg::Estimate(DeviceEstimate::new(n, &e));
            let mut buf = [0u8; DEVICE_MAX_FRAME];
            match encode_device(&msg, &mut buf) {
                Ok(frame) => {
                    let _ = uart.write_all(frame);
                }
                Err(_) => exit_failure(),
            }
            n += 1;
        }
        defmt::info!("golden: model {=usize}: {=usize} samples compensated", i, rec.len());
    }
    let _ = uart.flush();
    defmt::info!("golden: {=u32} samples compensated, stack peak {=u32} B", n, stack::peak_bytes());
    exit_success()
}
