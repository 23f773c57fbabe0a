//! Counters for measurements.
//!
//! - SysTick as a free-running 24-bit down-counter on the core clock. Under QEMU with
//!   `-icount shift=0` every instruction advances virtual time by 1 ns and SysTick follows the
//!   25 MHz board clock, so instructions = ticks × (instructions per tick), which the bench
//!   calibrates with a loop of known length.
//! - DWT CYCCNT for real hardware (QEMU does not model cycles and reads 0 there).

use core::hint::black_box;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{DCB, DWT, SYST};

/// Mask of the 24-bit SysTick counter.
pub const SYSTICK_MASK: u32 = 0x00FF_FFFF;

/// The core clock SysTick counts on the MPS2 AN386 (QEMU's model of it), Hz.
pub const CORE_HZ: u32 = 25_000_000;

/// Ticks of the core clock as whole microseconds.
pub fn ticks_to_us(ticks: u32) -> u32 {
    ticks / (CORE_HZ / 1_000_000)
}

/// Start SysTick free-running from 2^24 − 1 on the core clock, without interrupts.
pub fn systick_start(syst: &mut SYST) {
    syst.disable_interrupt();
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(SYSTICK_MASK);
    syst.clear_current();
    syst.enable_counter();
}

/// Current SysTick value (counts down).
#[inline(always)]
pub fn systick_now() -> u32 {
    SYST::get_current()
}

/// Ticks from `start` to `end` (both from [`systick_now`]); correct while under 2^24 ticks.
#[inline(always)]
pub fn systick_elapsed(start: u32, end: u32) -> u32 {
    start.wrapping_sub(end) & SYSTICK_MASK
}

/// Enable the DWT cycle counter. Returns false where there is none.
pub fn cycles_start(dcb: &mut DCB, dwt: &mut DWT) -> bool {
    dcb.enable_trace();
    DWT::unlock();
    dwt.set_cycle_count(0);
    dwt.enable_cycle_counter();
    DWT::has_cycle_counter()
}

/// Current DWT cycle count (0 under QEMU).
#[inline(always)]
pub fn cycles_now() -> u32 {
    DWT::cycle_count()
}

/// Iterations of [`known_loop`] a calibration runs: 2 × this instructions.
pub const CALIB_ITERS: u32 = 100_000;

/// `iters` iterations of a two-instruction loop (`subs`, `bne`).
#[inline(never)]
pub fn known_loop(iters: u32) {
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
