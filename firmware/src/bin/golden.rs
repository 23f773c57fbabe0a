//! Golden-vector test image: compensates the samples embedded at build time (`FBG_GOLDEN_INPUTS`,
//! raw LE f32 × 5 per sample) with the embedded model (`FBG_GOLDEN_MODEL`) and sends every
//! estimate as a protocol `Estimate` frame on UART0; the host compares them with its f64 answers.
//! Exits through semihosting (success after the last sample, failure if the model is refused).

#![no_std]
#![no_main]


use cortex_m_rt::entry;
use embedded_io::Write;
use fbg_firmware::uart::{CmsdkUart, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, exit_success, stack, step, K, KERNEL};
use fbg_firmware_app::{load_with, unloaded, Scratch};
use fbg_shared::protocol::{encode_device, DeviceEstimate, DeviceMsg, DEVICE_MAX_FRAME};
use fbg_shared::{Compensator, Sample};

static MODEL_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/golden_model.fbgm"));
static INPUTS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/golden_inputs.bin"));

#[entry]
fn main() -> ! {
    static mut MODEL: Compensator<f32, K> = unloaded();
    static mut SCRATCH: Scratch<K> = Scratch::new();

    // SAFETY: UART0 of the MPS2 board, driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, 115_200);
    let comp = match load_with(&KERNEL, MODEL, SCRATCH, MODEL_BLOB) {
        Ok(_) => MODEL,
        Err(r) => {
            defmt::error!("golden model rejected: {=istr} (detail {=u32})", fbg_firmware_app::reason_name(r.reason), r.detail);
            exit_failure()
        }
    };
    if INPUTS.is_empty() || INPUTS.len() % 20 != 0 {
        defmt::error!("golden inputs missing or not 5 × f32 per sample ({=usize} bytes)", INPUTS.len());
        exit_failure()
    }
    let mut n = 0u32;
    for rec in INPUTS.chunks_exact(20) {
        let mut f = [0f32; 5];
        for (o, b) in f.iter_mut().zip(rec.chunks_exact(4)) {
            *o = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        }
        let s = Sample { dl_pm: [f[0], f[1], f[2]], t_amb_c: f[3], t_s: f[4] };
        let e = step(comp, &s);
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
    let _ = uart.flush();
    defmt::info!("golden: {=u32} samples compensated, stack peak {=u32} B", n, stack::peak_bytes());
    exit_success()
}
