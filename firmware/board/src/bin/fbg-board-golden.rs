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
use fbg_firmware_app::unloaded;
use fbg_firmware_board::board::Board;
use fbg_firmware_board::store_flash::{StoreError, ERASE_SIZE, UNITS};
use fbg_firmware_board::{exit_failure, exit_success, stack, K};
use fbg_firmware_device::golden::{check_store_flash, compensate_pack, Refusals};
use fbg_shared::Compensator;

/// The golden pack, in the flash beyond the store (`.spare`, sectors 9–11 in `memory.x`): it is
/// larger than the image's sectors 0–4.
#[link_section = ".spare"]
static PACK: [u8; include_bytes!(concat!(env!("OUT_DIR"), "/golden_pack.bin")).len()] =
    *include_bytes!(concat!(env!("OUT_DIR"), "/golden_pack.bin"));

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
    let refusals = Refusals {
        not_erased: StoreError::NotErased,
        not_aligned: StoreError::NotAligned,
        out_of_bounds: StoreError::OutOfBounds,
    };
    check_store_flash(&mut store, UNITS, ERASE_SIZE, refusals, exit_failure);
    let n = compensate_pack(&PACK, MODEL, &mut link, exit_failure);
    defmt::info!("golden: {=u32} samples compensated, stack peak {=u32} B", n, stack::peak_bytes());
    exit_success()
}
