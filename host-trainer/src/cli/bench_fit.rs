//! `fbg-trainer bench-fit`: timed fits for `cargo xtask bench`.

use std::path::PathBuf;

use anyhow::Result;

use fbg_trainer::benchmark::{BenchFitOptions, DEFAULT_FIXED};

use crate::args::FeaturesArg;

/// Time the fit for benchmarks (`cargo xtask bench`): read a CSV once, fit it --repeats
/// times (each fit timed alone), evaluate the last fit on the hold-out.
#[derive(clap::Args, Clone, Debug)]
pub struct BenchFitArgs {
    /// Dataset CSV (DESIGN §3 columns).
    #[arg(long)]
    data: PathBuf,
    /// Fits to time (each alone; the median is reported).
    #[arg(long, default_value_t = 3)]
    repeats: usize,
    /// Fit one fixed configuration (--feature-set, --k, --sigma-mult, --alpha-rel,
    /// --dead-band-pm); the cross-validation then runs once, for the band.
    #[arg(long, conflicts_with = "select")]
    fixed: bool,
    /// Select the hyper-parameters by cross-validation over the full grid, as `train` does
    /// (the default).
    #[arg(long)]
    select: bool,
    /// With --select: the model variant, as `train --features` (memory, hysteresis-aware, latch,
    /// paper, all).
    #[arg(long, value_enum, default_value = "memory")]
    features: FeaturesArg,
    /// With --fixed: also fit the memory terms (cross-validated menu, as `train`). Off by default so
    /// that the fixed fit is the scikit-learn peer's pipeline, which has no memory terms.
    #[arg(long)]
    memory: bool,
    /// With --select: largest number of RBF centres to consider.
    #[arg(long, default_value_t = 32)]
    max_centres: usize,
    /// With --fixed: feature set (paper, hysteresis-aware, hysteresis-aware+time).
    #[arg(long, default_value = DEFAULT_FIXED.feature_set.name())]
    feature_set: String,
    /// With --fixed: RBF centres K.
    #[arg(long, default_value_t = DEFAULT_FIXED.k)]
    k: usize,
    /// With --fixed: σ as a multiple of the median nearest-neighbour distance of the centres.
    #[arg(long, default_value_t = DEFAULT_FIXED.sigma_mult, allow_negative_numbers = true)]
    sigma_mult: f64,
    /// With --fixed: ridge penalty per calibration sample (α = alpha_rel · n).
    #[arg(long, default_value_t = DEFAULT_FIXED.alpha_rel, allow_negative_numbers = true)]
    alpha_rel: f64,
    /// With --fixed: direction-latch dead band \[pm\].
    #[arg(long, default_value_t = DEFAULT_FIXED.dead_band_pm, allow_negative_numbers = true)]
    dead_band_pm: f64,
    /// Worker threads (0: one per core).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Print the figures as JSON on stdout.
    #[arg(long)]
    json: bool,
    /// Also write the per-sample hold-out errors and 95 % band half-widths to this CSV
    /// (`t_s`, Model-H's `err_<channel>`, `band_<channel>`, Model-P's `p_err_<channel>`,
    /// `p_band_<channel>`), for band-coverage studies across seeds.
    #[arg(long)]
    holdout_errors: Option<PathBuf>,
    /// The interrogator's stated stability [pm/√day], as `train --drift-spec`.
    #[arg(long, value_name = "PM_PER_SQRT_DAY", allow_negative_numbers = true)]
    drift_spec: Option<f64>,
    /// The drift's relative gain per grating, as `train --drift-gains`.
    #[arg(long, value_name = "G1,G2,..", value_delimiter = ',', allow_negative_numbers = true)]
    drift_gains: Option<Vec<f64>>,
}

impl BenchFitArgs {
    pub fn run(self) -> Result<()> {
        let json = self.json;
        let b = BenchFitOptions {
            data: self.data,
            repeats: self.repeats,
            fixed: self.fixed,
            features: self.features.0,
            memory: self.memory,
            max_centres: self.max_centres,
            feature_set: self.feature_set,
            k: self.k,
            sigma_mult: self.sigma_mult,
            alpha_rel: self.alpha_rel,
            dead_band_pm: self.dead_band_pm,
            threads: self.threads,
            holdout_errors: self.holdout_errors,
            drift_spec: self.drift_spec,
            drift_gains: self.drift_gains,
        }
        .run()?;
        if json {
            println!("{}", serde_json::to_string_pretty(&b)?);
        } else {
            eprintln!("{}", fbg_trainer::benchmark::text(&b));
        }
        Ok(())
    }
}
