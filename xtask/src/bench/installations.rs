//! The hold-out band coverage of the other installations, `array-8` and `strain-pair`, over the
//! coverage seeds (DESIGN §4: every preset's hold-out, mean within 95 ± 3 % per channel, no
//! seed below 85 %): `bench-fit --select` with the interrogator's statement, as the `paper`
//! coverage runs of the accuracy part (the same models and bands as `train` + `evaluate`).

use std::path::Path;

use anyhow::Result;
use serde::{Deserialize, Serialize};

use super::runner::Runner;
use super::stats::at;
use super::{build_trainer, coverage_run, preset_csv, update, COVERAGE_SEEDS};
use crate::cmd::step;

/// The installations of this part.
pub const PRESETS: [&str; 2] = ["array-8", "strain-pair"];
/// Mean band coverage per channel within this of 95 % over the seeds.
const MEAN_TOLERANCE: f64 = 0.03;
/// No seed's band coverage below this on any channel.
const SEED_FLOOR: f64 = 0.85;

/// One installation over the coverage seeds.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct InstallationCoverage {
    pub preset: String,
    pub channels: Vec<String>,
    pub seeds: Vec<u64>,
    /// Model-H's hold-out band coverage per seed and channel (fractions).
    pub coverage_h: Vec<Vec<f64>>,
    /// Model-P's, likewise.
    pub coverage_p: Vec<Vec<f64>>,
    /// The first seed's command.
    pub command: String,
}

impl InstallationCoverage {
    /// Mean over the seeds of `v` on channel `c`.
    pub fn mean(v: &[Vec<f64>], c: usize) -> f64 {
        v.iter().map(|s| at(s, c)).sum::<f64>() / v.len().max(1) as f64
    }
    /// Lowest seed of `v` on channel `c`.
    pub fn min(v: &[Vec<f64>], c: usize) -> f64 {
        v.iter().map(|s| at(s, c)).fold(f64::INFINITY, f64::min)
    }
    /// The (seed, channel, coverage) below [`SEED_FLOOR`].
    pub fn below_floor(&self) -> Vec<(u64, &str, f64)> {
        let mut low = Vec::new();
        for (seed, cov) in self.seeds.iter().zip(&self.coverage_h) {
            for (c, name) in self.channels.iter().enumerate() {
                if at(cov, c) < SEED_FLOOR {
                    low.push((*seed, name.as_str(), at(cov, c)));
                }
            }
        }
        low
    }
    /// Both targets on every channel, over every coverage seed.
    pub fn met(&self) -> bool {
        let nc = self.channels.len();
        nc > 0
            && self.seeds.len() == COVERAGE_SEEDS.len()
            && (0..nc).all(|c| (Self::mean(&self.coverage_h, c) - 0.95).abs() <= MEAN_TOLERANCE)
            && self.below_floor().is_empty()
    }
}

/// Every installation of [`PRESETS`] over the coverage seeds (their records simulated by the
/// datasets step).
pub fn part(root: &Path, r: &Runner) -> Result<Vec<InstallationCoverage>> {
    PRESETS
        .iter()
        .map(|&preset| {
            let (mut channels, mut seeds, mut coverage_h, mut coverage_p, mut command) =
                (Vec::new(), Vec::new(), Vec::new(), Vec::new(), String::new());
            for &seed in &COVERAGE_SEEDS {
                let (v, c) = coverage_run(root, r, preset, seed)?;
                if channels.is_empty() {
                    channels.clone_from(&v.channels);
                    command = c;
                } else if v.channels != channels {
                    anyhow::bail!("`{c}` fitted the outputs {:?}, seed {} {:?}", v.channels, seeds[0], channels);
                }
                seeds.push(seed);
                coverage_h.push(v.model_h.coverage);
                coverage_p.push(v.model_p.coverage);
            }
            Ok(InstallationCoverage { preset: preset.into(), channels, seeds, coverage_h, coverage_p, command })
        })
        .collect()
}

/// `cargo xtask bench --installations-only`: this part alone (its records simulated when
/// missing), into the BENCHMARKS.json already there.
pub fn only(root: &Path) -> Result<()> {
    let r = Runner { root: root.to_path_buf() };
    step("bench: release build of the trainer");
    build_trainer(root)?;
    step("bench: the installations' records");
    std::fs::create_dir_all(root.join("target/bench/data"))?;
    std::fs::create_dir_all(root.join("target/bench/holdout"))?;
    for preset in PRESETS {
        for &seed in &COVERAGE_SEEDS {
            let csv = preset_csv(preset, seed);
            if !root.join(&csv).exists() {
                r.simulate(&["--preset", preset, "--seed", &seed.to_string(), "--json", "--out", &csv])?;
            }
        }
    }
    step("bench: hold-out band coverage of the other installations");
    let inst = part(root, &r)?;
    update(root, |rep| {
        rep.installations = Some(inst);
        Ok(())
    })
}
