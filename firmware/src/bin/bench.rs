//! Bench image: cost of one `Compensator::step` with the model embedded at build time
//! (`FBG_BENCH_MODEL`, K = `FBG_K`) on the samples of `FBG_BENCH_INPUTS`.
//!
//! Under QEMU `-icount shift=0` SysTick counts virtual time that advances exactly one ns per
//! instruction, so SysTick deltas count instructions (the ratio is calibrated with a loop of
//! known length). Each measurement runs `n` steps and, separately, the same loop without the
//! step; the difference over `n` is the cost of one step, and two values of `n` check it is
//! linear. On hardware the same image also reports DWT CYCCNT cycles (QEMU reads 0).
//! Results go out as text lines on UART0; the run ends with a semihosting exit.

#![no_std]
#![no_main]

use core::fmt::Write as _;
use core::hint::black_box;

use cortex_m_rt::entry;
use embedded_io::Write;
use fbg_firmware::counters::{cycles_now, cycles_start, systick_elapsed, systick_now, systick_start};
use fbg_firmware::uart::{CmsdkUart, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, exit_success, stack, step, K, KERNEL};
use fbg_firmware_app::{load_with, unloaded, Scratch};
use fbg_shared::{Compensator, Sample};

static MODEL_BLOB: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/bench_model.fbgm"));
static INPUTS: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/bench_inputs.bin"));

const MAX_SAMPLES: usize = 64;
const CALIB_ITERS: u32 = 100_000;
const RUNS: [u32; 2] = [200, 800];

/// A tiny line buffer so the report can use `core::fmt` without a heap.
struct Line {
    buf: [u8; 160],
    len: usize,
}

impl core::fmt::Write for Line {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        let end = self.len + s.len();
        let dst = self.buf.get_mut(self.len..end).ok_or(core::fmt::Error)?;
        dst.copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

fn emit(uart: &mut CmsdkUart, args: core::fmt::Arguments<'_>) {
    let mut l = Line { buf: [0; 160], len: 0 };
    let _ = l.write_fmt(args);
    let _ = uart.write_all(l.buf.get(..l.len).unwrap_or(&[]));
    let _ = uart.write_all(b"\n");
}

/// `iters` iterations of a two-instruction loop (`subs`, `bne`).
#[inline(never)]
fn known_loop(iters: u32) {
    let mut n = iters;
    // SAFETY: register-only arithmetic loop.
    unsafe {
        core::arch::asm!(
            "2:",
            "subs {n}, {n}, #1",
            "bne 2b",
            n = inout(reg) n,
            options(nomem, nostack)
        );
    }
    black_box(n);
}

#[inline(never)]
fn empty_loop(samples: &[Sample<f32>], n: u32) {
    let len = samples.len().max(1);
    for i in 0..n as usize {
        black_box(samples.get(i % len));
    }
}

#[inline(never)]
fn step_loop(comp: &mut Compensator<f32, K>, samples: &[Sample<f32>], n: u32) {
    let len = samples.len().max(1);
    for i in 0..n as usize {
        if let Some(s) = samples.get(i % len) {
            black_box(step(comp, black_box(s)));
        }
    }
}

/// (SysTick ticks, DWT cycles) of `f`.
fn measure(f: impl FnOnce()) -> (u32, u32) {
    let c0 = cycles_now();
    let t0 = systick_now();
    f();
    let t1 = systick_now();
    let c1 = cycles_now();
    (systick_elapsed(t0, t1), c1.wrapping_sub(c0))
}

#[entry]
fn main() -> ! {
    static mut MODEL: Compensator<f32, K> = unloaded();
    static mut SCRATCH: Scratch<K> = Scratch::new();
    static mut SAMPLES: [Sample<f32>; MAX_SAMPLES] =
        [Sample { dl_pm: [0.0; 3], t_amb_c: 0.0, t_s: 0.0 }; MAX_SAMPLES];

    // SAFETY: UART0 of the MPS2 board, driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, 115_200);
    let info = match load_with(&KERNEL, MODEL, SCRATCH, MODEL_BLOB) {
        Ok(x) => x,
        Err(r) => {
            emit(&mut uart, format_args!("error model rejected: {} (detail {})", r.reason.describe(), r.detail));
            exit_failure()
        }
    };
    let mut n_samples = 0;
    for (dst, rec) in SAMPLES.iter_mut().zip(INPUTS.chunks_exact(20)) {
        let mut f = [0f32; 5];
        for (o, b) in f.iter_mut().zip(rec.chunks_exact(4)) {
            let mut w = [0u8; 4];
            w.copy_from_slice(b);
            *o = f32::from_le_bytes(w);
        }
        *dst = Sample { dl_pm: [f[0], f[1], f[2]], t_amb_c: f[3], t_s: f[4] };
        n_samples += 1;
    }
    if n_samples == 0 {
        emit(&mut uart, format_args!("error no bench inputs"));
        exit_failure()
    }
    let samples = SAMPLES.get(..n_samples).unwrap_or(&[]);

    let comp = MODEL;
    let Some(mut cp) = cortex_m::Peripherals::take() else { exit_failure() };
    systick_start(&mut cp.SYST);
    let has_cyccnt = cycles_start(&mut cp.DCB, &mut cp.DWT);

    emit(&mut uart, format_args!("model k={} centres={} crc={:#010x} samples={}", K, info.centres, info.crc, n_samples));
    let (t, c) = measure(|| known_loop(CALIB_ITERS));
    emit(&mut uart, format_args!("calib iters={} insns={} ticks={} cycles={} cyccnt={}", CALIB_ITERS, 2 * CALIB_ITERS, t, c, has_cyccnt as u8));
    // Warm up once (first-touch effects do not exist here, but keep runs identical).
    step_loop(comp, samples, 8);
    for n in RUNS {
        comp.reset();
        let (te, ce) = measure(|| empty_loop(samples, n));
        let (ts, cs) = measure(|| step_loop(comp, samples, n));
        emit(&mut uart, format_args!("run n={} empty_ticks={} step_ticks={} empty_cycles={} step_cycles={}", n, te, ts, ce, cs));
    }
    emit(&mut uart, format_args!("stack peak={} size={}", stack::peak_bytes(), stack::size()));
    emit(&mut uart, format_args!("done"));
    let _ = uart.flush();
    defmt::info!("bench done");
    exit_success()
}
