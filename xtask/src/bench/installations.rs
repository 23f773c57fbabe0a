//! The hold-out band coverage of the other installations, `array-8` and `strain-pair`, over the
//! coverage seeds (DESIGN §4: every preset's hold-out, mean within 95 ± 3 % per channel, no
//! seed below 85 %): `bench-fit --select` with the interrogator's statement, as the `paper`
//! coverage runs of the accuracy part (the same models and bands as `train` + `evaluate`).

use std::path::Path;

use anyhow::Result;
use serde::{Deserialize, Serialize};

use super::accuracy::coverage_run;
use super::markdown::{channel_names, pcts, slash};
use super::runner::Runner;
use super::stats::at;
use super::{build_trainer, preset_csv, update, COVERAGE_SEEDS};
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
    fn mean(v: &[Vec<f64>], c: usize) -> f64 {
        v.iter().map(|s| at(s, c)).sum::<f64>() / v.len().max(1) as f64
    }
    fn min(v: &[Vec<f64>], c: usize) -> f64 {
        v.iter().map(|s| at(s, c)).fold(f64::INFINITY, f64::min)
    }
    /// The (seed, channel, coverage) below [`SEED_FLOOR`].
    fn below_floor(&self) -> Vec<(u64, &str, f64)> {
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
    fn met(&self) -> bool {
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

/// The target row: every installation's mean within 95 ± 3 % per channel, no seed below 85 %.
pub fn target_row(s: &mut String, inst: &[InstallationCoverage]) {
    let measured: Vec<String> = inst
        .iter()
        .map(|i| {
            let nc = i.channels.len();
            let means: Vec<f64> = (0..nc).map(|c| InstallationCoverage::mean(&i.coverage_h, c)).collect();
            let mins: Vec<f64> = (0..nc).map(|c| InstallationCoverage::min(&i.coverage_h, c)).collect();
            format!(
                "`{}` ({}): mean {} %, lowest seed {} %, {} channel-seeds below 85 %",
                i.preset,
                channel_names(&i.channels),
                pcts(&means),
                pcts(&mins),
                i.below_floor().len()
            )
        })
        .collect();
    let met = !inst.is_empty() && inst.iter().all(InstallationCoverage::met);
    out!(
        s,
        "| {} presets, seeds {}–{}: Model-H hold-out band coverage, mean within 95 ± 3 % per channel, no seed below 85 % (DESIGN §4) | {} | {} | installations part (below) |",
        slash(inst.iter().map(|i| format!("`{}`", i.preset))),
        COVERAGE_SEEDS[0],
        COVERAGE_SEEDS[COVERAGE_SEEDS.len() - 1],
        measured.join("; "),
        if met { "**met**" } else { "**not met**" }
    );
}

/// The section: per installation, Model-H's and Model-P's coverage per channel over the seeds.
pub fn markdown(s: &mut String, inst: &[InstallationCoverage]) {
    if inst.is_empty() {
        return;
    }
    out!(s, "## Hold-out band coverage of the other installations\n");
    out!(
        s,
        "The week after calibration of each seed's own record (`simulate --preset P --seed S`), the models and bands `train` \
         makes with the interrogator's statement (its stated stability and per-channel drift gains, from the record's \
         `.meta.json`). Per channel: mean over the seeds (lowest seed). Target: mean within 95 ± 3 %, no seed below 85 %.\n"
    );
    out!(s, "| installation | seeds | channels | Model-H coverage | Model-P coverage | below 85 % (seed: channel %) |\n|---|---|---|---|---|---|");
    for i in inst {
        let nc = i.channels.len();
        let cell = |v: &[Vec<f64>]| {
            slash((0..nc).map(|c| {
                format!(
                    "{:.1} ({:.1})",
                    100.0 * InstallationCoverage::mean(v, c),
                    100.0 * InstallationCoverage::min(v, c)
                )
            }))
        };
        let low: Vec<String> =
            i.below_floor().iter().map(|(seed, ch, v)| format!("{seed}: {ch} {:.1}", 100.0 * v)).collect();
        out!(
            s,
            "| `{}` | {} | {} | {} % | {} % | {} |",
            i.preset,
            i.seeds.len(),
            channel_names(&i.channels),
            cell(&i.coverage_h),
            cell(&i.coverage_p),
            if low.is_empty() { "none".to_string() } else { low.join(", ") }
        );
    }
    if let Some(first) = inst.first() {
        out!(s, "\n    {}\n", first.command);
    }
}
