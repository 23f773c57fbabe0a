//! Progress bars on the terminal (indicatif) for the library's progress reports
//! ([`fbg_trainer::progress`]): drawn on stderr when it is a terminal, hidden otherwise.

use std::io::IsTerminal;
use std::time::Duration;

use fbg_trainer::progress::{Progress, Task};
use indicatif::{ProgressBar, ProgressStyle};

/// Bars on stderr.
pub struct Terminal;

impl Progress for Terminal {
    fn start(&self, what: &str, len: u64) -> Box<dyn Task> {
        if !std::io::stderr().is_terminal() {
            return Box::new(Bar(ProgressBar::hidden()));
        }
        let bar = ProgressBar::new(len);
        if let Ok(style) = ProgressStyle::with_template("{msg:>18} [{bar:40}] {pos}/{len} {elapsed}") {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(what.to_string());
        Box::new(Bar(bar))
    }
}

struct Bar(ProgressBar);

impl Task for Bar {
    fn inc(&self, delta: u64) {
        self.0.inc(delta);
    }
    fn set_position(&self, pos: u64) {
        self.0.set_position(pos);
    }
    fn set_message(&self, what: &str) {
        self.0.set_message(what.to_string());
    }
    fn steady_tick(&self, interval: Duration) {
        self.0.enable_steady_tick(interval);
    }
    fn suspend(&self, f: &mut dyn FnMut()) {
        self.0.suspend(f);
    }
    fn finish(&self) {
        if !self.0.is_finished() {
            self.0.finish_and_clear();
        }
    }
}
