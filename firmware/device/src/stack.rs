//! Stack high-water mark by stack painting.
//!
//! cortex-m-rt's `paint-stack` feature fills the whole stack region, from `_stack_end` (just
//! above the statics) to `_stack_start` (top of RAM), with `0xCCCC_CCCC` before `main`. The
//! deepest stack use since then is the distance from the top to the lowest word that no longer
//! holds the pattern.

use core::ptr::{addr_of, read_volatile, write_volatile};

/// The paint pattern (cortex-m-rt's `STACK_PAINT_VALUE`).
pub const PAINT: u32 = 0xCCCC_CCCC;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Lowest and highest (exclusive) address of the stack region.
pub fn bounds() -> (usize, usize) {
    // Only the addresses of the linker symbols are taken, never their contents.
    (addr_of!(_stack_end) as usize, addr_of!(_stack_start) as usize)
}

/// Bytes between the top of RAM and the static data: the most stack the program could use.
pub fn size() -> u32 {
    let (lo, hi) = bounds();
    (hi - lo) as u32
}

/// Deepest stack use since reset (or since [`repaint`]) in bytes.
pub fn peak_bytes() -> u32 {
    let (lo, hi) = bounds();
    let mut addr = lo;
    while addr < hi {
        // SAFETY: `addr` is word-aligned inside the RAM stack region.
        if unsafe { read_volatile(addr as *const u32) } != PAINT {
            break;
        }
        addr += 4;
    }
    (hi - addr) as u32
}

/// Paint the unused part of the stack again (below the current stack pointer, keeping a margin
/// for this function's own frame), so that a later [`peak_bytes`] measures only what runs
/// after this call. Interrupts are masked meanwhile.
pub fn repaint() {
    cortex_m::interrupt::free(|_| {
        let sp = cortex_m::register::msp::read() as usize;
        let (lo, _) = bounds();
        let mut addr = lo;
        let stop = sp.saturating_sub(64) & !3;
        while addr < stop {
            // SAFETY: word-aligned, inside the stack region and below the live stack.
            unsafe { write_volatile(addr as *mut u32, PAINT) };
            addr += 4;
        }
    });
}
