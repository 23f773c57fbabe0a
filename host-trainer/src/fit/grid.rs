//! The hyper-parameters cross-validation chooses from: one point of the grid ([`Config`]) and
//! the grid itself ([`CvGrid`]), the candidates of every hyper-parameter.

use fbg_shared::layout::FeatureSet;

use crate::error::TrainerError;

/// One point of the hyper-parameter grid.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Config {
    /// The RBF inputs (DESIGN §4).
    pub feature_set: FeatureSet,
    /// Direction-latch dead band \[pm\] (irrelevant for the `paper` set).
    pub dead_band_pm: f64,
    /// RBF centres K.
    pub k: usize,
    /// σ as a multiple of the median nearest-neighbour distance between centres.
    pub sigma_mult: f64,
    /// Ridge penalty per sample: α of Eq. 7 = alpha_rel × n_train.
    pub alpha_rel: f64,
    /// Whether stage 2 keeps the quadratic and cross terms.
    pub cross_terms: bool,
}

/// The candidates cross-validation tries: every combination of a feature set (with each dead
/// band for a set that uses the latches), a number of centres, a σ multiple and a ridge
/// penalty. Built by [`super::options::TrainOptionsBuilder`], which refuses an empty grid.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CvGrid {
    pub(super) feature_sets: Vec<FeatureSet>,
    pub(super) centres: Vec<usize>,
    pub(super) sigma_mults: Vec<f64>,
    pub(super) alpha_rels: Vec<f64>,
    pub(super) dead_bands_pm: Vec<f64>,
}

impl Default for CvGrid {
    fn default() -> Self {
        CvGrid {
            feature_sets: vec![FeatureSet::HysteresisAware],
            // The device step's 2 500-instruction budget holds the default model's memory bank
            // with up to 8 centres, not 16 (`cargo xtask bench`, device part), and on the `paper`
            // seeds K = 16 gained about a per cent of RMSE over K <= 8: the default grid stops at
            // 8.
            centres: vec![4, 8],
            sigma_mults: vec![0.5, 1.0, 2.0, 4.0],
            alpha_rels: vec![1e-6, 1e-5, 1e-4, 1e-3, 1e-2],
            dead_bands_pm: vec![1.0, 2.0, 4.0, 8.0],
        }
    }
}

impl CvGrid {
    /// The one-point grid of `cfg` (its `cross_terms` is an option, not a grid entry).
    pub fn fixed(cfg: &Config) -> Self {
        CvGrid {
            feature_sets: vec![cfg.feature_set],
            centres: vec![cfg.k],
            sigma_mults: vec![cfg.sigma_mult],
            alpha_rels: vec![cfg.alpha_rel],
            dead_bands_pm: vec![cfg.dead_band_pm],
        }
    }

    /// The RBF feature sets.
    pub fn feature_sets(&self) -> &[FeatureSet] {
        &self.feature_sets
    }
    /// Numbers of RBF centres K.
    pub fn centres(&self) -> &[usize] {
        &self.centres
    }
    /// σ multiples (of the median nearest-neighbour distance between centres).
    pub fn sigma_mults(&self) -> &[f64] {
        &self.sigma_mults
    }
    /// Ridge penalties per sample.
    pub fn alpha_rels(&self) -> &[f64] {
        &self.alpha_rels
    }
    /// Direction-latch dead bands \[pm\].
    pub fn dead_bands_pm(&self) -> &[f64] {
        &self.dead_bands_pm
    }

    /// The (feature set, dead band) pairs: each dead band for a set that uses the latches, one
    /// (the first, or 2 pm without any) for the `paper` set, which ignores it.
    pub(crate) fn bands(&self) -> Vec<(FeatureSet, f64)> {
        let mut bands = Vec::new();
        for &set in &self.feature_sets {
            if set.uses_latch() {
                for &db in &self.dead_bands_pm {
                    bands.push((set, db));
                }
            } else {
                bands.push((set, self.dead_bands_pm.first().copied().unwrap_or(2.0)));
            }
        }
        bands
    }

    /// The dead bands of [`CvGrid::bands`], sorted, each once.
    pub(crate) fn distinct_dead_bands(&self) -> Vec<f64> {
        let mut dbs: Vec<f64> = self.bands().iter().map(|b| b.1).collect();
        dbs.sort_by(f64::total_cmp);
        dbs.dedup();
        dbs
    }

    /// Number of grid points.
    pub fn len(&self) -> usize {
        self.bands().len() * self.centres.len() * self.sigma_mults.len() * self.alpha_rels.len()
    }

    /// Whether the grid has no point (what a [`super::TrainOptionsBuilder`] refuses).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The first point of the grid: the choice of a one-point grid.
    pub(crate) fn first(&self, cross_terms: bool) -> Option<Config> {
        let &(feature_set, dead_band_pm) = self.bands().first()?;
        Some(Config {
            feature_set,
            dead_band_pm,
            k: *self.centres.first()?,
            sigma_mult: *self.sigma_mults.first()?,
            alpha_rel: *self.alpha_rels.first()?,
            cross_terms,
        })
    }

    /// Refuse a grid without any point, naming the entry that leaves it empty.
    pub(crate) fn check(&self) -> Result<(), TrainerError> {
        let empty = |what: &str| Err(TrainerError::options(format!("empty hyper-parameter grid: no {what}")));
        if self.feature_sets.is_empty() {
            return empty("feature_sets");
        }
        if self.bands().is_empty() {
            return empty("dead_bands_pm for the latch feature sets");
        }
        if self.centres.is_empty() {
            return empty("centres");
        }
        if self.sigma_mults.is_empty() {
            return empty("sigma_mults");
        }
        if self.alpha_rels.is_empty() {
            return empty("alpha_rels");
        }
        Ok(())
    }
}
