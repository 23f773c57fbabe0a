//! The defmt global logger: frames go to the host over semihosting (QEMU's stdout). What
//! `defmt-semihosting` does, with a write loop that has no panic path (its `write_all` links
//! `core::fmt` into the image) and no panic on a nested use (the run ends with failure instead).

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, Ordering};

use semihosting::io::{Stdout, Write as _};

#[defmt::global_logger]
struct Logger;

/// The encoder, the host handle, and whether interrupts were enabled before `acquire`.
struct State {
    encoder: defmt::Encoder,
    handle: Option<Stdout>,
    irq_were_enabled: bool,
}

struct Shared {
    taken: AtomicBool,
    state: UnsafeCell<State>,
}

// SAFETY: `state` is only touched between `acquire` and `release`, with interrupts disabled
// and `taken` set (one core).
unsafe impl Sync for Shared {}

static SHARED: Shared = Shared {
    taken: AtomicBool::new(false),
    state: UnsafeCell::new(State { encoder: defmt::Encoder::new(), handle: None, irq_were_enabled: false }),
};

/// All of `bytes` to the host (what does not go is dropped).
fn out(handle: &mut Option<Stdout>, mut bytes: &[u8]) {
    let Some(h) = handle else { return };
    while !bytes.is_empty() {
        match h.write(bytes) {
            Ok(n) if n > 0 => bytes = bytes.get(n..).unwrap_or(&[]),
            _ => return,
        }
    }
}

// SAFETY: defmt calls these in the order acquire, write*, release; the state is exclusive in
// between (interrupts off, `taken` checked).
unsafe impl defmt::Logger for Logger {
    fn acquire() {
        let enabled = cortex_m::register::primask::read().is_active();
        cortex_m::interrupt::disable();
        if SHARED.taken.swap(true, Ordering::Relaxed) {
            // Logging from inside a log statement (a fault while logging): a bug; stop here.
            crate::exit_failure()
        }
        // SAFETY: taken just now, interrupts off.
        let st = unsafe { &mut *SHARED.state.get() };
        st.irq_were_enabled = enabled;
        if st.handle.is_none() {
            st.handle = semihosting::io::stdout().ok();
        }
        let State { encoder, handle, .. } = st;
        encoder.start_frame(|b| out(handle, b));
    }

    unsafe fn flush() {}

    unsafe fn release() {
        if !SHARED.taken.load(Ordering::Relaxed) {
            return;
        }
        // SAFETY: taken (by `acquire`), interrupts off.
        let st = unsafe { &mut *SHARED.state.get() };
        let State { encoder, handle, irq_were_enabled } = st;
        encoder.end_frame(|b| out(handle, b));
        let enable = *irq_were_enabled;
        SHARED.taken.store(false, Ordering::Relaxed);
        if enable {
            // SAFETY: they were enabled when this frame began.
            unsafe { cortex_m::interrupt::enable() };
        }
    }

    unsafe fn write(bytes: &[u8]) {
        if !SHARED.taken.load(Ordering::Relaxed) {
            return;
        }
        // SAFETY: taken (by `acquire`), interrupts off.
        let st = unsafe { &mut *SHARED.state.get() };
        let State { encoder, handle, .. } = st;
        encoder.write(bytes, |b| out(handle, b));
    }
}
