//! Golden-vector test image: for every record of the pack embedded at build time
//! (`FBG_GOLDEN_PACK`, read with `fbg_shared::golden::records`: a model blob and its samples), loads the model the way
//! the product does (a fresh stream state each time) and compensates the samples, sending
//! every estimate as a protocol `Estimate` frame on UART0, numbered across the records; the
//! host compares them with its f64 answers. Exits through semihosting (success after the last
//! sample, failure if a model is refused or the pack is malformed).

#![no_std]
#![no_main]

use cortex_m_rt::entry;
use embedded_io::Write;
use fbg_firmware::uart::{CmsdkUart, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, exit_success, stack, step, K, KERNEL};
use fbg_firmware_app::{load_blob, unloaded};
use fbg_shared::protocol::{encode_device, DeviceEstimate, DeviceMsg, DEVICE_MAX_FRAME};
use fbg_shared::Compensator;

static PACK: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/golden_pack.bin"));

#[entry]
fn main() -> ! {
    static mut MODEL: Compensator<f32, K> = unloaded();

    // SAFETY: UART0 of the MPS2 board, driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, 115_200);
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
            let msg = DeviceMsg::Estimate(DeviceEstimate { seq: n, values: e.values, band: e.band95, flags: e.flags });
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
