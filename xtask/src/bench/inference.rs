//! Host inference throughput: the criterion bench of `fbg-shared` (`shared/benches/step.rs`).

use std::path::Path;

use anyhow::Result;

use super::report::{Inference, InferenceRow};
use super::runner::{read_json, CriterionEstimates};
use super::{Opts, STEP_BATCH};
use crate::cmd::{cargo, run};

pub fn part(root: &Path, opts: &Opts) -> Result<Inference> {
    let mut args = vec!["bench", "--locked", "-p", "fbg-shared", "--bench", "step"];
    if opts.quick {
        args.extend(["--", "--warm-up-time", "1", "--measurement-time", "2"]);
    }
    run(cargo().current_dir(root).args(&args))?;
    let mut rows = Vec::new();
    for prec in ["f32", "f64"] {
        for k in [16, 32, 64] {
            let p = root.join(format!("target/criterion/step_{prec}/{k}/new/estimates.json"));
            let m = read_json::<CriterionEstimates>(&p)?.median;
            let ns_step = m.point_estimate / STEP_BATCH;
            rows.push(InferenceRow {
                precision: prec.into(),
                k,
                ns_per_step: ns_step,
                samples_per_second: 1e9 / ns_step,
                ci95_ns_per_step: [
                    m.confidence_interval.lower_bound / STEP_BATCH,
                    m.confidence_interval.upper_bound / STEP_BATCH,
                ],
            });
        }
    }
    Ok(Inference {
        command: format!("cargo {}", args.join(" ")),
        samples_per_iteration: STEP_BATCH,
        criterion_samples: 100,
        statistic: "criterion median of 100 samples (each many iterations of 1024 steps)".into(),
        rows,
    })
}
