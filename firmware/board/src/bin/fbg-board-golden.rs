//! Golden-vector test image of the board: for every record of the pack embedded at build time
//! (`FBG_GOLDEN_PACK`, as the QEMU firmware's `golden` image), loads the model the way the
//! product does and compensates the samples, sending every estimate as a protocol `Estimate`
//! frame on the link's USART, numbered across the records; the host compares them with its f64
//! answers (`cargo xtask board`, on QEMU's `netduinoplus2` with the `emulator` build). Exits
//! through semihosting: success after the last sample, failure if a model is refused or the
//! pack is malformed.
//!
//! First it checks the model store's flash driver on the target
//! (`fbg_firmware_board::store_flash`): four equal erase units large enough for the longest
//! update, an erase sets `0xFF`, a write lands and reads back, a second write over written
//! bytes and unaligned or out-of-bounds operations are refused. On the part this erases the
//! store's first sector.

#![no_std]
#![no_main]

use cortex_m_rt::entry;
use embedded_io::Write;
use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
use fbg_firmware_app::{load_blob, unloaded, MappedFlash};
use fbg_firmware_board::board::Board;
use fbg_firmware_board::store_flash::{StoreError, StoreFlash, ERASE_SIZE, UNITS};
use fbg_firmware_board::{exit_failure, exit_success, stack, step, K, KERNEL, STAGING_LEN};
use fbg_shared::protocol::{encode_device, DeviceEstimate, DeviceMsg, DEVICE_MAX_FRAME};
use fbg_shared::Compensator;

/// The golden pack, in the flash beyond the store (`.spare`, sectors 9–11 in `memory.x`): it is
/// larger than the image's sectors 0–4.
#[link_section = ".spare"]
static PACK: [u8; include_bytes!(concat!(env!("OUT_DIR"), "/golden_pack.bin")).len()] =
    *include_bytes!(concat!(env!("OUT_DIR"), "/golden_pack.bin"));

/// The store's NOR semantics on the target; exits with failure on any surprise.
fn check_store(store: &mut StoreFlash) {
    let e = ERASE_SIZE as u32;
    let word = [0x12, 0x34, 0x56, 0x78];
    let mut back = [0u8; 4];
    let checks = [
        store.capacity() == UNITS * ERASE_SIZE && ERASE_SIZE >= STAGING_LEN,
        store.erase(0, e).is_ok(),
        store.contents().get(..ERASE_SIZE).is_some_and(|b| b.iter().all(|&x| x == 0xFF)),
        store.write(8, &word).is_ok(),
        store.read(8, &mut back).is_ok() && back == word,
        store.contents().get(8..12) == Some(&word[..]),
        store.write(8, &word) == Err(StoreError::NotErased),
        store.write(2, &word) == Err(StoreError::NotAligned),
        store.write(8, &word[..3]) == Err(StoreError::NotAligned),
        store.erase(0, e / 2) == Err(StoreError::NotAligned),
        store.erase(0, store.capacity() as u32 + e) == Err(StoreError::OutOfBounds),
        store.erase(0, e).is_ok() && store.write(8, &word).is_ok(),
        store.erase(0, e).is_ok(),
    ];
    if let Some(i) = checks.iter().position(|ok| !ok) {
        defmt::error!("store flash: check {=usize} failed", i);
        exit_failure()
    }
    defmt::info!("golden: the store flash ({=usize} units of {=usize} B) behaves as NOR flash", UNITS, ERASE_SIZE);
}

#[entry]
fn main() -> ! {
    static mut MODEL: Compensator<f32, K> = unloaded();

    let Board { mut link, mut store, .. } = match Board::take() {
        Ok(b) => b,
        Err(e) => {
            defmt::error!("board bring-up failed: {}", e);
            exit_failure()
        }
    };
    check_store(&mut store);
    if PACK.is_empty() {
        defmt::error!("golden pack missing (FBG_GOLDEN_PACK)");
        exit_failure()
    }
    let mut n = 0u32;
    for (i, rec) in fbg_shared::golden::records(&PACK).enumerate() {
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
                    let _ = link.write_all(frame);
                }
                Err(_) => exit_failure(),
            }
            n += 1;
        }
        defmt::info!("golden: model {=usize}: {=usize} samples compensated", i, rec.len());
    }
    let _ = link.flush();
    defmt::info!("golden: {=u32} samples compensated, stack peak {=u32} B", n, stack::peak_bytes());
    exit_success()
}
