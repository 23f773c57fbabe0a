//! Host inference throughput: the criterion bench of `fbg-shared` (`shared/benches/step.rs`).

use std::path::Path;

use anyhow::Result;

use super::report::{Inference, InferenceRow};
use super::runner::{criterion, criterion_median};
use super::{Opts, STEP_BATCH};

pub fn part(root: &Path, opts: &Opts) -> Result<Inference> {
    let command = criterion(root, opts.quick, "step")?;
    let mut rows = Vec::new();
    for prec in ["f32", "f64"] {
        for k in [16, 32, 64] {
            let (ns_per_step, ci95_ns_per_step) = criterion_median(root, &format!("step_{prec}/{k}"), STEP_BATCH)?;
            rows.push(InferenceRow {
                precision: prec.into(),
                k,
                ns_per_step,
                samples_per_second: 1e9 / ns_per_step,
                ci95_ns_per_step,
            });
        }
    }
    Ok(Inference {
        command,
        samples_per_iteration: STEP_BATCH,
        criterion_samples: 100,
        statistic: "criterion median of 100 samples (each many iterations of 1024 steps)".into(),
        rows,
    })
}
