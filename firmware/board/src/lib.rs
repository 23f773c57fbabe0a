//! Board support of the FBG firmware on an STM32F405 (the chip of QEMU's `netduinoplus2`; e.g.
//! an STM32F405RG board such as the Adafruit Feather STM32F405 or the Netduino Plus 2), built
//! on the ecosystem's crates: `stm32f4xx-hal` for clocks, GPIO and USART, the PAC's interrupt
//! table (`stm32f4`, feature `rt`), `defmt-rtt` for the log. What it holds:
//!
//! - [`board`]: bring-up — clocks, the link's USART, the alarm LED, the model store;
//! - [`serial`]: the HAL's USART as the `embedded-io` 0.7 `Read`/`Write` the application takes;
//! - [`store_flash`]: the model store, flash sectors 5–8, as NOR flash;
//! - [`stack`]: the stack high-water mark (the device crate's painting, every board's);
//! - the fatal path ([`fatal`]), the panic and fault handlers, the defmt logger.
//!
//! With the `emulator` feature the same images run on QEMU's `netduinoplus2`, which models the
//! USARTs but not the clock tree nor the flash controller (README-firmware.md, "Flashing a
//! real board"): clocks are left at reset (HSI 16 MHz), the store is RAM, defmt goes over
//! semihosting and the fatal path exits through semihosting.
//!
//! The application logic lives in the host-testable `fbg-firmware-app` crate; this crate does
//! not depend on the QEMU firmware (`fbg-firmware`), whose build puts the mps2 memory map on
//! the linker path.

#![no_std]

pub mod board;
pub mod serial;
pub mod store_flash;

#[cfg(not(feature = "emulator"))]
use defmt_rtt as _;
#[cfg(feature = "emulator")]
use defmt_semihosting as _;
// The PAC's interrupt table (`__INTERRUPTS`, `device.x`) must be linked in.
use stm32f4 as _;

/// Centre capacity of this build (env `FBG_K` at build time, default 32), and the step and
/// blob parser compiled for it for speed (`fbg-firmware-kernel`), with the update limits that
/// follow from it (`MAX_BLOB`, `STAGING_LEN`, the same for every board).
pub use fbg_firmware_kernel::{step, K, KERNEL, MAX_BLOB, STAGING_LEN};

/// The signature policy every board's images are built with (`FBG_TRUSTED_KEYS`,
/// `FBG_ALLOW_ROLLBACK`, `FBG_REQUIRE_SIGNED_DEFAULT`: the device crate's build script;
/// README-firmware.md, "Signed model updates").
pub use fbg_firmware_device::{trust, POLICY};

/// The model embedded in the product image (the device crate's, every board's), and the stack
/// high-water mark (the same).
pub use fbg_firmware_device::{stack, DEFAULT_MODEL};

/// Leave the debug session (probe-rs or QEMU, both serve semihosting) with success: the end of
/// a test image.
pub fn exit_success() -> ! {
    semihosting::process::exit(0)
}

/// Leave the debug session with failure: the end of a failed test image.
pub fn exit_failure() -> ! {
    semihosting::process::exit(1)
}

/// The product's fatal path, after the reason is logged: on the part a reset (a deployed
/// device has no debugger to serve semihosting, whose call would halt it); in the emulator a
/// semihosting exit with failure, so that a test sees it.
pub fn fatal() -> ! {
    #[cfg(feature = "emulator")]
    exit_failure();
    #[cfg(not(feature = "emulator"))]
    cortex_m::peripheral::SCB::sys_reset()
}

fbg_firmware_device::fault_handlers!(fatal);
