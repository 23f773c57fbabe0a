//! Long work that Ctrl-C can stop: Python runs its signal handlers only when the calling thread
//! holds the GIL, so work that releases it for minutes would ignore a KeyboardInterrupt until
//! it ended.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::Arc;
use std::time::Duration;

use pyo3::prelude::*;

use crate::error::msg;

/// How often a waiting call looks for a pending signal.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Rows a stream compensates between two looks for a pending signal.
pub const ROWS_PER_CHUNK: usize = 1 << 16;

/// Run `work` on its own thread with the GIL released, looking for Ctrl-C (Python's signal
/// handlers, `Python::check_signals`) while it runs. A KeyboardInterrupt returns at once and
/// sets `cancel` (a fit stops at its next task); work without one finishes unobserved and its
/// result is dropped, so only work that writes nothing (a fit, a read, a simulation) may run
/// here.
pub fn interruptible<T: Send + 'static>(
    py: Python<'_>,
    cancel: Option<Arc<AtomicBool>>,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    watch(py, cancel, false, work)
}

/// Run `work` (given a cancel flag) on its own thread with the GIL released, as
/// [`interruptible`], for work that writes files: on Ctrl-C the flag is set and the call waits
/// for the work to stop (it looks at the flag between chunks) before it raises the
/// KeyboardInterrupt, so nothing is written after the call returned.
pub fn cancellable<T: Send + 'static>(
    py: Python<'_>,
    work: impl FnOnce(&AtomicBool) -> T + Send + 'static,
) -> PyResult<T> {
    let cancel = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&cancel);
    watch(py, Some(cancel), true, move || work(&flag))
}

/// `work` on its own thread, the GIL released while waiting for it; a pending signal sets
/// `cancel` and raises, after the work stopped when `await_stop`.
fn watch<T: Send + 'static>(
    py: Python<'_>,
    cancel: Option<Arc<AtomicBool>>,
    await_stop: bool,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    let (tx, rx) = mpsc::channel();
    std::thread::Builder::new()
        .name("fbg-work".into())
        .spawn(move || {
            // The receiver is gone after an interrupt that does not wait: nobody wants the
            // result then.
            let _ = tx.send(work());
        })
        .map_err(|e| msg(format!("cannot start the work thread: {e}")))?;
    let mut rx = rx;
    loop {
        // The receiver is not `Sync`: it goes into the GIL-free wait and comes back.
        let (got, back) = py.detach(move || (rx.recv_timeout(SIGNAL_POLL), rx));
        rx = back;
        match got {
            Ok(v) => return Ok(v),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(e) = py.check_signals() {
                    if let Some(c) = &cancel {
                        c.store(true, Ordering::Relaxed);
                    }
                    if await_stop {
                        // The work stops at its next chunk; its result (an interruption) is
                        // dropped.
                        let _ = py.detach(move || rx.recv());
                    }
                    return Err(e);
                }
            }
            Err(RecvTimeoutError::Disconnected) => return Err(msg("the work thread ended without a result")),
        }
    }
}
