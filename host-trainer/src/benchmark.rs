//! Timed fits for `cargo xtask bench` (DESIGN §8): `fbg-trainer bench-fit`.
//!
//! The task runner builds in the dev profile, so it cannot time the fit in-process; it runs this
//! command of the release binary instead. The CSV is read once, then [`fit::train`] runs
//! `repeats` times on it and each fit is timed on its own (reading and evaluating are outside
//! the clock), so the figure is the fit alone, comparable with a peer that times its own fit
//! the same way (`bench/sklearn_peer.py`). The last fit is evaluated on the hold-out, so every
//! timing comes with the accuracy it bought.

use std::time::Instant;

use fbg_shared::layout::FeatureSet;
use fbg_shared::Estimate;

use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::parity;
use crate::eval::score::{channels, evaluate_holdout, ModelEval};
use crate::export;
use crate::fit::{self, Config, FeatureChoice, HyperParam, Origin, TrainOptions};
use crate::stats::median;

/// Hyper-parameters of a fixed-configuration fit when none are given: what cross-validation
/// chooses on the `paper` preset with the default features (K = 32, σ = 2 × the median
/// nearest-neighbour distance of the centres, α = 1e-5 · n, dead band 4 pm).
pub const DEFAULT_FIXED: Config = Config {
    feature_set: FeatureSet::HysteresisAware,
    dead_band_pm: 4.0,
    k: 32,
    sigma_mult: 2.0,
    alpha_rel: 1e-5,
    cross_terms: true,
};

pub use fbg_report::HoldoutFigures;

/// What `bench-fit` measures.
pub type FitBench = fbg_report::FitBench<Config>;

/// One model's hold-out figures, with its blob's size.
fn holdout_figures(e: &ModelEval, blob_bytes: usize) -> HoldoutFigures {
    HoldoutFigures {
        rmse: e.channels.iter().map(|c| c.rmse).collect(),
        coverage: e.channels.iter().map(|c| c.coverage).collect(),
        blob_bytes,
    }
}

/// Read `data`, fit `repeats` times with `opts` on `threads` worker threads (0: rayon's
/// default), evaluate the last fit on the hold-out (and write Model-H's per-sample errors and
/// band to `holdout_errors` when given).
pub fn bench_fit(
    data: &std::path::Path,
    opts: &TrainOptions,
    mode: &'static str,
    repeats: usize,
    threads: usize,
    holdout_errors: Option<&std::path::Path>,
) -> Result<FitBench, TrainerError> {
    let t = Instant::now();
    let d = Dataset::read_csv(data)?;
    let read_seconds = t.elapsed().as_secs_f64();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| TrainerError::fit(format!("thread pool: {e}")))?;
    let origin = Origin { scenario: "bench".into(), seed: 0 };
    let (fit_seconds, mut fits) = pool.install(|| -> Result<_, TrainerError> {
        let mut secs = Vec::with_capacity(repeats);
        let mut fits = Vec::with_capacity(repeats);
        for _ in 0..repeats.max(1) {
            let t = Instant::now();
            let tr = fit::train(&d, opts, &origin)?;
            secs.push(t.elapsed().as_secs_f64());
            fits.push(tr);
        }
        Ok((secs, fits))
    })?;
    // Median of each phase over the fits (every fit has the same phases, in order).
    let phase_seconds = fits
        .first()
        .map(|f| {
            f.phase_seconds
                .iter()
                .enumerate()
                .map(|(k, &(name, _))| {
                    let times: Vec<f64> = fits.iter().filter_map(|f| f.phase_seconds.get(k)).map(|p| p.1).collect();
                    (name.to_string(), median(&times))
                })
                .collect()
        })
        .unwrap_or_default();
    let tr = fits.pop().ok_or_else(|| TrainerError::fit("no fit ran"))?;
    let (ep, estp) = evaluate_holdout(&tr.model_p, &d)?;
    let (eh, esth) = evaluate_holdout(&tr.model_h, &d)?;
    if let Some(path) = holdout_errors {
        write_holdout_errors(path, &tr.model_h.dims, &d, [&esth, &estp])?;
    }
    Ok(FitBench {
        mode: mode.to_string(),
        channels: channels(&tr.model_h.dims),
        units: crate::eval::score::units(&tr.model_h.dims),
        n_samples: d.len(),
        n_cal: tr.selection.n_cal,
        threads: pool.current_num_threads(),
        read_seconds,
        fit_seconds_median: median(&fit_seconds),
        fit_seconds,
        phase_seconds,
        chosen: tr.selection.chosen,
        memory_groups: (0..tr.model_h.dims.n_outputs())
            .map(|o| tr.selection.memory.names(o).into_iter().map(String::from).collect())
            .collect(),
        memory_lambda: tr.selection.memory.lambda[..tr.model_h.dims.n_outputs()].to_vec(),
        grid_points: tr.selection.rows.len(),
        model_p: holdout_figures(&ep, export::blob_bytes(&tr.model_p)?.len()),
        model_h: holdout_figures(&eh, export::blob_bytes(&tr.model_h)?.len()),
        parity: parity::check(&tr.model_h, &d, &eh)?,
    })
}

/// What `fbg-trainer bench-fit` times (its flags, as plain options).
#[derive(Clone, Debug)]
pub struct BenchFitOptions {
    /// Dataset CSV (DESIGN §3 columns).
    pub data: std::path::PathBuf,
    /// Fits to time (each alone; the median is reported).
    pub repeats: usize,
    /// Fit one fixed configuration (the fields below marked "fixed"); else select the
    /// hyper-parameters by cross-validation over the full grid, as `train` does.
    pub fixed: bool,
    /// Select: the model variant, as `train --features`.
    pub features: FeatureChoice,
    /// Fixed: also fit the memory terms (cross-validated menu, as `train`).
    pub memory: bool,
    /// Select: largest number of RBF centres to consider.
    pub max_centres: usize,
    /// Fixed: feature set by its report name (`paper`, `hysteresis-aware`, `hysteresis-aware+time`).
    pub feature_set: String,
    /// Fixed: RBF centres K.
    pub k: usize,
    /// Fixed: σ as a multiple of the median nearest-neighbour distance of the centres.
    pub sigma_mult: f64,
    /// Fixed: ridge penalty per calibration sample (α = alpha_rel · n).
    pub alpha_rel: f64,
    /// Fixed: direction-latch dead band \[pm\].
    pub dead_band_pm: f64,
    /// Worker threads (0: one per core).
    pub threads: usize,
    /// The interrogator's stated stability \[pm/√day\], as `train --drift-spec`.
    pub drift_spec: Option<f64>,
    /// The drift's relative gain per grating, as `train --drift-gains`.
    pub drift_gains: Option<Vec<f64>>,
    /// Also write Model-H's per-sample hold-out errors and 95 % band half-widths to this CSV.
    pub holdout_errors: Option<std::path::PathBuf>,
}

impl BenchFitOptions {
    /// The training options these ask for, and the mode's name.
    pub fn options(&self) -> Result<(TrainOptions, &'static str), TrainerError> {
        self.options_named(&|flag| format!("--{flag}"))
    }

    /// [`BenchFitOptions::options`] with the errors naming each option as `name(flag)` does
    /// (`--k` on the command line, Python's `fixed['k']`).
    pub fn options_named(&self, name: &dyn Fn(&str) -> String) -> Result<(TrainOptions, &'static str), TrainerError> {
        if self.fixed {
            let fs = feature_set_named(&self.feature_set).ok_or_else(|| {
                TrainerError::options(format!(
                    "{}: unknown feature set `{}` (paper, hysteresis-aware, hysteresis-aware+time)",
                    name("feature-set"),
                    crate::error::quote_cell(&self.feature_set)
                ))
            })?;
            if self.k == 0 || self.k > fit::HOST_CAP {
                return Err(TrainerError::options(format!("{} must be in 1..={}", name("k"), fit::HOST_CAP)));
            }
            // The values the blob carries, in the ranges its check accepts: refused here, before
            // the file is read, not by the assembled model's check after the whole fit.
            HyperParam::SigmaMult.check(self.sigma_mult, &name("sigma-mult"))?;
            HyperParam::AlphaRel.check(self.alpha_rel, &name("alpha-rel"))?;
            HyperParam::DeadBandPm.check(self.dead_band_pm, &name("dead-band-pm"))?;
            let cfg = Config {
                feature_set: fs,
                dead_band_pm: self.dead_band_pm,
                k: self.k,
                sigma_mult: self.sigma_mult,
                alpha_rel: self.alpha_rel,
                cross_terms: true,
            };
            let mut opts = TrainOptions::fixed(&cfg);
            if !self.memory {
                opts = opts.to_builder().memory(fit::memory_core::MemoryOptions::off()).check()?;
            }
            Ok((self.with_drift_spec(opts, name)?, "fixed"))
        } else {
            let opts = self
                .features
                .train_options(self.max_centres)
                .map_err(|m| TrainerError::options(format!("{}: {m}", name("max-centres"))))?;
            Ok((self.with_drift_spec(opts, name)?, "select"))
        }
    }

    /// `opts` with the stated drift and its gains, checked; an error names the option as
    /// `name` does.
    fn with_drift_spec(&self, opts: TrainOptions, name: &dyn Fn(&str) -> String) -> Result<TrainOptions, TrainerError> {
        let opts = match self.drift_spec {
            None => opts,
            Some(_) => opts
                .to_builder()
                .drift_spec_pm_per_sqrt_day(self.drift_spec)
                .check()
                .map_err(|e| TrainerError::options(format!("{}: {e}", name("drift-spec"))))?,
        };
        match &self.drift_gains {
            None => Ok(opts),
            Some(g) => opts
                .to_builder()
                .drift_gains(Some(g.clone()))
                .check()
                .map_err(|e| TrainerError::options(format!("{}: {e}", name("drift-gains")))),
        }
    }

    /// Run the benchmark.
    pub fn run(&self) -> Result<FitBench, TrainerError> {
        let (opts, mode) = self.options()?;
        bench_fit(&self.data, &opts, mode, self.repeats, self.threads, self.holdout_errors.as_deref())
    }
}

/// Model-H's hold-out errors (estimate − truth) and band half-widths, then Model-P's
/// (`p_err_*`, `p_band_*`), one row per scored sample.
fn write_holdout_errors(
    path: &std::path::Path,
    dims: &fbg_shared::layout::Dims,
    d: &Dataset,
    est: [&[Estimate<f64>]; 2],
) -> Result<(), TrainerError> {
    use std::io::Write;
    let idx: Vec<usize> = d.holdout_indices().into_iter().filter(|&i| d.usable(i)).collect();
    if est.iter().any(|e| e.len() != idx.len()) {
        return Err(TrainerError::fit("hold-out errors: the two models scored different rows"));
    }
    let refs = d.references_of(dims);
    crate::data::files::write_atomically(path, |w| {
        write!(w, "t_s")?;
        for name in ["err", "band", "p_err", "p_band"] {
            for ch in channels(dims) {
                write!(w, ",{name}_{ch}")?;
            }
        }
        writeln!(w)?;
        for (k, &i) in idx.iter().enumerate() {
            write!(w, "{}", d.t_s[i])?;
            for e in est.iter().filter_map(|e| e.get(k)) {
                for (c, r) in refs.iter().enumerate() {
                    write!(w, ",{}", e.values[c] - r[i])?;
                }
                for c in 0..dims.n_outputs() {
                    write!(w, ",{}", e.band95[c])?;
                }
            }
            writeln!(w)?;
        }
        Ok(())
    })
}

/// "T 0.123 °C, ε 1.23 µε" (units only when `units`).
fn rmse_text(b: &FitBench, rmse: &[f64], units: bool) -> String {
    b.channels
        .iter()
        .zip(&b.units)
        .zip(rmse)
        .map(|((ch, u), v)| {
            let (sym, dg) = (ch.replacen("strain", "ε", 1), if u == "°C" { 3 } else { 2 });
            if units {
                format!("{sym} {v:.dg$} {u}")
            } else {
                format!("{sym} {v:.dg$}")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// One human-readable paragraph.
pub fn text(b: &FitBench) -> String {
    let c = &b.chosen;
    format!(
        "{} fit of {} calibration samples ({} in the file, {} threads): median {:.3} s over {} fits {:?} (CSV read {:.2} s)\n\
         configuration: {} features, K = {}, σ = {}×NN, α = {:e}·n, dead band {} pm ({} grid points)\n\
         hold-out RMSE Model-P: {} ({} B); Model-H: {} ({} B)",
        b.mode, b.n_cal, b.n_samples, b.threads, b.fit_seconds_median, b.fit_seconds.len(),
        b.fit_seconds.iter().map(|s| (s * 1000.0).round() / 1000.0).collect::<Vec<_>>(), b.read_seconds,
        c.feature_set.name(), c.k, c.sigma_mult, c.alpha_rel, c.dead_band_pm, b.grid_points,
        rmse_text(b, &b.model_p.rmse, true), b.model_p.blob_bytes,
        rmse_text(b, &b.model_h.rmse, false), b.model_h.blob_bytes,
    )
}

/// A fixed configuration's feature set by its report name (`paper`, `hysteresis-aware`,
/// `hysteresis-aware+time`).
pub(crate) fn feature_set_named(name: &str) -> Option<FeatureSet> {
    FeatureSet::ALL.into_iter().find(|f| f.name() == name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feature_sets_by_name() {
        for f in FeatureSet::ALL {
            assert_eq!(feature_set_named(f.name()), Some(f));
        }
        assert_eq!(feature_set_named("nope"), None);
    }
}
