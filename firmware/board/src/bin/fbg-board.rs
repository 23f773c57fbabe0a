//! The product firmware on the STM32F405: boot the model store's newest verified model (else
//! the embedded default), then serve the
//! serial link (samples, status, model updates) and drive the alarm output, forever. The same
//! entry as the QEMU firmware's product (`firmware/src/product.rs`), on this board's USART,
//! LED and flash store.

#![no_std]
#![no_main]

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use fbg_firmware_app::{unloaded, Device, ModelInfo, Store};
use fbg_firmware_board::board::{Alarm, Board, LINK_IRQ};
use fbg_firmware_board::store_flash::StoreFlash;
use fbg_firmware_board::{fatal, stack, trust, DEFAULT_MODEL, K, KERNEL, POLICY, STAGING_LEN};
use fbg_shared::protocol::{FrameReader, HOST_MAX_FRAME};
use fbg_shared::Compensator;

#[entry]
fn main() -> ! {
    // `static mut` at the top of `#[entry]` become `&'static mut` (cortex-m-rt), initialised at
    // load time: the active model and the frame reader live in .bss (what must persist across
    // messages); an update is staged in the flash store, not in RAM; the parameter slot a model
    // is parsed into is on the stack of the load only (`load_blob`).
    static mut MODEL: Compensator<f32, K> = unloaded();
    static mut READER: FrameReader<HOST_MAX_FRAME> = FrameReader::new();
    static mut DEVICE: MaybeUninit<Device<'static, Alarm, StoreFlash, K>> = MaybeUninit::uninit();

    let Board { mut link, alarm, store } = match Board::take() {
        Ok(b) => b,
        Err(e) => {
            defmt::error!("board bring-up failed: {}", e);
            fatal()
        }
    };
    // Sleep between received bytes instead of spinning.
    link.enable_rx_wakeup(LINK_IRQ);

    if trust::TEST_KEY_ONLY {
        defmt::warn!("this image trusts only the QEMU TEST key (firmware/keys/): not for production");
    }
    // The model store (sectors 5-8): the newest verified slot at or above the rollback floor
    // boots, else the embedded default. Either goes the way of every update: parsed into a
    // parameter slot on the stack of `load_blob`, then folded into the (unloaded) active
    // compensator in place. The embedded default is trusted as part of the image unless the
    // build requires it to be signed.
    // The device, the store in it, is built once in place in a static (`install`), so that
    // neither it nor a temporary copy sits on main's stack frame while a model loads; then it
    // boots.
    let dev = install(DEVICE, MODEL, READER, store, alarm);
    let info = match dev.boot(trust::REQUIRE_SIGNED_DEFAULT, DEFAULT_MODEL) {
        Ok(info) => info,
        Err(r) => {
            defmt::error!(
                "no model to boot: the embedded default was rejected: {} (code {=u8}, detail {=u32})",
                r.reason,
                r.reason.code(),
                r.detail
            );
            fatal()
        }
    };
    // Boot (decoding and folding the model) is the deepest the stack goes before serving;
    // record it, then paint again so that the status reports the serving path on its own.
    let boot_peak = stack::peak_bytes();
    stack::repaint();
    defmt::info!(
        "fbg-board up: K = {=usize}, model {=u16} centres, crc {=u32:#010x}, stack peak during boot {=u32} B",
        K,
        info.centres,
        info.crc,
        boot_peak
    );
    dev.set_stack_probe(stack::peak_bytes, boot_peak);
    match dev.serve(&mut link) {
        Ok(never) => match never {},
        Err(never) => match never {},
    }
}

/// Open the model store on `flash` and build the device around it in `slot`, in this frame
/// (gone once it returns), not main's.
#[inline(never)]
fn install(
    slot: &'static mut MaybeUninit<Device<'static, Alarm, StoreFlash, K>>,
    comp: &'static mut Compensator<f32, K>,
    reader: &'static mut FrameReader<HOST_MAX_FRAME>,
    flash: StoreFlash,
    alarm: Alarm,
) -> &'static mut Device<'static, Alarm, StoreFlash, K> {
    let Ok(store) = Store::open(flash, STAGING_LEN) else {
        defmt::error!("the model store's flash is smaller than four erase units");
        fatal()
    };
    slot.write(Device::new(comp, KERNEL, POLICY, reader, ModelInfo::default(), store, alarm))
}
