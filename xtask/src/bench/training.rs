//! Host training time: our fit (fixed and with selection) against the scikit-learn peer at
//! three dataset sizes, and `train` end to end.

use std::fs;
use std::path::Path;

use anyhow::{bail, Result};

use fbg_report::FitBench;

use super::report::{
    FitRun, FixedConfig, FixedDefault, FixedMemory, FixedPaper, GrowthExponent, OursFixed, OursSelect, PeerFixed,
    PeerLatch, PeerMemory, SizeRun, TrainEndToEnd, Training,
};
use super::runner::{PeerFit, Runner, TrainOut};
use super::stats::{log_slope, median};
use super::{data, rel, Opts, SIZES};

/// Our fit as a row of the training tables, with the command that printed it.
fn ours(b: &FitBench, command: String) -> FitRun {
    FitRun {
        command,
        fit_seconds: b.fit_seconds.clone(),
        median: b.fit_seconds_median,
        rmse_p: b.model_p.rmse.clone(),
        rmse_h: b.model_h.rmse.clone(),
    }
}

impl PeerFit {
    fn run(&self, command: String, fit_seconds: Vec<f64>) -> FitRun {
        FitRun {
            command,
            median: median(&fit_seconds),
            fit_seconds,
            rmse_p: self.model_p.rmse.clone(),
            rmse_h: self.model_h.rmse.clone(),
        }
    }
}

/// The commands of one dataset size: its CSV, repeats per process and rounds.
struct Size {
    csv: String,
    reps: String,
    rounds: usize,
    peer_ok: bool,
}

impl Size {
    /// `bench-fit --fixed` with feature set `fs`.
    fn fixed<'a>(&'a self, fs: &'a str) -> Vec<&'a str> {
        vec!["bench-fit", "--data", &self.csv, "--fixed", "--feature-set", fs, "--repeats", &self.reps, "--json"]
    }

    /// The scikit-learn peer's fit with feature set `fs` (our k-means subsample).
    fn peer<'a>(&'a self, fs: &'a str) -> Vec<&'a str> {
        vec!["fit", "--data", &self.csv, "--features", fs, "--repeats", &self.reps]
    }

    /// The peer as a notebook writes it (k-means over every row).
    fn notebook(&self) -> [&str; 9] {
        ["fit", "--data", &self.csv, "--features", "paper", "--kmeans", "all", "--repeats", &self.reps]
    }
}

pub fn part(root: &Path, r: &Runner, opts: &Opts, peer_ok: bool) -> Result<Training> {
    let rounds = if opts.quick { 1 } else { 3 };
    let mut sizes = Vec::new();
    let mut channels = Vec::new();
    for (n, _) in SIZES {
        let reps = if opts.quick {
            1
        } else if n >= 1_000_000 {
            3
        } else {
            5
        };
        let size = Size { csv: data(n), reps: reps.to_string(), rounds, peer_ok };
        let (run, outputs) = size_run(root, r, n, reps, &size)?;
        if !channels.is_empty() && outputs != channels {
            bail!("the fits at {n} samples have the outputs {outputs:?}, those before {channels:?}");
        }
        sizes.push(run);
        channels = outputs;
    }
    let ns: Vec<f64> = SIZES.iter().map(|(n, _)| *n as f64).collect();
    let slope = |time: &dyn Fn(&SizeRun) -> f64| {
        let t: Vec<f64> = sizes.iter().map(time).collect();
        if t.iter().all(|v| v.is_finite() && *v > 0.0) {
            log_slope(&ns, &t)
        } else {
            f64::NAN
        }
    };
    let growth_exponent = GrowthExponent {
        ours_select: slope(&|s| s.ours_select.fit.median),
        ours_fixed_paper: slope(&|s| s.fixed_paper.ours.fit.median),
        peer_fixed_paper: slope(&|s| s.fixed_paper.peer.as_ref().map_or(f64::NAN, |p| p.fit.median)),
        notebook_fixed_paper: slope(&|s| s.fixed_paper.notebook.as_ref().map_or(f64::NAN, |p| p.median)),
    };
    Ok(Training {
        channels,
        fixed_config: FixedConfig { k: 32, sigma_mult: 2.0, alpha_rel: 1e-5, dead_band_pm: 4.0, kmeans_seed: 1 },
        sizes,
        growth_exponent,
    })
}

/// Every training figure at one dataset size, in the order they are taken: the paper feature
/// set against the peers, the default feature set, the selection, the memory terms, `train`.
/// With the models' outputs.
fn size_run(root: &Path, r: &Runner, n: usize, reps: usize, size: &Size) -> Result<(SizeRun, Vec<String>)> {
    let (fixed_paper, last_ours) = fixed_paper(r, size)?;
    // The default (hysteresis-aware) features: the peer computes the same latches with a
    // Python loop before its clock starts.
    let (oh, cmd_oh): (FitBench, _) = r.trainer(&size.fixed("hysteresis-aware"))?;
    let ph: Option<(PeerFit, String)> = if size.peer_ok { Some(r.peer(&size.peer("hysteresis-aware"))?) } else { None };
    let (sel, cmd_sel): (FitBench, _) =
        r.trainer(&["bench-fit", "--data", &size.csv, "--select", "--repeats", &size.reps, "--json"])?;
    let fixed_memory = fixed_memory(r, size)?;
    let train_end_to_end = train_end_to_end(root, r, n, &size.csv, last_ours.read_seconds)?;
    let run = SizeRun {
        n_samples: n,
        n_cal: last_ours.n_cal,
        repeats_per_process: reps,
        rounds: size.rounds,
        train_end_to_end: Some(train_end_to_end),
        fixed_memory,
        ours_select: OursSelect { fit: ours(&sel, cmd_sel), chosen: sel.chosen, grid_points: sel.grid_points },
        fixed_paper,
        fixed_default: FixedDefault {
            ratio: ph.as_ref().map_or(f64::NAN, |(p, _)| p.fit_seconds_median / oh.fit_seconds_median),
            ours: ours(&oh, cmd_oh),
            peer: ph.map(|(p, c)| PeerLatch {
                latch_seconds: p.latch_seconds,
                fit: FitRun { median: p.fit_seconds_median, ..p.run(c, p.fit_seconds.clone()) },
            }),
        },
    };
    Ok((run, last_ours.channels))
}

/// Like with like: the paper feature set (pure scikit-learn on the peer's side), fixed
/// hyper-parameters on both sides, alternating ours / the notebook pipeline / the pipeline
/// with our k-means subsample in each round. Also returns our last fit.
fn fixed_paper(r: &Runner, size: &Size) -> Result<(FixedPaper, FitBench)> {
    let mut ours_p = Vec::new();
    let mut ours_phases = Vec::new();
    let mut peer_p = Vec::new();
    let mut nb_p = Vec::new();
    let mut ratios = Vec::new();
    let mut nb_ratios = Vec::new();
    let (mut cmd_ours, mut cmd_peer, mut cmd_nb) = (String::new(), String::new(), String::new());
    let (mut last_ours, mut last_peer, mut last_nb) = (None, None, None);
    for _ in 0..size.rounds {
        let (o, c): (FitBench, _) = r.trainer(&size.fixed("paper"))?;
        cmd_ours = c;
        let mo = o.fit_seconds_median;
        ours_p.extend(o.fit_seconds.iter().copied());
        ours_phases.push(o.phase_seconds.clone());
        last_ours = Some(o);
        if size.peer_ok {
            let (p, c): (PeerFit, _) = r.peer(&size.notebook())?;
            cmd_nb = c;
            nb_ratios.push(p.fit_seconds_median / mo);
            nb_p.extend(p.fit_seconds.iter().copied());
            last_nb = Some(p);
            let (p, c): (PeerFit, _) = r.peer(&size.peer("paper"))?;
            cmd_peer = c;
            ratios.push(p.fit_seconds_median / mo);
            peer_p.extend(p.fit_seconds.iter().copied());
            last_peer = Some(p);
        }
    }
    let Some(last_ours) = last_ours else { bail!("bench: no training round ran") };
    let fixed = FixedPaper {
        ours: OursFixed {
            fit: FitRun { median: median(&ours_p), fit_seconds: ours_p, ..ours(&last_ours, cmd_ours) },
            blob_bytes: last_ours.model_h.blob_bytes,
            read_seconds: last_ours.read_seconds,
            threads: last_ours.threads,
        },
        ours_phases_per_round: ours_phases,
        peer: last_peer.map(|p| PeerFixed { pickle_bytes: p.model_h.pickle_bytes, fit: p.run(cmd_peer, peer_p) }),
        ratio_median: median(&ratios),
        ratio_per_round: ratios,
        notebook: last_nb.map(|p| p.run(cmd_nb, nb_p)),
        notebook_ratio_median: median(&nb_ratios),
        notebook_ratio_per_round: nb_ratios,
    };
    Ok((fixed, last_ours))
}

/// The default model's own terms: memory terms (cross-validated menu) fitted with the core,
/// against the peer given the same terms (the groups and ridge our CV chose; it does not
/// cross-validate them), alternating in each round.
fn fixed_memory(r: &Runner, size: &Size) -> Result<FixedMemory> {
    let mut with_memory = size.fixed("hysteresis-aware");
    with_memory.push("--memory");
    let (mut om_p, mut pm_p, mut m_ratios, mut pipe_ratios) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut last_om = None;
    let mut last_pm = None;
    for _ in 0..size.rounds {
        let (om, cmd_om): (FitBench, _) = r.trainer(&with_memory)?;
        om_p.extend(om.fit_seconds.iter().copied());
        if size.peer_ok {
            let groups: Vec<String> = om.memory_groups.iter().map(|g| g.join("+")).collect();
            let lambdas: Vec<String> = om.memory_lambda.iter().map(|l| format!("{l:e}")).collect();
            let (groups, lambdas) = (groups.join(","), lambdas.join(","));
            let mut args = size.peer("memory");
            args.extend(["--memory-groups", &groups, "--memory-lambda", &lambdas]);
            let (p, c): (PeerFit, _) = r.peer(&args)?;
            m_ratios.push(p.fit_seconds_median / om.fit_seconds_median);
            pipe_ratios.push((p.fit_seconds_median + p.latch_seconds + p.feature_seconds) / om.fit_seconds_median);
            pm_p.extend(p.fit_seconds.iter().copied());
            last_pm = Some((p, c));
        }
        last_om = Some((om, cmd_om));
    }
    let Some((om, cmd_om)) = last_om else { bail!("bench: no memory round ran") };
    Ok(FixedMemory {
        fit: FitRun { median: median(&om_p), fit_seconds: om_p, ..ours(&om, cmd_om) },
        phase_seconds: om.phase_seconds.clone(),
        peer: last_pm.map(|(p, c)| PeerMemory {
            latch_seconds: p.latch_seconds,
            feature_seconds: p.feature_seconds,
            fit: p.run(c, pm_p),
        }),
        ratio_median: median(&m_ratios),
        ratio_per_round: m_ratios,
        pipeline_ratio_median: median(&pipe_ratios),
        pipeline_ratio_per_round: pipe_ratios,
    })
}

/// What a user waits for: `train` end to end (read the CSV, select, fit, write the blobs and
/// the coefficients), wall clock, once per size; `read_s` is the CSV read our fit timed.
fn train_end_to_end(root: &Path, r: &Runner, n: usize, csv: &str, read_s: f64) -> Result<TrainEndToEnd> {
    let train_dir = root.join("target/bench/train");
    fs::create_dir_all(&train_dir)?;
    let model = rel(&train_dir.join(format!("n{n}.fbgm")), root);
    let t = std::time::Instant::now();
    let (tj, cmd_train): (TrainOut, _) = r.trainer(&["train", "--data", csv, "--out", &model, "--json"])?;
    let train_wall = t.elapsed().as_secs_f64();
    let csv_bytes = fs::metadata(root.join(csv)).map(|m| m.len()).unwrap_or(0);
    Ok(TrainEndToEnd {
        command: cmd_train,
        wall_seconds: train_wall,
        fit_seconds: tj.train_seconds,
        csv_bytes,
        csv_read_seconds: read_s,
        csv_read_mb_per_s: csv_bytes as f64 / 1e6 / read_s,
    })
}
