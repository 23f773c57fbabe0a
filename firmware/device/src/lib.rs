//! The product firmware over a [`Board`]: [`run_product`] boots the newest model of the
//! persistent store (or the embedded default), then serves the serial link (samples, status,
//! model updates) and drives the alarm output, forever. Every board's product image is its
//! `#[entry]` calling `run_product::<ItsBoard>()`; a board gives the link, the alarm, the
//! store's flash, its trust policy, the static the device lives in and its fatal path.
//!
//! [`golden`]: the golden-vector run every board's golden image makes. [`link`]: the serial
//! link's blocking read every board's driver shares. [`stack`]: the stack high-water mark by
//! painting, which every board reports. [`trust`] and
//! [`POLICY`]: the signature policy every board's images are built with (the build script).

#![no_std]

pub mod golden;
pub mod link;
pub mod stack;

use core::mem::MaybeUninit;
use core::ptr::addr_of_mut;
use core::sync::atomic::{AtomicBool, Ordering};

use embedded_hal::digital::OutputPin;
use embedded_io::{Read, Write};
use fbg_firmware_app::staging::MappedFlash;
use fbg_firmware_app::store::Store;
use fbg_firmware_app::{unloaded, Device, ModelInfo, Policy};
use fbg_firmware_kernel::{K, KERNEL, STAGING_LEN};
use fbg_shared::protocol::{FrameReader, HOST_MAX_FRAME};
use fbg_shared::Compensator;

/// The signature policy compiled in by `build.rs` (`FBG_TRUSTED_KEYS`, `FBG_ALLOW_ROLLBACK`,
/// `FBG_REQUIRE_SIGNED_DEFAULT`; README-firmware.md, "Signed model updates").
pub mod trust {
    include!(concat!(env!("OUT_DIR"), "/trust.rs"));
}

/// The images' [`Policy`].
pub const POLICY: Policy = Policy { trusted: trust::TRUSTED_KEYS, allow_rollback: trust::ALLOW_ROLLBACK };

/// The model embedded in every product image (replaced by the trainer's export).
pub static DEFAULT_MODEL: &[u8] = include_bytes!("../../model/default.fbgm");

/// The device a board's product runs, on that board's alarm and store flash.
pub type BoardDevice<B> = Device<'static, <B as Board>::Alarm, <B as Board>::Flash, K>;

/// What a board gives the product.
pub trait Board {
    /// The serial link.
    type Link: Read + Write;
    /// The alarm output.
    type Alarm: OutputPin + 'static;
    /// The model store's flash.
    type Flash: MappedFlash + 'static;
    /// The product's name in its log.
    const NAME: &'static str;
    /// The signature policy (trusted keys, rollbacks).
    const POLICY: Policy;
    /// The embedded default model must be signed too.
    const REQUIRE_SIGNED_DEFAULT: bool;
    /// Only the QEMU test key is trusted (a warning at boot).
    const TEST_KEY_ONLY: bool;

    /// Start the clock [`Board::elapsed_us`] reads (first thing at boot; nothing by default).
    fn start_clock() {}
    /// Microseconds since [`Board::start_clock`], when the board keeps a clock.
    fn elapsed_us() -> Option<u32> {
        None
    }
    /// Bring the board up, once: its link (waking the core on a received byte), its alarm
    /// (off) and the model store's flash. A failure is logged and ends in [`Board::fatal`].
    fn bring_up() -> (Self::Link, Self::Alarm, Self::Flash);
    /// The static the device is built in, in place (the board's types are concrete there, so
    /// the board declares it). Called once.
    fn device_slot() -> &'static mut MaybeUninit<BoardDevice<Self>>;
    /// The fatal path, after the reason is logged.
    fn fatal() -> !;
}

/// The product on board `B`, forever (call it once, from the image's entry).
pub fn run_product<B: Board>() -> ! {
    // The active model and the frame reader live in .bss (what must persist across messages);
    // an update is staged in the flash slot, not in RAM; the parameter slot a model is parsed
    // into is on the stack of the load only (`load_blob`).
    static TAKEN: AtomicBool = AtomicBool::new(false);
    static mut MODEL: Compensator<f32, K> = unloaded();
    static mut READER: FrameReader<HOST_MAX_FRAME> = FrameReader::new();
    if TAKEN.swap(true, Ordering::Relaxed) {
        defmt::error!("run_product called twice");
        B::fatal()
    }
    // SAFETY: reached once (`TAKEN`), so these are the only references to the two statics.
    let (model, reader) = unsafe { (&mut *addr_of_mut!(MODEL), &mut *addr_of_mut!(READER)) };

    // Boot time is measured from here to the first frame served (on the boards that keep a
    // clock: SysTick on the core clock, under QEMU's `-icount` emulated time).
    B::start_clock();
    let (mut link, alarm, flash) = B::bring_up();
    if B::TEST_KEY_ONLY {
        defmt::warn!("this image trusts only the QEMU TEST key (firmware/keys/): not for production");
    }
    // The device, the store in it, is built once in place in a static (`install`), so that
    // neither it nor a temporary copy sits on this frame while a model loads. Then it boots the
    // newest complete, verified slot at or above the rollback floor, else the embedded
    // default; either goes the way of every update: parsed into a parameter slot on the stack
    // of `load_blob`, then folded into the (unloaded) active compensator in place. The embedded
    // default is trusted as part of the image unless the build requires it to be signed.
    let dev = install::<B>(model, reader, flash, alarm);
    let info = match dev.boot(B::REQUIRE_SIGNED_DEFAULT, DEFAULT_MODEL) {
        Ok(info) => info,
        Err(r) => {
            defmt::error!(
                "no model to boot: the embedded default was rejected: {} (code {=u8}, detail {=u32})",
                r.reason,
                r.reason.code(),
                r.detail
            );
            B::fatal()
        }
    };
    // Boot (decoding and folding the model) is the deepest the stack goes before serving;
    // record it, then paint again so that the status reports the serving path on its own.
    let boot_peak = stack::peak_bytes();
    stack::repaint();
    defmt::info!(
        "{=str} up: K = {=usize}, model {=u16} centres, crc {=u32:#010x}, serial {=u64}, stack peak during boot {=u32} B",
        B::NAME,
        K,
        info.centres,
        info.crc,
        info.serial,
        boot_peak
    );
    dev.set_stack_probe(stack::peak_bytes, boot_peak);
    // Serving starts now: the boot time is what the status reports.
    if let Some(us) = B::elapsed_us() {
        dev.set_boot_time_us(us);
    }
    match dev.serve(&mut link) {
        Ok(never) => match never {},
        Err(_) => {
            defmt::error!("the serial link failed");
            B::fatal()
        }
    }
}

/// Open the model store on `flash` (it only reads here: which slots hold a complete model, the
/// log's totals and the rollback floor) and build the device around it in the board's slot,
/// in this frame (gone once it returns), not the caller's.
#[inline(never)]
fn install<B: Board>(
    comp: &'static mut Compensator<f32, K>,
    reader: &'static mut FrameReader<HOST_MAX_FRAME>,
    flash: B::Flash,
    alarm: B::Alarm,
) -> &'static mut BoardDevice<B> {
    let Ok(store) = Store::open(flash, STAGING_LEN) else {
        defmt::error!("the model store's flash is smaller than its four erase units");
        B::fatal()
    };
    B::device_slot().write(Device::new(comp, KERNEL, B::POLICY, reader, ModelInfo::default(), store, alarm))
}

/// The panic handler and the fault and default exception handlers of a board's images: each
/// logs what it knows (no `core::fmt`: a panic's location is enough, and keeps the formatting
/// machinery out of flash), then ends in `$fatal` (a `fn() -> !`). The code is written not
/// to panic; reaching a handler is a bug. Invoke once, in the board's library.
#[macro_export]
macro_rules! fault_handlers {
    ($fatal:path) => {
        #[panic_handler]
        fn panic(info: &core::panic::PanicInfo) -> ! {
            match info.location() {
                Some(l) => defmt::error!("panic at {=str}:{=u32}", l.file(), l.line()),
                None => defmt::error!("panic"),
            }
            $fatal()
        }

        #[cortex_m_rt::exception]
        unsafe fn HardFault(ef: &cortex_m_rt::ExceptionFrame) -> ! {
            defmt::error!("HardFault at pc {=u32:#010x}, lr {=u32:#010x}", ef.pc(), ef.lr());
            $fatal()
        }

        #[cortex_m_rt::exception]
        unsafe fn DefaultHandler(irqn: i16) {
            defmt::error!("unexpected exception or interrupt {=i16}", irqn);
            $fatal()
        }
    };
}
