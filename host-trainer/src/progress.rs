//! Progress of long operations (cross-validation, evaluation, compensation, streaming, fleets),
//! reported to whatever the program installs, as the `log` crate's facade does for messages.
//!
//! The library draws nothing itself: an operation asked to show progress opens a [`Bar`],
//! which is inert unless a [`Progress`] reporter was installed with [`set_reporter`]. The
//! `fbg-trainer` binary installs one that draws terminal bars; tests and other callers of the
//! library see nothing.

use std::sync::OnceLock;
use std::time::Duration;

/// Where progress goes: starts one [`Task`] per operation.
pub trait Progress: Send + Sync {
    /// An operation of `len` steps, labelled `what`, has started.
    fn start(&self, what: &str, len: u64) -> Box<dyn Task>;
}

/// One operation's progress. Steps may be counted from several threads at once.
pub trait Task: Send + Sync {
    /// `delta` more steps are done.
    fn inc(&self, delta: u64);
    /// `pos` steps are done.
    fn set_position(&self, pos: u64);
    /// The part of the operation now running.
    fn set_message(&self, what: &str);
    /// Redraw every `interval` (the elapsed time) while steps take long.
    fn steady_tick(&self, interval: Duration);
    /// Hide the progress while `f` runs (it writes to the terminal, or runs operations that
    /// report their own progress).
    fn suspend(&self, f: &mut dyn FnMut());
    /// The operation is over: remove its progress from view (called again on drop: a second
    /// call does nothing).
    fn finish(&self);
}

static REPORTER: OnceLock<Box<dyn Progress>> = OnceLock::new();

/// Install the reporter of this process (once; a second one is handed back).
pub fn set_reporter(reporter: Box<dyn Progress>) -> Result<(), Box<dyn Progress>> {
    REPORTER.set(reporter)
}

/// The progress of one operation: inert when not `enabled` or when no reporter is installed.
/// Dropped unfinished (an error ended the operation), it is finished.
#[derive(Default)]
pub struct Bar {
    task: Option<Box<dyn Task>>,
}

/// The progress of an operation of `len` steps labelled `what`, shown when `enabled` (and the
/// program installed a reporter).
pub fn bar(enabled: bool, len: u64, what: &str) -> Bar {
    let task = if enabled { REPORTER.get().map(|r| r.start(what, len)) } else { None };
    Bar { task }
}

impl Bar {
    /// A bar that shows nothing.
    pub fn hidden() -> Bar {
        Bar::default()
    }

    /// `delta` more steps are done.
    pub fn inc(&self, delta: u64) {
        if let Some(t) = &self.task {
            t.inc(delta);
        }
    }

    /// `pos` steps are done.
    pub fn set_position(&self, pos: u64) {
        if let Some(t) = &self.task {
            t.set_position(pos);
        }
    }

    /// The part of the operation now running.
    pub fn set_message(&self, what: &str) {
        if let Some(t) = &self.task {
            t.set_message(what);
        }
    }

    /// Redraw every `interval` while steps take long.
    pub fn steady_tick(&self, interval: Duration) {
        if let Some(t) = &self.task {
            t.steady_tick(interval);
        }
    }

    /// Run `f` with the progress hidden.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        let Some(t) = &self.task else { return f() };
        let mut f = Some(f);
        let mut out = None;
        t.suspend(&mut || {
            if let Some(f) = f.take() {
                out = Some(f());
            }
        });
        match (out, f) {
            (Some(r), _) => r,
            // A reporter that did not run the closure: run it here.
            (None, Some(f)) => f(),
            (None, None) => unreachable!("the closure ran but left no result"),
        }
    }

    /// The operation is over.
    pub fn finish_and_clear(&self) {
        if let Some(t) = &self.task {
            t.finish();
        }
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        self.finish_and_clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::sync::Arc;

    /// Counts the steps and finishes of the tasks labelled `probe` (other tests of this
    /// process may open bars of their own once it is installed).
    struct Probe(Arc<[AtomicU64; 3]>);
    struct ProbeTask(Arc<[AtomicU64; 3]>);

    impl Progress for Probe {
        fn start(&self, what: &str, _len: u64) -> Box<dyn Task> {
            if what == "probe" {
                self.0[0].fetch_add(1, Ordering::SeqCst);
                Box::new(ProbeTask(self.0.clone()))
            } else {
                Box::new(ProbeTask(Arc::new(Default::default())))
            }
        }
    }

    impl Task for ProbeTask {
        fn inc(&self, delta: u64) {
            self.0[1].fetch_add(delta, Ordering::SeqCst);
        }
        fn set_position(&self, pos: u64) {
            self.0[1].store(pos, Ordering::SeqCst);
        }
        fn set_message(&self, _: &str) {}
        fn steady_tick(&self, _: Duration) {}
        fn suspend(&self, f: &mut dyn FnMut()) {
            f();
        }
        fn finish(&self) {
            self.0[2].fetch_add(1, Ordering::SeqCst);
        }
    }

    #[test]
    fn an_installed_reporter_sees_enabled_bars_only() {
        let counts: Arc<[AtomicU64; 3]> = Arc::new(Default::default());
        assert!(set_reporter(Box::new(Probe(counts.clone()))).is_ok());
        drop(bar(false, 3, "probe"));
        assert_eq!(counts[0].load(Ordering::SeqCst), 0, "a bar not enabled starts nothing");
        {
            let b = bar(true, 3, "probe");
            b.inc(2);
            assert_eq!(b.suspend(|| 7), 7);
        }
        let got: Vec<u64> = counts.iter().map(|c| c.load(Ordering::SeqCst)).collect();
        assert_eq!(got, [1, 2, 1], "started once, two steps, finished on drop");
    }

    #[test]
    fn a_bar_runs_what_it_suspends() {
        let b = bar(true, 10, "test");
        b.inc(1);
        b.set_position(5);
        assert_eq!(b.suspend(|| 42), 42);
        assert_eq!(Bar::hidden().suspend(|| "x"), "x");
    }
}
