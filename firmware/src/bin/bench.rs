//! Bench image: cost of one `Compensator::step` for every model of the pack embedded at build
//! time (`FBG_BENCH_PACK`, read with `fbg_shared::golden::records`; capacity K = `FBG_K`) on its samples.
//!
//! Under QEMU `-icount shift=0` SysTick counts virtual time that advances exactly one ns per
//! instruction, so SysTick deltas count instructions (the ratio is calibrated with a loop of
//! known length). Each measurement runs `n` steps and, separately, the same loop without the
//! step; the difference over `n` is the cost of one step, and two values of `n` check it is
//! linear. The samples (at most 64) are replayed in order with the clock continued across
//! passes, so that the memory bank sees a regular stream (mode `regular`: the sampling clock as
//! given, its smoothing factors cached); mode `jitter` adds ±0.25 s to every other time stamp,
//! so that every step has a new Δt and recomputes the factors. On hardware the same image also
//! reports DWT CYCCNT cycles (QEMU reads 0). Results go out as text lines on UART0 (with the
//! sizes of the device's types); the run ends with a semihosting exit.
//!
//! With a signed model embedded (`FBG_BENCH_SIGNED`) it also times one signature check of a
//! model update as the product runs it (`fbg_firmware_app::authenticate` with the image's
//! policy: trailer, key lookup, Ed25519 verification, serial) and reports its instructions and
//! the stack it reached.

#![no_std]
#![no_main]

use core::fmt::Write as _;
use core::hint::black_box;

use cortex_m_rt::entry;
use embedded_io::Write;
use fbg_firmware::counters::{
    cycles_now, cycles_start, known_loop, systick_elapsed, systick_now, systick_start, CALIB_ITERS,
};
use fbg_firmware::uart::{CmsdkUart, MPS2_PCLK_HZ, UART0_BASE};
use fbg_firmware::{exit_failure, exit_success, stack, step, K, KERNEL, POLICY, STAGING_LEN};
#[cfg(feature = "spectrum")]
use fbg_firmware_app::spectrum::{GratingSetup, GridSetup, Outcome, SpectrumFront};
use fbg_firmware_app::{authenticate, load_blob, unloaded};
#[cfg(feature = "spectrum")]
use fbg_shared::protocol::MAX_PIXELS_PER_CHUNK;
use fbg_shared::protocol::{FrameReader, HOST_MAX_FRAME};
#[cfg(feature = "spectrum")]
use fbg_shared::spectrum::centroid::maximum;
#[cfg(feature = "spectrum")]
use fbg_shared::spectrum::correlation::cross_correlation;
#[cfg(feature = "spectrum")]
use fbg_shared::spectrum::{DetectorConfig, Estimate, Grid, Method, Region, ShiftRef, Span, Spectrum, Window};
use fbg_shared::{Compensator, MemoryBank, MemoryState, ModelParams, Sample, StreamState};

static PACK: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/bench_pack.bin"));
static SIGNED: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/bench_signed.fbgm"));

const MAX_SAMPLES: usize = 64;
const RUNS: [u32; 2] = [200, 800];
/// Runs of the spectrum bench (channel frames).
#[cfg(feature = "spectrum")]
const SPECTRUM_RUNS: [u32; 2] = [10, 40];
/// The spectrum bench's frame: pixels, and the gratings' centres \[nm\] (all on channel 0).
#[cfg(feature = "spectrum")]
const SPECTRUM_PIXELS: usize = 512;
#[cfg(feature = "spectrum")]
const SPECTRUM_PEAKS: [f32; 3] = [1530.013, 1550.021, 1570.034];
/// Modes: (name, time-stamp jitter on every other step [s]).
const MODES: [(&str, f32); 2] = [("regular", 0.0), ("jitter", 0.25)];

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

/// The samples replayed: sample `i % len`, its clock moved on by a whole period per pass, and
/// `jitter` added to every other time stamp.
#[derive(Clone, Copy)]
struct Replay<'a> {
    samples: &'a [Sample<f32>],
    period: f32,
    jitter: f32,
}

impl Replay<'_> {
    #[inline(always)]
    fn nth(&self, i: usize) -> Sample<f32> {
        let len = self.samples.len().max(1);
        let mut s = self.samples.get(i % len).copied().unwrap_or_default();
        let odd = if i & 1 == 1 { self.jitter } else { 0.0 };
        s.t_s += (i / len) as f32 * self.period + odd;
        s
    }
}

#[inline(never)]
fn empty_loop(r: &Replay<'_>, n: u32) {
    for i in 0..n as usize {
        black_box(r.nth(i));
    }
}

#[inline(never)]
fn step_loop(comp: &mut Compensator<f32, K>, r: &Replay<'_>, n: u32) {
    for i in 0..n as usize {
        let s = r.nth(i);
        black_box(step(comp, black_box(&s)));
    }
}

/// One 512-pixel frame (little-endian u16) of three Gaussian peaks of 0.3 nm FWHM, 20 000
/// counts over a floor of 1 000, with ±35 counts of deterministic noise (σ ≈ 20: 30 dB), on
/// the grid λ(p) = 1510 + 0.166·p + 2·10⁻⁶·p² nm (the QEMU spectrum test's). The Gaussian is
/// (1 − z²/128)⁶⁴ (within 1 % of exp(−z²/2) where it matters; the cost does not depend on it).
#[cfg(feature = "spectrum")]
fn make_frame(out: &mut [u8; 2 * SPECTRUM_PIXELS]) {
    let mut state: u32 = 12_345;
    for (p, px) in out.chunks_exact_mut(2).enumerate() {
        let x = p as f32;
        let lambda = 1510.0 + x * (0.166 + x * 2.0e-6);
        let mut v = 1000.0f32;
        for c in SPECTRUM_PEAKS {
            let z = (lambda - c) / (0.3 / 2.354_82);
            let mut g = 1.0 - z * z / 128.0;
            if g > 0.0 {
                for _ in 0..6 {
                    g *= g;
                }
                v += 20_000.0 * g;
            }
        }
        state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        v += ((state >> 16) % 71) as f32 - 35.0;
        px.copy_from_slice(&(v as u16).to_le_bytes());
    }
}

/// `n` channel frames through the device's spectrum front (begin, the chunks, the three
/// gratings' detection); returns the readings completed (`n` when all is well).
#[cfg(feature = "spectrum")]
#[inline(never)]
fn frame_loop(front: &mut SpectrumFront, frame: &[u8], n: u32) -> u32 {
    let mut readings = 0;
    for i in 0..n {
        black_box(front.begin(i, 0, i as f32 * 60.0, 20.0));
        for (k, c) in frame.chunks(2 * MAX_PIXELS_PER_CHUNK).enumerate() {
            let first = (k * MAX_PIXELS_PER_CHUNK) as u16;
            if let Outcome::Reading { .. } = black_box(front.pixels(first, black_box(c))) {
                readings += 1;
            }
        }
    }
    readings
}

/// `n` channel frames on a channel without gratings: the frame's reception alone.
#[cfg(feature = "spectrum")]
#[inline(never)]
fn ingest_loop(front: &mut SpectrumFront, frame: &[u8], n: u32) {
    for i in 0..n {
        black_box(front.begin(i, 9, i as f32 * 60.0, 20.0));
        for (k, c) in frame.chunks(2 * MAX_PIXELS_PER_CHUNK).enumerate() {
            black_box(front.pixels((k * MAX_PIXELS_PER_CHUNK) as u16, black_box(c)));
        }
    }
}

/// A method's estimator (the detector's `detect_with` argument).
#[cfg(feature = "spectrum")]
type EstimateFn = fn(&Region<'_, f32>, f32) -> Estimate<f32>;

/// `n` detections of one window's peak (the first grating's 25 pixels, f32) with `estimate`,
/// on the span its set-up found (as the product detects).
#[cfg(feature = "spectrum")]
#[inline(never)]
fn window_loop(config: &DetectorConfig<f32>, part: &Spectrum<'_, f32>, span: Span, estimate: EstimateFn, n: u32) {
    for _ in 0..n {
        black_box(config.detect_span(black_box(part), black_box(span), estimate));
    }
}

#[cfg(feature = "spectrum")]
#[inline(never)]
fn window_empty_loop(part: &Spectrum<'_, f32>, n: u32) {
    for _ in 0..n {
        black_box(black_box(part));
    }
}

/// Where a frame's instructions go: its reception alone (a channel without gratings), and one
/// window's detection with the maximum (the detector's common part: checks, noise, region,
/// half-widths, flags) and with the cross-correlation.
#[cfg(feature = "spectrum")]
fn bench_spectrum_parts(uart: &mut CmsdkUart, front: &mut SpectrumFront, frame: &[u8]) {
    for n in SPECTRUM_RUNS {
        let (te, _) = measure(|| frame_empty_loop(frame, n));
        let (tf, _) = measure(|| ingest_loop(front, frame, n));
        emit(uart, format_args!("spectrum_part what=ingest n={} empty_ticks={} ticks={}", n, te, tf));
    }
    let grid = Grid::polynomial([1510.0, 0.166, 2.0e-6, 0.0, 0.0, 0.0]);
    let window = Window::centred(SPECTRUM_PEAKS[0], 2.0);
    let Some(span) = window.span_of(&grid, 0, SPECTRUM_PIXELS) else { exit_failure() };
    let mut buf = [0f32; 64];
    for (d, px) in buf.iter_mut().zip(frame.chunks_exact(2).skip(span.first)) {
        if let [lo, hi] = *px {
            *d = f32::from(u16::from_le_bytes([lo, hi]));
        }
    }
    let len = (span.last - span.first + 1).min(64);
    let part = Spectrum::part(buf.get(..len).unwrap_or(&[]), grid, span.first);
    let config = DetectorConfig { full_scale: 65_535.0, ..DetectorConfig::default() };
    let methods: [(&str, EstimateFn); 2] =
        [("window_maximum", |r, _| maximum(r)), ("window_cross_correlation", cross_correlation::<f32>)];
    for (what, f) in methods {
        for n in SPECTRUM_RUNS {
            let (te, _) = measure(|| window_empty_loop(&part, n));
            let (tf, _) = measure(|| window_loop(&config, &part, span, f, n));
            emit(uart, format_args!("spectrum_part what={} n={} empty_ticks={} ticks={}", what, n, te, tf));
        }
    }
}

/// [`frame_loop`] without the device: the same loop over the chunks.
#[cfg(feature = "spectrum")]
#[inline(never)]
fn frame_empty_loop(frame: &[u8], n: u32) {
    for i in 0..n {
        black_box(i);
        for c in frame.chunks(2 * MAX_PIXELS_PER_CHUNK) {
            black_box(c);
        }
    }
}

/// The spectrum bench: instructions per 512-pixel channel frame with three gratings, default
/// method (cross-correlation), as the product receives it (without the link's framing and
/// without the step, timed apart).
#[cfg(feature = "spectrum")]
fn bench_spectrum(uart: &mut CmsdkUart, front: &mut SpectrumFront, frame: &mut [u8; 2 * SPECTRUM_PIXELS]) {
    make_frame(frame);
    let grid = GridSetup {
        gratings: 3,
        pixels: SPECTRUM_PIXELS as u16,
        uniform: false,
        coefficients: [1510.0, 0.166, 2.0e-6, 0.0, 0.0, 0.0],
        method: Method::CrossCorrelation.code(),
        full_scale: 65_535.0,
    };
    let mut ok = matches!(front.grid(&grid), Outcome::Set(3));
    for (k, c) in SPECTRUM_PEAKS.iter().enumerate() {
        let g = GratingSetup {
            index: k as u8,
            channel: 0,
            window: Window::centred(*c, 2.0),
            shift: ShiftRef { hi_nm: *c, lo_nm: 0.0 },
        };
        ok &= matches!(front.grating(&g), Outcome::Set(_));
    }
    if !ok {
        emit(uart, format_args!("error spectrum set-up refused"));
        exit_failure()
    }
    black_box(frame_loop(front, frame, 2));
    for n in SPECTRUM_RUNS {
        let (te, _) = measure(|| frame_empty_loop(frame, n));
        let mut readings = 0;
        let (tf, _) = measure(|| readings = frame_loop(front, frame, n));
        emit(
            uart,
            format_args!(
                "spectrum pixels={} gratings=3 n={} readings={} empty_ticks={} frame_ticks={}",
                SPECTRUM_PIXELS, n, readings, te, tf
            ),
        );
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

/// The sizes of the device's types, in the line `cargo xtask device-bench` reads.
fn emit_sizes(uart: &mut CmsdkUart) {
    use core::mem::size_of;
    emit(
        uart,
        format_args!(
            "sizes k={} memory_state={} stream_state={} memory_bank={} compensator={} model_params={} reader={} staging={}",
            K,
            size_of::<MemoryState<f32>>(),
            size_of::<StreamState<f32>>(),
            size_of::<MemoryBank<f32>>(),
            size_of::<Compensator<f32, K>>(),
            size_of::<ModelParams<f32, 0, 0>>(),
            size_of::<FrameReader<HOST_MAX_FRAME>>(),
            STAGING_LEN
        ),
    );
}

/// One signature check of the embedded signed model, with the stack it reached (nothing
/// without one).
fn bench_verify(uart: &mut CmsdkUart) {
    if SIGNED.is_empty() {
        return;
    }
    // Painted again first, so that the peak is the check's own (plus this frame).
    stack::repaint();
    let base = stack::peak_bytes();
    let mut ok = false;
    let (t, c) = measure(|| ok = black_box(authenticate(&POLICY, black_box(SIGNED), None)).is_ok());
    emit(
        uart,
        format_args!(
            "verify bytes={} ok={} ticks={} cycles={} stack_before={} stack_peak={}",
            SIGNED.len(),
            ok as u8,
            t,
            c,
            base,
            stack::peak_bytes()
        ),
    );
    stack::repaint();
}

/// Load record `idx` of the pack into `comp`, copy its samples into `buf` and time the step
/// over them in every mode.
fn bench_model(
    uart: &mut CmsdkUart,
    idx: usize,
    rec: &fbg_shared::golden::Record<'_>,
    comp: &mut Compensator<f32, K>,
    buf: &mut [Sample<f32>; MAX_SAMPLES],
) {
    let info = match load_blob(&KERNEL, comp, rec.blob) {
        Ok(x) => x,
        Err(r) => {
            emit(uart, format_args!("error model {} rejected: {} (detail {})", idx, r.reason.describe(), r.detail));
            exit_failure()
        }
    };
    let mut n_samples = 0;
    for (dst, s) in buf.iter_mut().zip(rec.iter()) {
        *dst = s;
        n_samples += 1;
    }
    if n_samples == 0 {
        emit(uart, format_args!("error no samples for model {}", idx));
        exit_failure()
    }
    let samples = buf.get(..n_samples).unwrap_or(&[]);
    // One pass lasts from the first time stamp to the last plus one more step.
    let period = match samples {
        [first, .., before, last] => last.t_s - first.t_s + (last.t_s - before.t_s),
        _ => 60.0,
    };
    emit(
        uart,
        format_args!(
            "model idx={} k={} centres={} memory={} crc={:#010x} samples={} period={}",
            idx,
            K,
            info.centres,
            comp.has_memory() as u8,
            info.crc,
            n_samples,
            period
        ),
    );
    for (mode, jitter) in MODES {
        let replay = Replay { samples, period, jitter };
        // Warm up once (first-touch effects do not exist here, but keep runs identical).
        comp.reset();
        step_loop(comp, &replay, 8);
        for n in RUNS {
            comp.reset();
            let (te, ce) = measure(|| empty_loop(&replay, n));
            let (ts, cs) = measure(|| step_loop(comp, &replay, n));
            emit(
                uart,
                format_args!(
                    "run idx={} mode={} n={} empty_ticks={} step_ticks={} empty_cycles={} step_cycles={}",
                    idx, mode, n, te, ts, ce, cs
                ),
            );
        }
    }
}

#[entry]
fn main() -> ! {
    static mut MODEL: Compensator<f32, K> = unloaded();
    #[cfg(feature = "spectrum")]
    static mut FRONT: Option<SpectrumFront> = None;
    #[cfg(feature = "spectrum")]
    static mut FRAME: [u8; 2 * SPECTRUM_PIXELS] = [0; 2 * SPECTRUM_PIXELS];
    static mut SAMPLES: [Sample<f32>; MAX_SAMPLES] =
        [Sample { dl_pm: [0.0; fbg_shared::layout::MAX_GRATINGS], gratings: 0, t_amb_c: 0.0, t_s: 0.0 }; MAX_SAMPLES];

    // SAFETY: UART0 of the MPS2 board, driven only from here.
    let mut uart = unsafe { CmsdkUart::new(UART0_BASE) };
    uart.init(MPS2_PCLK_HZ, 115_200);
    if PACK.is_empty() {
        emit(&mut uart, format_args!("error no bench pack (FBG_BENCH_PACK)"));
        exit_failure()
    }
    let Some(mut cp) = cortex_m::Peripherals::take() else { exit_failure() };
    systick_start(&mut cp.SYST);
    let has_cyccnt = cycles_start(&mut cp.DCB, &mut cp.DWT);
    emit_sizes(&mut uart);
    let (t, c) = measure(|| known_loop(CALIB_ITERS));
    emit(
        &mut uart,
        format_args!(
            "calib iters={} insns={} ticks={} cycles={} cyccnt={}",
            CALIB_ITERS,
            2 * CALIB_ITERS,
            t,
            c,
            has_cyccnt as u8
        ),
    );
    bench_verify(&mut uart);
    #[cfg(feature = "spectrum")]
    {
        let front = FRONT.insert(SpectrumFront::new());
        bench_spectrum(&mut uart, front, FRAME);
        bench_spectrum_parts(&mut uart, front, FRAME);
    }
    for (idx, rec) in fbg_shared::golden::records(PACK).enumerate() {
        let Some(rec) = rec else {
            emit(&mut uart, format_args!("error bench pack malformed at record {}", idx));
            exit_failure()
        };
        bench_model(&mut uart, idx, &rec, MODEL, SAMPLES);
    }
    emit(&mut uart, format_args!("stack peak={} size={}", stack::peak_bytes(), stack::size()));
    emit(&mut uart, format_args!("done"));
    let _ = uart.flush();
    defmt::info!("bench done");
    exit_success()
}
