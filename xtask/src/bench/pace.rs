//! Static fidelity and pace (DESIGN §4, §5): `train` and `evaluate --quick` through the CLI, as a
//! user runs them, on every coverage seed of the `paper` preset (the pace study of `evaluate`: the
//! calibration's installation at ×¼, ×4, ×8, all measurands and each alone, and on a steps
//! record, with the settled slopes) and of the `field` preset (other physics per effect).

use std::fs;
use std::path::Path;

use anyhow::{bail, Result};

use fbg_report::{Metrics, ModelEval, PaceRow};

use super::report::{at_most, EvalRun, FieldBench, PaceBench, PaceSummary};
use super::runner::Runner;
use super::stats::{at, fold_nan, mean};
use super::{drift_statement, preset_csv, COVERAGE_SEEDS};

/// Band coverage Model-H must reach on every channel of every pace record of every seed
/// (fraction; DESIGN §5: no seed below 85 %).
pub const PACE_MIN_COVERAGE: f64 = 0.85;
/// Largest |settled slope − 1| on the steps record, both models, every measurand.
pub const SLOPE_TOL: f64 = 0.01;

/// Where `train` writes the model of `preset` and `seed` (Model-P beside it, `-p.fbgm`).
fn model_path(preset: &str, seed: u64) -> String {
    format!("target/bench/models/{preset}-s{seed}.fbgm")
}

/// `train`, then `evaluate --quick` (no refit; the pace study re-simulates the installation from
/// the CSV's `.meta.json`) on the simulated dataset of `preset` and `seed`.
fn train_eval(root: &Path, r: &Runner, preset: &str, seed: u64) -> Result<EvalRun> {
    let csv = preset_csv(preset, seed);
    let model = model_path(preset, seed);
    let mut args: Vec<String> = ["train", "--data", &csv, "--out", &model, "--json"].map(String::from).to_vec();
    args.extend(drift_statement(root, &csv)?);
    let (_, train_command): (serde_json::Value, _) = r.trainer(&args)?;
    let (e, evaluate_command): (Metrics, _) =
        r.trainer(&["evaluate", "--quick", "--data", &csv, "--model", &model, "--json"])?;
    if e.seed != seed {
        bail!("`{evaluate_command}` reports seed {}, expected {seed}", e.seed);
    }
    let col =
        |m: &ModelEval, f: fn(&fbg_report::ChannelMetrics) -> f64| -> Vec<f64> { m.channels.iter().map(f).collect() };
    let (p, h) = (&e.table2.model_p, &e.table2.model_h);
    Ok(EvalRun {
        seed,
        channels: e.channels,
        rmse_p: col(p, |c| c.rmse),
        rmse_h: col(h, |c| c.rmse),
        coverage_p: col(p, |c| c.coverage),
        coverage_h: col(h, |c| c.coverage),
        static_fidelity: e.static_fidelity,
        pace: e.pace,
        train_command,
        evaluate_command,
    })
}

/// Both studies: the `paper` preset with every seed's pace study kept, the `field` preset with
/// its pace studies summarised only.
pub fn part(root: &Path, r: &Runner) -> Result<(PaceBench, FieldBench)> {
    fs::create_dir_all(root.join("target/bench/models"))?;
    let runs = |preset: &str| -> Result<Vec<EvalRun>> {
        COVERAGE_SEEDS.iter().map(|&s| train_eval(root, r, preset, s)).collect()
    };
    let paper = runs("paper")?;
    let pace_paper = PaceBench {
        preset: "paper".into(),
        summary: summarise(&paper),
        seeds_pace_targets: seeds_pace_targets(&paper),
        runs: paper,
    };
    let mut field = runs("field")?;
    let pace_summary = summarise(&field);
    let field_pace_targets = seeds_pace_targets(&field);
    for run in &mut field {
        run.pace = None;
    }
    Ok((pace_paper, field_bench(field, pace_summary, field_pace_targets)))
}

/// Every record meets both pace targets: Model-H's RMSE within the record's ratio of Model-P's
/// (1.01, 1.05 at rest) and its band coverage ≥ 85 % on every channel (false without records).
pub fn pace_targets_met(rows: &[PaceRow]) -> bool {
    !rows.is_empty() && rows.iter().all(|r| r.h_within_p() && r.coverage_h_at_least(PACE_MIN_COVERAGE))
}

fn seeds_pace_targets(runs: &[EvalRun]) -> usize {
    runs.iter().filter(|r| r.pace.as_ref().is_some_and(|p| pace_targets_met(&p.rows))).count()
}

/// Per record of the pace study (in the order of the first seed's), over the seeds.
pub fn summarise(runs: &[EvalRun]) -> Vec<PaceSummary> {
    let mut labels: Vec<&str> = Vec::new();
    for row in runs.iter().flat_map(|r| r.pace.iter().flat_map(|p| &p.rows)) {
        if !labels.contains(&row.label.as_str()) {
            labels.push(&row.label);
        }
    }
    labels
        .into_iter()
        .map(|label| {
            let rows: Vec<&PaceRow> =
                runs.iter().filter_map(|r| r.pace.as_ref()?.rows.iter().find(|x| x.label == label)).collect();
            let nc = rows.iter().map(|r| r.rmse_p.len()).max().unwrap_or(0);
            let per = |f: &dyn Fn(&PaceRow, usize) -> f64, agg: &dyn Fn(&mut dyn Iterator<Item = f64>) -> f64| {
                (0..nc).map(|c| agg(&mut rows.iter().map(|r| f(r, c)))).collect::<Vec<f64>>()
            };
            let min = |it: &mut dyn Iterator<Item = f64>| fold_nan(it, f64::min);
            let max = |it: &mut dyn Iterator<Item = f64>| fold_nan(it, f64::max);
            let avg = |it: &mut dyn Iterator<Item = f64>| mean(it);
            let steps = rows.iter().any(|r| r.is_steps());
            let dev = |v: &[f64], c: usize| (at(v, c) - 1.0).abs();
            PaceSummary {
                label: label.to_string(),
                seeds: rows.len(),
                seeds_h_le_p: rows.iter().filter(|r| r.h_within_p()).count(),
                seeds_coverage_h_90: rows.iter().filter(|r| r.coverage_h_at_least(PACE_MIN_COVERAGE)).count(),
                mean_gain_pct: per(&|r, c| r.gain_pct(c), &avg),
                worst_gain_pct: per(&|r, c| r.gain_pct(c), &min),
                min_coverage_h: per(&|r, c| at(&r.coverage_h, c), &min),
                mean_coverage_h: per(&|r, c| at(&r.coverage_h, c), &avg),
                max_slope_dev_p: if steps { per(&|r, c| dev(&r.slope_p, c), &max) } else { Vec::new() },
                max_slope_dev_h: if steps { per(&|r, c| dev(&r.slope_h, c), &max) } else { Vec::new() },
                seeds_slopes_within_1pct: rows.iter().filter(|r| r.slopes_within(SLOPE_TOL)).count(),
            }
        })
        .collect()
}

/// The `field` figures over the seeds.
fn field_bench(runs: Vec<EvalRun>, pace_summary: Vec<PaceSummary>, seeds_pace_targets: usize) -> FieldBench {
    let nc = runs.iter().map(|r| r.rmse_p.len()).max().unwrap_or(0);
    let per = |f: &dyn Fn(&EvalRun, usize) -> f64, agg: fn(&mut dyn Iterator<Item = f64>) -> f64| -> Vec<f64> {
        (0..nc).map(|c| agg(&mut runs.iter().map(|r| f(r, c)))).collect()
    };
    // Worse: not at most Model-P's (a missing figure counts as worse).
    let worse = |r: &EvalRun, c: usize| !at_most(at(&r.rmse_h, c), at(&r.rmse_p, c));
    FieldBench {
        preset: "field".into(),
        mean_gain_pct: per(&|r, c| r.gain_pct(c), |it| mean(it)),
        min_gain_pct: per(&|r, c| r.gain_pct(c), |it| fold_nan(it, f64::min)),
        seeds_h_worse: (0..nc).map(|c| runs.iter().filter(|r| worse(r, c)).count()).collect(),
        seeds_h_worse_any: runs.iter().filter(|r| (0..nc).any(|c| worse(r, c))).count(),
        mean_coverage_h: per(&|r, c| at(&r.coverage_h, c), |it| mean(it)),
        mean_coverage_p: per(&|r, c| at(&r.coverage_p, c), |it| mean(it)),
        pace_summary,
        seeds_pace_targets,
        runs,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fbg_report::PaceStudy;

    fn row(label: &str, p: [f64; 3], h: [f64; 3], cov_h: [f64; 3], slopes: Option<([f64; 3], [f64; 3])>) -> PaceRow {
        PaceRow {
            label: label.into(),
            factor: 1.0,
            only: None,
            samples: 10,
            rmse_p: p.to_vec(),
            rmse_h: h.to_vec(),
            coverage_p: vec![0.95; 3],
            coverage_h: cov_h.to_vec(),
            slope_p: slopes.map_or(Vec::new(), |s| s.0.to_vec()),
            slope_h: slopes.map_or(Vec::new(), |s| s.1.to_vec()),
            holds: if slopes.is_some() { 30 } else { 0 },
        }
    }

    fn run(seed: u64, rows: Vec<PaceRow>) -> EvalRun {
        EvalRun {
            seed,
            channels: vec!["T".into(), "strain".into(), "p".into()],
            rmse_p: vec![1.0; 3],
            rmse_h: vec![0.5; 3],
            coverage_p: vec![0.95; 3],
            coverage_h: vec![0.95; 3],
            static_fidelity: None,
            pace: Some(PaceStudy { scenario: "paper".into(), seed, rows, glitch: Vec::new() }),
            train_command: String::new(),
            evaluate_command: String::new(),
        }
    }

    #[test]
    fn summary_counts_seeds_and_keeps_the_worst() {
        let good = ([1.0, 1.005, 0.995], [1.002, 0.999, 1.0]);
        let bad = ([1.0, 1.0, 0.98], [1.0, 1.0, 1.0]);
        let runs = vec![
            run(
                7,
                vec![
                    row("×4", [1.0, 2.0, 3.0], [0.5, 1.0, 3.0], [0.95, 0.91, 0.9], None),
                    row("steps", [1.0; 3], [0.9; 3], [0.95; 3], Some(good)),
                ],
            ),
            run(
                8,
                vec![
                    row("×4", [1.0, 2.0, 3.0], [0.5, 2.2, f64::NAN], [0.95, 0.80, 0.95], None),
                    row("steps", [1.0; 3], [0.9; 3], [0.95; 3], Some(bad)),
                ],
            ),
        ];
        let s = summarise(&runs);
        assert_eq!(s.len(), 2);
        let x4 = &s[0];
        assert_eq!((x4.label.as_str(), x4.seeds, x4.seeds_h_le_p, x4.seeds_coverage_h_90), ("×4", 2, 1, 1));
        assert_eq!(x4.worst_gain_pct[0], 50.0);
        assert!((x4.worst_gain_pct[1] + 10.0).abs() < 1e-9);
        assert!(x4.worst_gain_pct[2].is_nan(), "a missing figure is not hidden by the minimum");
        assert_eq!(x4.min_coverage_h[1], 0.80);
        assert!(x4.max_slope_dev_p.is_empty());
        let st = &s[1];
        assert_eq!(st.seeds_slopes_within_1pct, 1);
        assert!((st.max_slope_dev_p[2] - 0.02).abs() < 1e-12);
        assert!(pace_targets_met(&runs[0].pace.as_ref().unwrap().rows));
        assert!(!pace_targets_met(&runs[1].pace.as_ref().unwrap().rows));
        assert!(!pace_targets_met(&[]));
        assert_eq!(seeds_pace_targets(&runs), 1);
    }

    #[test]
    fn field_counts_worse_seeds_per_channel() {
        let mut a = run(7, Vec::new());
        a.rmse_h = vec![0.5, 1.1, 0.9];
        let b = run(8, Vec::new());
        let f = field_bench(vec![a, b], Vec::new(), 0);
        assert_eq!(f.seeds_h_worse, vec![0, 1, 0]);
        assert_eq!(f.seeds_h_worse_any, 1);
        assert!((f.mean_gain_pct[1] - 20.0).abs() < 1e-9);
        assert!((f.min_gain_pct[1] + 10.0).abs() < 1e-9);
        assert_eq!(f.mean_coverage_h, vec![0.95; 3]);
    }
}
