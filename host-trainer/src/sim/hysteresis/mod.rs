//! The interrogator's hysteresis on each grating's physical shift: three models, chosen by
//! `hysteresis.model` (DESIGN §3). Each returns its *contribution* (reading − shift) \[pm\].
//!
//! - [`eq9_play`]: the paper's Eq. 9 followed by a play operator (the default);
//! - [`bouc_wen`]: a rate-independent Bouc–Wen model driven by the shift's increments;
//! - [`preisach`]: a discrete Preisach sum of relays.

pub mod bouc_wen;
pub(crate) mod eq9_play;
pub mod preisach;

use crate::sim::scenario::{Hysteresis, HysteresisModel};

/// Hysteresis contribution \[pm\] of the configured model on the shift series `x` \[pm\].
pub fn contribution(x: &[f64], cfg: &Hysteresis) -> Vec<f64> {
    match cfg.model {
        HysteresisModel::Eq9Play => eq9_play::contribution(x, cfg),
        HysteresisModel::BoucWen => bouc_wen::contribution(x, &cfg.bouc_wen),
        HysteresisModel::Preisach => preisach::contribution(x, &cfg.preisach),
    }
}

/// Test paths shared by the models' tests.
#[cfg(test)]
pub(crate) mod paths {
    /// A triangle wave between −`amp` and +`amp` \[pm\] for `cycles` cycles, starting at 0 and
    /// rising, sampled every `step` \[pm\] of travel (`amp` a multiple of `step`): a slower pace
    /// of the same path is the same call with a smaller step.
    pub(crate) fn triangle(amp: f64, cycles: usize, step: f64) -> Vec<f64> {
        let per_quarter = (amp / step).round() as usize;
        let mut x = vec![0.0];
        for _ in 0..cycles {
            for (from, to) in [(0.0, amp), (amp, -amp), (-amp, 0.0)] {
                let n = per_quarter * if from == amp { 2 } else { 1 };
                for k in 1..=n {
                    x.push(from + (to - from) * k as f64 / n as f64);
                }
            }
        }
        x
    }

    /// The outputs `y` at the rising and at the falling crossing of the last cycle through
    /// x = `at` (the path from [`triangle`]).
    pub fn branches(x: &[f64], y: &[f64], at: f64) -> (f64, f64) {
        let n = x.len();
        let last = &x[n - n / 3..];
        let off = n - last.len();
        let mut rise = f64::NAN;
        let mut fall = f64::NAN;
        for i in 1..last.len() {
            if last[i] == at || (last[i - 1] - at) * (last[i] - at) < 0.0 {
                if last[i] > last[i - 1] {
                    rise = y[off + i];
                } else {
                    fall = y[off + i];
                }
            }
        }
        (rise, fall)
    }
}
