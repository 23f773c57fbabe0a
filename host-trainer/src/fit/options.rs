//! The options of a fit, checked before any work as linfa's hyper-parameters are: a
//! [`TrainOptionsBuilder`] takes any values, its [`check`](TrainOptionsBuilder::check) gives
//! [`TrainOptions`] whose values the fit can use, or names the one it cannot.

use super::grid::{Config, CvGrid};
use super::memory_core::MemoryOptions;
use crate::data::import::OnError;
use crate::error::TrainerError;
use fbg_shared::layout::FeatureSet;

/// Checked options of a fit: the grid cross-validation searches and the CV layout. Made by
/// [`TrainOptions::default`], [`TrainOptions::fixed`] or a [`TrainOptionsBuilder`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct TrainOptions {
    #[serde(flatten)]
    grid: CvGrid,
    /// Keep the quadratic and cross terms of stage 2 (false only for the ablation).
    cross_terms: bool,
    /// The memory menu (off for the `paper` and `latch` variants).
    memory: MemoryOptions,
    /// Contiguous blocks the calibration batch is cut into.
    blocks: usize,
    /// Blocks in the first fold's training set.
    min_train_blocks: usize,
    /// Seed of k-means++.
    seed: u64,
    /// Largest number of calibration rows the cross-validation works on.
    cv_max_samples: usize,
    /// Show a progress bar (only on a terminal).
    #[serde(skip)]
    progress: bool,
    /// Reference outliers in the calibration rows: refuse the batch or leave their rows out.
    on_outlier: OnError,
    /// How the refusal of outliers names the option that skips them (the front end's word).
    #[serde(skip)]
    skip_outliers_hint: &'static str,
    /// Set by another thread to stop the fit at its next task (Python's Ctrl-C).
    #[serde(skip)]
    cancel: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
    /// The interrogator's stated wavelength stability as a random walk \[pm/√day\]: a walk the
    /// bands add beside the growth the calibration's errors show (`None`: the errors alone).
    drift_spec_pm_per_sqrt_day: Option<f64>,
    /// The drift's relative gain per grating, in the record's order (`None`: one gain, every
    /// grating walks the same path): an interrogator whose channels drift by different amounts
    /// reaches each output through Σᵢ gᵢ·∂y/∂λᵢ, not through the plain sum.
    #[serde(skip_serializing_if = "Option::is_none")]
    drift_gains: Option<Vec<f64>>,
    /// How a refusal of the gains' count names them (the front end's word).
    #[serde(skip)]
    drift_gains_name: &'static str,
}

/// Largest stated drift [pm/√day] accepted (a random walk of a nanometre per √day is no
/// interrogator's specification, but a unit slip).
pub const DRIFT_SPEC_MAX_PM_PER_SQRT_DAY: f64 = 1_000.0;

/// Largest |relative drift gain| of a grating accepted (the simulator's range).
pub const DRIFT_GAIN_MAX: f64 = 10.0;

/// The command line's name of the option that leaves outlying rows out.
pub const CLI_SKIP_OUTLIERS: &str = "train with `--on-error skip`";

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            grid: CvGrid::default(),
            cross_terms: true,
            memory: MemoryOptions::default_menu(),
            blocks: 5,
            min_train_blocks: 2,
            seed: 1,
            cv_max_samples: 40_000,
            progress: false,
            on_outlier: OnError::Fail,
            skip_outliers_hint: CLI_SKIP_OUTLIERS,
            cancel: None,
            drift_spec_pm_per_sqrt_day: None,
            drift_gains: None,
            drift_gains_name: "--drift-gains",
        }
    }
}

impl TrainOptions {
    /// A builder from the defaults.
    pub fn builder() -> TrainOptionsBuilder {
        TrainOptionsBuilder(TrainOptions::default())
    }

    /// A builder from these options, to change some of them.
    pub fn to_builder(&self) -> TrainOptionsBuilder {
        TrainOptionsBuilder(self.clone())
    }

    /// A one-point grid: no choice left to make (CV still runs, for s²).
    pub fn fixed(cfg: &Config) -> Self {
        TrainOptions { grid: CvGrid::fixed(cfg), cross_terms: cfg.cross_terms, ..TrainOptions::default() }
    }

    /// [`TrainOptions::fixed`] keeping this grid's memory menu (cross-validation still chooses
    /// the memory terms: it costs one pass of the bank per fold).
    pub fn fixed_like(&self, cfg: &Config) -> Self {
        TrainOptions { memory: self.memory.clone(), ..TrainOptions::fixed(cfg) }
    }

    /// These options with another k-means++ seed (any seed is valid: no check needed).
    pub fn with_seed(self, seed: u64) -> Self {
        TrainOptions { seed, ..self }
    }

    /// These options with another wording of the option that skips outlying rows, as the
    /// refusal of reference outliers gives it (default: train with `--on-error skip`; Python names
    /// its parameter).
    pub fn with_skip_outliers_hint(self, skip_outliers_hint: &'static str) -> Self {
        TrainOptions { skip_outliers_hint, ..self }
    }

    /// These options with a cancel flag: once another thread sets it, the fit ends at its next
    /// cross-validation task or phase with [`TrainerError::Interrupted`].
    pub fn with_cancel(self, cancel: std::sync::Arc<std::sync::atomic::AtomicBool>) -> Self {
        TrainOptions { cancel: Some(cancel), ..self }
    }

    /// `Err(Interrupted)` once the cancel flag is set.
    pub(crate) fn check_cancel(&self) -> Result<(), TrainerError> {
        match &self.cancel {
            Some(c) if c.load(std::sync::atomic::Ordering::Relaxed) => {
                Err(TrainerError::Interrupted { what: "fit".into() })
            }
            _ => Ok(()),
        }
    }

    /// The wording of the option that skips outlying rows.
    pub fn skip_outliers_hint(&self) -> &'static str {
        self.skip_outliers_hint
    }

    /// These options with or without a progress bar.
    pub fn with_progress(self, progress: bool) -> Self {
        TrainOptions { progress, ..self }
    }

    /// These options refusing a batch with reference outliers (`Fail`) or leaving their rows
    /// out (`Skip`).
    pub fn with_on_outlier(self, on_outlier: OnError) -> Self {
        TrainOptions { on_outlier, ..self }
    }

    /// The interrogator's stated stability \[pm/√day\], if given.
    pub fn drift_spec_pm_per_sqrt_day(&self) -> Option<f64> {
        self.drift_spec_pm_per_sqrt_day
    }

    /// The drift's stated relative gain per grating, if given.
    pub fn drift_gains(&self) -> Option<&[f64]> {
        self.drift_gains.as_deref()
    }

    /// These options naming the drift's gains as `name` when the fit refuses their count
    /// (default `--drift-gains`; Python and the fleet manifest name theirs).
    pub fn with_drift_gains_name(self, drift_gains_name: &'static str) -> Self {
        TrainOptions { drift_gains_name, ..self }
    }

    /// How a refusal of the gains' count names them.
    pub(crate) fn drift_gains_name(&self) -> &'static str {
        self.drift_gains_name
    }

    /// The stated stability as a walk rate \[pm²/s\] (`None` when not given).
    pub(crate) fn drift_spec_rate_pm2_per_s(&self) -> Option<f64> {
        self.drift_spec_pm_per_sqrt_day.map(|s| s * s / 86_400.0)
    }

    /// The candidates cross-validation tries.
    pub fn grid(&self) -> &CvGrid {
        &self.grid
    }
    /// Whether stage 2 keeps the quadratic and cross terms (false only for the ablation).
    pub fn cross_terms(&self) -> bool {
        self.cross_terms
    }
    /// The memory menu (off for the `paper` and `latch` variants).
    pub fn memory(&self) -> &MemoryOptions {
        &self.memory
    }
    /// Contiguous blocks the calibration batch is cut into.
    pub fn blocks(&self) -> usize {
        self.blocks
    }
    /// Blocks in the first fold's training set.
    pub fn min_train_blocks(&self) -> usize {
        self.min_train_blocks
    }
    /// Seed of k-means++.
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// Largest number of calibration rows the cross-validation works on: beyond it the rows are
    /// thinned by an even stride (time order and span kept; the latches still see every
    /// sample). The final fit always uses every row.
    pub fn cv_max_samples(&self) -> usize {
        self.cv_max_samples
    }
    /// Whether a progress bar shows (only on a terminal).
    pub fn progress(&self) -> bool {
        self.progress
    }
    /// Reference outliers in the calibration rows (`data::outliers`): refuse the batch
    /// (`Fail`, the default) or leave their rows out of the fit (`Skip`).
    pub fn on_outlier(&self) -> OnError {
        self.on_outlier
    }
}

/// Options of a fit not yet checked: setters that take any value, and
/// [`check`](TrainOptionsBuilder::check).
#[derive(Clone, Debug)]
pub struct TrainOptionsBuilder(TrainOptions);

impl TrainOptionsBuilder {
    /// The RBF feature sets cross-validation may choose from (`paper` → only the paper set;
    /// `hysteresis-aware` → the latch sets, with time left to cross-validation).
    pub fn feature_sets(mut self, sets: Vec<FeatureSet>) -> Self {
        self.0.grid.feature_sets = sets;
        self
    }
    /// The numbers of RBF centres K to try.
    pub fn centres(mut self, centres: Vec<usize>) -> Self {
        self.0.grid.centres = centres;
        self
    }
    /// The σ multiples to try.
    pub fn sigma_mults(mut self, sigma_mults: Vec<f64>) -> Self {
        self.0.grid.sigma_mults = sigma_mults;
        self
    }
    /// The ridge penalties per sample to try.
    pub fn alpha_rels(mut self, alpha_rels: Vec<f64>) -> Self {
        self.0.grid.alpha_rels = alpha_rels;
        self
    }
    /// The direction-latch dead bands \[pm\] to try.
    pub fn dead_bands_pm(mut self, dead_bands_pm: Vec<f64>) -> Self {
        self.0.grid.dead_bands_pm = dead_bands_pm;
        self
    }
    /// Keep the quadratic and cross terms of stage 2.
    pub fn cross_terms(mut self, on: bool) -> Self {
        self.0.cross_terms = on;
        self
    }
    /// The memory menu.
    pub fn memory(mut self, memory: MemoryOptions) -> Self {
        self.0.memory = memory;
        self
    }
    /// Contiguous blocks the calibration batch is cut into (at least 2).
    pub fn blocks(mut self, blocks: usize) -> Self {
        self.0.blocks = blocks;
        self
    }
    /// Blocks in the first fold's training set (1 to `blocks` − 1).
    pub fn min_train_blocks(mut self, min_train_blocks: usize) -> Self {
        self.0.min_train_blocks = min_train_blocks;
        self
    }
    /// Seed of k-means++.
    pub fn seed(mut self, seed: u64) -> Self {
        self.0.seed = seed;
        self
    }
    /// Largest number of calibration rows the cross-validation works on.
    pub fn cv_max_samples(mut self, n: usize) -> Self {
        self.0.cv_max_samples = n;
        self
    }
    /// Show a progress bar (only on a terminal).
    pub fn progress(mut self, on: bool) -> Self {
        self.0.progress = on;
        self
    }
    /// Refuse a batch with reference outliers (`Fail`) or leave their rows out (`Skip`).
    pub fn on_outlier(mut self, on_outlier: OnError) -> Self {
        self.0.on_outlier = on_outlier;
        self
    }

    /// The interrogator's stated wavelength stability, as a random walk \[pm/√day\] (a
    /// datasheet's "±x pm over a day" is about x/2 as a walk's standard deviation): the bands
    /// add a walk of this rate through each output's common-mode sensitivity, Gaussian, from
    /// the offset it has at the end of calibration on.
    pub fn drift_spec_pm_per_sqrt_day(mut self, spec: Option<f64>) -> Self {
        self.0.drift_spec_pm_per_sqrt_day = spec;
        self
    }

    /// The drift's relative gain per grating, in the record's order (the interrogator's
    /// per-channel stability over the stated one, e.g. `[1.0, 1.1, 1.2]`): the bands take the
    /// walk through Σᵢ gᵢ·∂y/∂λᵢ instead of assuming every grating drifts alike. The fit
    /// refuses a count other than the record's gratings.
    pub fn drift_gains(mut self, gains: Option<Vec<f64>>) -> Self {
        self.0.drift_gains = gains;
        self
    }

    /// The options, if the fit can use them: a CV layout of at least two blocks with
    /// 1 <= `min_train_blocks` < `blocks`, a grid with at least one point, a stated drift
    /// (if any) in 0 ..= 1 000 pm/√day and its gains (if any) finite, in −10 ..= 10, at
    /// most one per grating a model carries.
    pub fn check(self) -> Result<TrainOptions, TrainerError> {
        self.check_ref()?;
        Ok(self.0)
    }

    /// [`TrainOptionsBuilder::check`] without giving the builder up.
    pub fn check_ref(&self) -> Result<&TrainOptions, TrainerError> {
        let o = &self.0;
        if o.blocks < 2 || o.min_train_blocks == 0 || o.min_train_blocks >= o.blocks {
            return Err(TrainerError::options("cross-validation needs 1 <= min_train_blocks < blocks"));
        }
        if let Some(s) = o.drift_spec_pm_per_sqrt_day {
            if !(0.0..=DRIFT_SPEC_MAX_PM_PER_SQRT_DAY).contains(&s) {
                return Err(TrainerError::options(format!(
                    "the stated drift is {s} pm/√day; give 0 to {DRIFT_SPEC_MAX_PM_PER_SQRT_DAY} pm/√day"
                )));
            }
        }
        if let Some(g) = &o.drift_gains {
            if g.is_empty() || g.len() > fbg_shared::layout::MAX_GRATINGS {
                return Err(TrainerError::options(format!(
                    "{} drift gains given; give one per grating (1 to {})",
                    g.len(),
                    fbg_shared::layout::MAX_GRATINGS
                )));
            }
            if let Some((i, v)) = g.iter().enumerate().find(|(_, v)| !(-DRIFT_GAIN_MAX..=DRIFT_GAIN_MAX).contains(*v)) {
                return Err(TrainerError::options(format!(
                    "drift gain {} is {v}; give -{DRIFT_GAIN_MAX} to {DRIFT_GAIN_MAX}",
                    i + 1
                )));
            }
            // All zero would drop the walk from every band, the stated one and the one read.
            if g.iter().all(|v| *v == 0.0) {
                return Err(TrainerError::options("every drift gain is 0; give at least one that is not"));
            }
        }
        o.grid.check()?;
        Ok(o)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_pass_their_own_check() {
        let o = TrainOptions::builder().check().unwrap();
        assert_eq!(o.grid(), TrainOptions::default().grid());
        assert_eq!((o.blocks(), o.min_train_blocks(), o.seed()), (5, 2, 1));
    }

    #[test]
    fn a_stated_drift_outside_its_range_is_refused_naming_it() {
        for bad in [-1.0, f64::NAN, 1e4] {
            let e = TrainOptions::builder().drift_spec_pm_per_sqrt_day(Some(bad)).check().unwrap_err().to_string();
            // An option's error, not a fit's: no `fit: ` before it (a front end puts its own
            // name of the option first).
            assert!(e.starts_with("the stated drift is"), "{e}");
        }
        let o = TrainOptions::builder().drift_spec_pm_per_sqrt_day(Some(2.0)).check().unwrap();
        assert!((o.drift_spec_rate_pm2_per_s().unwrap() - 4.0 / 86_400.0).abs() < 1e-15);
    }

    #[test]
    fn drift_gains_outside_their_range_are_refused_naming_the_gain() {
        for (bad, says) in [
            (vec![], "0 drift gains"),
            (vec![1.0, f64::NAN], "drift gain 2 is NaN"),
            (vec![1.0, 1.1, 11.0], "drift gain 3 is 11"),
            (vec![1.0; fbg_shared::layout::MAX_GRATINGS + 1], "drift gains given"),
            (vec![0.0, -0.0], "every drift gain is 0"),
        ] {
            let e = TrainOptions::builder().drift_gains(Some(bad)).check().unwrap_err().to_string();
            assert!(e.contains(says), "{e}");
        }
        let o = TrainOptions::builder().drift_gains(Some(vec![1.0, -1.2])).check().unwrap();
        assert_eq!(o.drift_gains(), Some(&[1.0, -1.2][..]));
    }

    #[test]
    fn a_bad_cv_layout_is_refused_naming_its_fields() {
        for (blocks, min) in [(1, 1), (5, 0), (5, 5), (3, 4)] {
            let e = TrainOptions::builder().blocks(blocks).min_train_blocks(min).check().unwrap_err().to_string();
            assert!(e.contains("min_train_blocks < blocks"), "{e}");
        }
        assert!(TrainOptions::builder().blocks(2).min_train_blocks(1).check().is_ok());
    }

    #[test]
    fn an_empty_grid_is_refused_naming_the_empty_entry() {
        let cases: [(TrainOptionsBuilder, &str); 5] = [
            (TrainOptions::builder().feature_sets(vec![]), "feature_sets"),
            (TrainOptions::builder().centres(vec![]), "centres"),
            (TrainOptions::builder().sigma_mults(vec![]), "sigma_mults"),
            (TrainOptions::builder().alpha_rels(vec![]), "alpha_rels"),
            (TrainOptions::builder().dead_bands_pm(vec![]), "dead_bands_pm"),
        ];
        for (b, field) in cases {
            let e = b.check().unwrap_err().to_string();
            assert!(e.contains("empty hyper-parameter grid") && e.contains(field), "{e}");
        }
        // The paper set ignores the dead band: it needs none.
        let paper = TrainOptions::builder().feature_sets(vec![FeatureSet::Paper]).dead_bands_pm(vec![]).check();
        assert_eq!(paper.unwrap().grid().len(), 2 * 4 * 5);
    }

    #[test]
    fn a_grid_value_a_blob_cannot_carry_is_refused_naming_the_entry() {
        let cases: [(TrainOptionsBuilder, &str); 4] = [
            (
                TrainOptions::builder().sigma_mults(vec![1.0, 0.0]),
                "sigma_mults must be above 0 and at most 1e6 (got 0)",
            ),
            (TrainOptions::builder().alpha_rels(vec![f64::NAN]), "alpha_rels must be in 0..=1e12 (got NaN)"),
            (TrainOptions::builder().alpha_rels(vec![-1e-5]), "alpha_rels must be in 0..=1e12 (got -1e-5)"),
            (TrainOptions::builder().dead_bands_pm(vec![2.0, -1.0]), "dead_bands_pm must be in 0..=1e6 (got -1)"),
        ];
        for (b, message) in cases {
            let e = b.check().unwrap_err().to_string();
            assert_eq!(e, format!("hyper-parameter grid: {message}"));
        }
        // A fixed configuration is checked too, when its options are.
        let cfg = Config {
            feature_set: FeatureSet::HysteresisAware,
            dead_band_pm: 4.0,
            k: 8,
            sigma_mult: f64::INFINITY,
            alpha_rel: 1e-5,
            cross_terms: true,
        };
        assert!(TrainOptions::fixed(&cfg).to_builder().check().is_err());
    }

    #[test]
    fn a_fixed_grid_has_one_point_its_config() {
        let cfg = Config {
            feature_set: FeatureSet::Paper,
            dead_band_pm: 3.0,
            k: 6,
            sigma_mult: 1.5,
            alpha_rel: 1e-4,
            cross_terms: false,
        };
        let o = TrainOptions::fixed(&cfg);
        assert_eq!(o.grid().len(), 1);
        assert_eq!(o.grid().first(o.cross_terms()), Some(cfg));
        assert!(o.to_builder().check().is_ok());
    }
}
