//! Fleet scaling: `fbg-trainer fleet` on 16 short groups with 1 and 2 jobs, and a rerun that
//! skips everything.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;

use anyhow::{bail, Result};

use super::report::{Fleet, FleetResume, FleetRun};
use super::runner::{FleetOut, Runner};
use super::stats::median;
use super::{rel, Opts, FLEET_GROUPS};

pub fn part(root: &Path, r: &Runner, opts: &Opts) -> Result<Fleet> {
    let dir = root.join("target/bench/fleet");
    if dir.exists() {
        fs::remove_dir_all(&dir)?;
    }
    fs::create_dir_all(&dir)?;
    let cfg = dir.join("short.toml");
    fs::write(&cfg, "# a short scenario: 2 days at 60 s (2 880 samples, 1 440 calibrate)\n[clock]\ndays = 2.0\n")?;
    let mut manifest = String::from("# every group gets the full `train` grid (features all, K <= 32)\n");
    let mut sim_cmd = String::new();
    for g in 0..FLEET_GROUPS {
        let (seed, csv) = ((100 + g).to_string(), rel(&dir.join(format!("g{g:02}.csv")), root));
        let c = r.simulate(&["--config", &rel(&cfg, root), "--seed", &seed, "--json", "--out", &csv])?;
        if g == 0 {
            sim_cmd = c;
        }
        let _ = write!(
            manifest,
            "\n[[group]]\nname = \"g{g:02}\"\ndata = \"g{g:02}.csv\"\nout = \"models/g{g:02}.fbgm\"\n"
        );
    }
    let m = dir.join("fleet.toml");
    fs::write(&m, manifest)?;
    let rounds = if opts.quick { 1 } else { 3 };
    let mut per_jobs: Vec<(usize, Vec<f64>, String)> = vec![(1, vec![], String::new()), (2, vec![], String::new())];
    let mut speedups = Vec::new();
    for _ in 0..rounds {
        let mut secs = [0.0; 2];
        for (i, (jobs, times, cmd)) in per_jobs.iter_mut().enumerate() {
            let models = dir.join("models");
            if models.exists() {
                fs::remove_dir_all(&models)?;
            }
            let (v, c): (FleetOut, _) =
                r.trainer(&["fleet", "--manifest", &rel(&m, root), "--jobs", &jobs.to_string(), "--json"])?;
            if v.trained != FLEET_GROUPS {
                bail!("fleet bench: expected {FLEET_GROUPS} trained groups, got {}", v.trained);
            }
            times.push(v.seconds);
            secs[i] = v.seconds;
            *cmd = c;
        }
        speedups.push(secs[0] / secs[1]);
    }
    // Nothing changed since the last run: everything is skipped.
    let (resume, c_resume): (FleetOut, _) =
        r.trainer(&["fleet", "--manifest", &rel(&m, root), "--jobs", "2", "--json"])?;
    Ok(Fleet {
        groups: FLEET_GROUPS,
        scenario: "paper preset, 2 days at 60 s (2 880 samples, 1 440 calibrate), seeds 100..115".into(),
        simulate_command: format!("{sim_cmd}   (one per group, seeds 100..115)"),
        rounds,
        runs: per_jobs
            .into_iter()
            .map(|(jobs, seconds, command)| FleetRun {
                jobs,
                median_seconds: median(&seconds),
                groups_per_second: FLEET_GROUPS as f64 / median(&seconds),
                seconds,
                command,
            })
            .collect(),
        speedup_2_over_1_median: median(&speedups),
        speedup_2_over_1_per_round: speedups,
        resume: FleetResume {
            command: c_resume,
            skipped: resume.skipped,
            trained: resume.trained,
            seconds: resume.seconds,
        },
    })
}
