//! Board support of the FBG firmware on the MPS2 AN386 (Cortex-M4F), as QEMU's `mps2-an386`
//! models it: the CMSDK APB UART driver (`embedded-io`), the FPGA IO LED as the alarm
//! (`embedded-hal` `OutputPin`), the flash of the persistent model store (`embedded-storage`
//! `NorFlash`, kept across QEMU runs in a host file), SysTick/DWT counters, the stack high-water
//! mark, the fatal-error path (defmt log, then semihosting exit with failure), the defmt logger
//! (over semihosting). The test images read the packs of models and samples they embed with
//! `fbg_shared::golden::records`.
//!
//! The application logic lives in the host-testable `fbg-firmware-app` crate.

#![no_std]

pub mod counters;
pub mod led;
mod logger;
pub mod product;
pub mod rfc8032;
pub mod store_flash;
pub mod uart;

/// Centre capacity of this build (env `FBG_K` at build time, default 32), and the step and
/// blob parser compiled for it for speed (`fbg-firmware-kernel`), with the update limits that
/// follow from it (`MAX_BLOB`, `STAGING_LEN`, the same for every board).
pub use fbg_firmware_kernel::{step, K, KERNEL, MAX_BLOB, STAGING_LEN};

/// The signature policy every board's images are built with (`FBG_TRUSTED_KEYS`,
/// `FBG_ALLOW_ROLLBACK`, `FBG_REQUIRE_SIGNED_DEFAULT`: the device crate's build script;
/// README-firmware.md, "Signed model updates").
pub use fbg_firmware_device::{trust, POLICY};

/// The model embedded in the product image, and the stack high-water mark (the device
/// crate's, every board's).
pub use fbg_firmware_device::{stack, DEFAULT_MODEL};

/// Leave the emulator (or the debug session) with success.
pub fn exit_success() -> ! {
    semihosting::process::exit(0)
}

/// Leave the emulator (or the debug session) with failure.
pub fn exit_failure() -> ! {
    semihosting::process::exit(1)
}

/// Device interrupt vectors in the image: the 32 lines of the MPS2's CMSDK subsystem
/// (cortex-m-rt's generic table has 240, 832 bytes more flash). Every line goes to
/// `DefaultHandler`; the only line this firmware unmasks is UART0's receive interrupt, as a
/// wake-up event under PRIMASK (no handler runs). On another part, make this at least the
/// number of its lines that can be enabled (README-firmware.md, real hardware).
pub const N_IRQ: usize = 32;

const _: () = assert!((uart::Uart0Rx::LINE as usize) < N_IRQ, "the UART wake-up line needs a vector");

extern "C" {
    fn DefaultHandler();
}

/// The device part of the vector table (cortex-m-rt's `device` feature: the image provides it,
/// `build.rs` an empty `device.x`).
#[doc(hidden)]
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
#[used]
pub static __INTERRUPTS: [unsafe extern "C" fn(); N_IRQ] = [DefaultHandler; N_IRQ];

fbg_firmware_device::fault_handlers!(exit_failure);
