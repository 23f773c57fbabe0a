// The product firmware's entry, shared by the product image (`main.rs`, the build's policy),
// the QEMU test image `rollback` (the same with rollbacks accepted) and the QEMU test image
// `torture` (the same whose flash loses power at a chosen operation); the including file
// defines `POLICY`, the store's flash type `Flash` and `store_flash()`, which makes it (called
// once).

use core::mem::MaybeUninit;

use cortex_m_rt::entry;
use fbg_firmware::counters::{systick_elapsed, systick_now, systick_start, ticks_to_us};
use fbg_firmware::led::FpgaioLed;
use fbg_firmware::uart::{CmsdkUart, Uart0Rx, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, stack, trust, DEFAULT_MODEL, K, KERNEL, STAGING_LEN};
use fbg_firmware_app::store::Store;
use fbg_firmware_app::{unloaded, Device, ModelInfo};
use fbg_shared::protocol::{FrameReader, HOST_MAX_FRAME};
use fbg_shared::Compensator;

/// Link speed on hardware (QEMU ignores it).
const BAUD: u32 = 115_200;

#[entry]
fn main() -> ! {
    // `static mut` at the top of `#[entry]` become `&'static mut` (cortex-m-rt), initialised at
    // load time: the active model and the frame reader live in .bss (what must persist across
    // messages); an update is staged in the flash slot, not in RAM; the parameter slot a model
    // is parsed into is on the stack of the load only (`load_blob`).
    static mut MODEL: Compensator<f32, K> = unloaded();
    static mut READER: FrameReader<HOST_MAX_FRAME> = FrameReader::new();
    static mut DEVICE: MaybeUninit<Device<'static, FpgaioLed, Flash, K>> = MaybeUninit::uninit();

    // Boot time is measured from here to the first frame served (SysTick on the core clock:
    // under QEMU's `-icount` emulated time, on a part real time).
    let Some(mut cp) = cortex_m::Peripherals::take() else { exit_failure() };
    systick_start(&mut cp.SYST);
    let boot_start = systick_now();

    // SAFETY: UART0 and LED0 of the MPS2 board, each driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, BAUD);
    // Sleep between received bytes instead of spinning.
    uart.enable_rx_wakeup(Uart0Rx);
    let alarm = unsafe { FpgaioLed::new(0) };
    if trust::TEST_KEY_ONLY {
        defmt::warn!("this image trusts only the QEMU TEST key (firmware/keys/): not for production");
    }
    // The device, the store in it, is built once in place in a static (`install`), so that
    // neither it nor a temporary copy sits on main's stack frame while a model loads. Then it
    // boots the newest complete, verified slot at or above the rollback floor, else the
    // embedded default; either goes the way of every update: parsed into a parameter slot on
    // the stack of `load_blob`, then folded into the (unloaded) active compensator in place.
    // The embedded default is trusted as part of the image unless the build requires it to be
    // signed.
    let dev = install(DEVICE, MODEL, READER, alarm);
    let info = match dev.boot(trust::REQUIRE_SIGNED_DEFAULT, DEFAULT_MODEL) {
        Ok(info) => info,
        Err(r) => {
            defmt::error!(
                "no model to boot: the embedded default was rejected: {} (code {=u8}, detail {=u32})",
                r.reason,
                r.reason.code(),
                r.detail
            );
            exit_failure()
        }
    };
    // Boot (decoding and folding the model) is the deepest the stack goes before serving;
    // record it, then paint again so that the status reports the serving path on its own.
    let boot_peak = stack::peak_bytes();
    stack::repaint();
    let st = dev.store().status();
    defmt::info!(
        "fbg-firmware up: K = {=usize}, model {=u16} centres, crc {=u32:#010x}, serial {=u64} from {}, rollback floor {=u64}, stack peak during boot {=u32} B",
        K,
        info.centres,
        info.crc,
        info.serial,
        st.boot_source,
        st.rollback_floor,
        boot_peak
    );
    dev.set_stack_probe(stack::peak_bytes, boot_peak);
    // Serving starts now: the boot time is what the status reports.
    dev.set_boot_time_us(ticks_to_us(systick_elapsed(boot_start, systick_now())));
    match dev.serve(&mut uart) {
        Ok(never) => match never {},
        Err(never) => match never {},
    }
}

/// Open the model store on its flash (it only reads here: which slots hold a complete model,
/// the log's totals and the rollback floor) and build the device around it in `slot`, in this
/// frame (gone once it returns), not main's.
#[inline(never)]
fn install(
    slot: &'static mut MaybeUninit<Device<'static, FpgaioLed, Flash, K>>,
    comp: &'static mut Compensator<f32, K>,
    reader: &'static mut FrameReader<HOST_MAX_FRAME>,
    alarm: FpgaioLed,
) -> &'static mut Device<'static, FpgaioLed, Flash, K> {
    let Ok(store) = Store::open(store_flash(), STAGING_LEN) else {
        defmt::error!("the model store's flash is smaller than its four sectors");
        exit_failure()
    };
    slot.write(Device::new(comp, KERNEL, POLICY, reader, ModelInfo::default(), store, alarm))
}
