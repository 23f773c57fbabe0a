//! Accuracy: our models against the scikit-learn black boxes and the per-sample oracle on the
//! `paper` and `harsh` presets, and the gain and band coverage of Model-H over 20 seeds.

use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

use fbg_report::FitBench;

use super::report::{
    Accuracy, Blackbox, Coverage, DayChannel, EnsembleBand, EnsembleChannel, Gain, HybridComparison, ModelHDefault,
    ModelHPaper, ModelRun, OracleFloor, PeerBlackbox, PresetRun, SeedRun,
};
use super::runner::{read_json, Runner, SimMeta};
use super::stats::{at, median};
use super::{coverage_run, holdout_errors_csv, preset_csv, COVERAGE_SEEDS};

/// Width of the lead-time bins of the ensemble band \[s\].
const ENSEMBLE_BIN_S: f64 = 7200.0;

impl SeedRun {
    fn of(seed: u64, v: &FitBench, command: String) -> SeedRun {
        SeedRun {
            seed,
            k: v.chosen.k,
            coverage_h: v.model_h.coverage.clone(),
            coverage_p: v.model_p.coverage.clone(),
            rmse_h: v.model_h.rmse.clone(),
            rmse_p: v.model_p.rmse.clone(),
            command,
            gb_hybrids: Vec::new(),
        }
    }
}

/// Every table of the part has a column per output: each fit must have the part's outputs.
fn same_outputs(channels: &mut Vec<String>, v: &FitBench, command: &str) -> Result<()> {
    if channels.is_empty() {
        channels.clone_from(&v.channels);
    } else if v.channels != *channels {
        bail!("`{command}` fitted the outputs {:?}, the part's first fit {:?}", v.channels, channels);
    }
    Ok(())
}

pub fn part(root: &Path, r: &Runner, peer_ok: bool) -> Result<Accuracy> {
    fs::create_dir_all(root.join("target/bench/holdout"))?;
    let mut presets = Vec::new();
    let mut coverage = Vec::new();
    let mut channels = Vec::new();
    for preset in ["paper", "harsh"] {
        let csv = preset_csv(preset, 7);
        let (def, c_def) = coverage_run(root, r, preset, 7)?;
        let (pap, c_pap): (FitBench, _) =
            r.trainer(&["bench-fit", "--data", &csv, "--select", "--features", "paper", "--repeats", "1", "--json"])?;
        same_outputs(&mut channels, &def, &c_def)?;
        same_outputs(&mut channels, &pap, &c_pap)?;
        let meta_path = csv.replace(".csv", ".meta.json");
        let meta: SimMeta = read_json(&root.join(&meta_path))?;
        let blackbox = if peer_ok {
            let (bb, c_bb): (PeerBlackbox, _) = r.peer(&["blackbox", "--data", &csv])?;
            Some(Blackbox { command: c_bb, peers: bb.peers })
        } else {
            None
        };
        if preset == "paper" {
            let mut run = SeedRun::of(7, &def, c_def.clone());
            run.gb_hybrids = blackbox.iter().flat_map(|b| &b.peers).filter(|p| p.is_gb_hybrid()).cloned().collect();
            coverage.push(run);
        }
        presets.push(PresetRun {
            preset: preset.into(),
            seed: 7,
            data: csv.clone(),
            model_p: ModelRun { rmse: def.model_p.rmse, bytes: def.model_p.blob_bytes, command: c_def.clone() },
            model_h_default: ModelHDefault {
                run: ModelRun { rmse: def.model_h.rmse, bytes: def.model_h.blob_bytes, command: c_def },
                chosen: def.chosen,
                coverage: def.model_h.coverage,
                parity: def.parity,
            },
            model_h_paper: ModelHPaper {
                run: ModelRun { rmse: pap.model_h.rmse, bytes: pap.model_h.blob_bytes, command: c_pap },
                chosen: pap.chosen,
            },
            oracle_floor: OracleFloor {
                rmse: meta.oracle_floor_holdout,
                source: format!("{meta_path} (written by the simulate command)"),
            },
            blackbox,
        });
    }
    for &seed in &COVERAGE_SEEDS[1..] {
        let (v, c) = coverage_run(root, r, "paper", seed)?;
        same_outputs(&mut channels, &v, &c)?;
        let mut run = SeedRun::of(seed, &v, c);
        if peer_ok {
            let (h, _): (PeerBlackbox, _) = r.peer(&["hybrids", "--data", &preset_csv("paper", seed)])?;
            run.gb_hybrids = h.peers;
        }
        coverage.push(run);
    }
    let nc = channels.len();
    let gb_hybrids_paper = hybrid_comparisons(&coverage, nc);
    // Gain of Model-H over Model-P per seed and channel [%].
    let gains: Vec<Vec<f64>> = coverage.iter().map(|s| (0..nc).map(|c| s.gain_pct(c)).collect()).collect();
    let mean_pct = (0..nc).map(|c| gains.iter().map(|g| g[c]).sum::<f64>() / gains.len().max(1) as f64).collect();
    let min_pct = (0..nc).map(|c| gains.iter().map(|g| g[c]).fold(f64::INFINITY, f64::min)).collect();
    let seeds_all_channels_25 = gains.iter().filter(|g| g.iter().all(|&v| v >= 25.0)).count();
    let per = |c: usize| -> Vec<f64> { coverage.iter().map(|s| at(&s.coverage_h, c)).collect() };
    let mean_h = (0..nc).map(|c| per(c).iter().sum::<f64>() / coverage.len() as f64).collect();
    let median_h = (0..nc).map(|c| median(&per(c))).collect();
    let seeds_within_95_pm_2 = (0..nc).map(|c| per(c).iter().filter(|v| (*v - 0.95).abs() <= 0.02).count()).collect();
    let files: Vec<PathBuf> = COVERAGE_SEEDS.iter().map(|&s| root.join(holdout_errors_csv("paper", s))).collect();
    let holdouts = read_holdouts(&files, nc)?;
    let ensemble_band = Some(ensemble_band_coverage(&holdouts, nc));
    let by_day = Some(by_day(&holdouts, nc));
    Ok(Accuracy {
        channels,
        presets,
        coverage_paper: Coverage { per_seed: coverage, mean_h, median_h, seeds_within_95_pm_2, ensemble_band, by_day },
        gain_paper: Gain { per_seed: gains, mean_pct, min_pct, seeds_all_channels_25 },
        gb_hybrids_paper,
    })
}

/// Model-H against each gradient-boosting hybrid, over the seeds that have it.
fn hybrid_comparisons(runs: &[SeedRun], nc: usize) -> Vec<HybridComparison> {
    let mut inputs: Vec<(String, Option<u64>)> = Vec::new();
    for p in runs.iter().flat_map(|r| &r.gb_hybrids) {
        if !inputs.iter().any(|(i, _)| *i == p.inputs) {
            inputs.push((p.inputs.clone(), p.n_inputs));
        }
    }
    inputs
        .into_iter()
        .map(|(name, n_inputs)| {
            let pairs: Vec<(&[f64], &[f64])> = runs
                .iter()
                .filter_map(|r| r.gb_hybrids.iter().find(|p| p.inputs == name).map(|p| (&r.rmse_h[..], &p.rmse[..])))
                .collect();
            let n = pairs.len().max(1) as f64;
            HybridComparison {
                inputs: name,
                n_inputs,
                seeds: pairs.len(),
                mean_rmse_h: (0..nc).map(|c| pairs.iter().map(|p| at(p.0, c)).sum::<f64>() / n).collect(),
                mean_rmse_peer: (0..nc).map(|c| pairs.iter().map(|p| at(p.1, c)).sum::<f64>() / n).collect(),
                seeds_ahead: (0..nc).map(|c| pairs.iter().filter(|p| at(p.0, c) < at(p.1, c)).count()).collect(),
            }
        })
        .collect()
}

/// The reference for per-seed band coverage: a band that depends on the lead time alone, set to
/// the 95 % quantile of |error| over *all* seeds' hold-outs in each 2-hour lead bin (it reads the
/// hold-outs, so no model can have it). Its per-seed coverage shows how much of the seed-to-seed
/// spread comes from the hold-out week itself (one drift path per seed) rather than from the
/// band a model estimated from its own calibration batch.
fn ensemble_band_coverage(holdouts: &[Holdout], nc: usize) -> EnsembleBand {
    // Per seed: (lead from the first hold-out sample [s], |error| per channel).
    let runs: Vec<Vec<(f64, Vec<f64>)>> = holdouts
        .iter()
        .map(|rows| rows.iter().map(|(t, v)| (*t, v[..nc].iter().map(|e| e.abs()).collect())).collect())
        .collect();
    let bin = |lead: f64| (lead / ENSEMBLE_BIN_S).max(0.0) as usize;
    let n_bins = runs.iter().flatten().map(|r| bin(r.0) + 1).max().unwrap_or(0);
    let mut per_channel = Vec::new();
    for c in 0..nc {
        let mut pooled: Vec<Vec<f64>> = vec![Vec::new(); n_bins];
        for r in runs.iter().flatten() {
            pooled[bin(r.0)].push(r.1[c]);
        }
        let q95: Vec<f64> = pooled
            .iter_mut()
            .map(|v| {
                v.sort_by(f64::total_cmp);
                v.get(((v.len() as f64) * 0.95) as usize).or(v.last()).copied().unwrap_or(f64::INFINITY)
            })
            .collect();
        let cov: Vec<f64> = runs
            .iter()
            .map(|run| run.iter().filter(|r| r.1[c] <= q95[bin(r.0)]).count() as f64 / run.len().max(1) as f64)
            .collect();
        per_channel.push(EnsembleChannel {
            mean: cov.iter().sum::<f64>() / cov.len().max(1) as f64,
            seeds_within_95_pm_2: cov.iter().filter(|v| (*v - 0.95).abs() <= 0.02).count(),
            min: cov.iter().copied().fold(f64::INFINITY, f64::min),
            per_seed: cov,
        });
    }
    EnsembleBand { bin_seconds: ENSEMBLE_BIN_S, channels: per_channel }
}

/// One seed's hold-out (`bench-fit --holdout-errors`): per sample, the lead from the first
/// hold-out sample \[s\] and the file's other columns (Model-H's errors and bands, then
/// Model-P's when the file has them).
type Holdout = Vec<(f64, Vec<f64>)>;

fn read_holdouts(files: &[PathBuf], nc: usize) -> Result<Vec<Holdout>> {
    let mut runs = Vec::new();
    for f in files {
        let text = fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
        let mut rows = Vec::new();
        for (n, line) in text.lines().enumerate().skip(1) {
            let v: Vec<f64> = line
                .split(',')
                .map(str::parse)
                .collect::<Result<_, _>>()
                .with_context(|| format!("{}:{}: not a number", f.display(), n + 1))?;
            if v.len() < 1 + 2 * nc {
                bail!("{}:{}: expected {} columns, found {}", f.display(), n + 1, 1 + 2 * nc, v.len());
            }
            rows.push((v[0], v[1..].to_vec()));
        }
        let t0 = rows.first().map(|r| r.0).unwrap_or(0.0);
        runs.push(rows.into_iter().map(|(t, v)| (t - t0, v)).collect());
    }
    Ok(runs)
}

/// Per channel and whole day after the first hold-out sample, the seeds pooled: the fraction of Model-H's and of
/// Model-P's errors inside their bands, and Model-H's mean squared error over Model-P's (NaN
/// where a file has no Model-P columns).
fn by_day(holdouts: &[Holdout], nc: usize) -> Vec<DayChannel> {
    let day = |lead: f64| (lead / 86_400.0).max(0.0) as usize;
    let n_days = holdouts.iter().flatten().map(|r| day(r.0) + 1).max().unwrap_or(0);
    (0..nc)
        .map(|c| {
            // Per day: samples, inside H's band, inside P's band, Σe_H², Σe_P².
            let mut acc = vec![[0.0f64; 5]; n_days];
            for (lead, v) in holdouts.iter().flatten() {
                let a = &mut acc[day(*lead)];
                let (eh, bh) = (v[c], v[nc + c]);
                let (ep, bp) =
                    (v.get(2 * nc + c).copied().unwrap_or(f64::NAN), v.get(3 * nc + c).copied().unwrap_or(f64::NAN));
                a[0] += 1.0;
                a[1] += f64::from(u8::from(eh.abs() <= bh));
                a[2] += if bp.is_nan() { f64::NAN } else { f64::from(u8::from(ep.abs() <= bp)) };
                a[3] += eh * eh;
                a[4] += ep * ep;
            }
            DayChannel {
                coverage_h: acc.iter().map(|a| a[1] / a[0]).collect(),
                coverage_p: acc.iter().map(|a| a[2] / a[0]).collect(),
                mse_ratio: acc.iter().map(|a| a[3] / a[4]).collect(),
            }
        })
        .collect()
}
