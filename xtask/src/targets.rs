//! The constants every task shares: the device's target and capacity, and the targets of
//! DESIGN §8 the size and bench tasks measure against.

/// The firmware's target triple (the Cortex-M4F of the interrogator's co-processor).
pub const THUMB: &str = "thumbv7em-none-eabihf";

/// The product's centre capacity.
pub const PRODUCT_K: usize = 32;

/// Instructions per step of the default model (with its memory bank).
pub const TARGET_INSNS_K32: f64 = 2500.0;
/// Flash target in bytes (DESIGN §8: 32 KiB, ≤ 48 KiB once the signature verifier is in; it
/// is).
pub const TARGET_FLASH: u64 = 48 * 1024;
/// Static RAM + stack target while serving, in bytes.
pub const TARGET_RAM: u64 = 8 * 1024;
/// Static RAM + stack target at the peak of a model load (boot, update: where the signature
/// verification runs), in bytes (DESIGN §8: ≤ 12 KiB at the verification peak).
pub const TARGET_RAM_LOAD: u64 = 12 * 1024;
/// Blob size target in bytes (K = 32).
pub const TARGET_BLOB: u64 = 4 * 1024;
/// Flash target of the product as it ships, the STM32F405 board's product image (`cargo xtask
/// board`, `cargo xtask size`), in bytes: [`TARGET_FLASH`] (the mps2 QEMU image,
/// which carries a semihosting persistence driver the part never runs, is reported beside it).
pub const TARGET_BOARD_FLASH: u64 = TARGET_FLASH;
/// Boot to serving with a full event log, µs of emulated time.
pub const TARGET_BOOT_US: u32 = 50_000;
/// Erases one model update may cause: the inactive slot, and a log sector when the
/// update's record rotates the log.
pub const TARGET_ERASES_PER_UPDATE: u32 = 2;

/// Records per sector of the model store's event log: `(ERASE_SIZE − RECORDS_AT) /
/// RECORD_LEN` of `fbg_firmware_app::store::format` with the product's 16 KiB sectors.
pub const STORE_LOG_RECORDS_PER_SECTOR: u32 = (16 * 1024 - 96) / 64;

/// The word a measured figure gets against its target.
pub fn verdict(ok: bool) -> &'static str {
    if ok {
        "meets target"
    } else {
        "MISSES target"
    }
}
