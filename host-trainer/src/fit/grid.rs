//! The hyper-parameters cross-validation chooses from: one point of the grid ([`Config`]) and
//! the grid itself ([`CvGrid`]), the candidates of every hyper-parameter.

use fbg_shared::bounds::{INPUT_MAX, INV_G_MAX, STANDARDISED_MAX};
use fbg_shared::layout::FeatureSet;

use crate::error::{ShortNumber, TrainerError};

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

    /// Refuse a grid without any point, naming the entry that leaves it empty, or with a value a
    /// model blob cannot carry ([`HyperParam`]), naming the entry and the value.
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
        for (param, values) in [
            (HyperParam::SigmaMult, &self.sigma_mults),
            (HyperParam::AlphaRel, &self.alpha_rels),
            (HyperParam::DeadBandPm, &self.dead_bands_pm),
        ] {
            for &v in values {
                param.check(v, &format!("hyper-parameter grid: {}", param.grid_entry()))?;
            }
        }
        Ok(())
    }
}

/// A hyper-parameter of the grid that the model blob carries and bounds. The range each accepts
/// is the one the blob's check (`fbg_shared::ModelParams::validate`, [`fbg_shared::bounds`])
/// accepts for the value it stores: σ's multiple as it is, α = alpha_rel · n (n ≥ 1 calibration
/// samples), the dead band as it is. A value outside it is refused before any work, naming the
/// option, rather than by the assembled model's check after the whole fit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum HyperParam {
    /// σ as a multiple of the median nearest-neighbour distance: above 0, at most
    /// [`STANDARDISED_MAX`].
    SigmaMult,
    /// Ridge penalty per calibration sample: 0 to [`INV_G_MAX`] (α = alpha_rel · n must stay
    /// within it; a large batch lowers the largest alpha_rel a fit can use).
    AlphaRel,
    /// Direction-latch dead band \[pm\]: 0 to [`INPUT_MAX`].
    DeadBandPm,
}

impl HyperParam {
    /// Whether a model blob can carry `v` (NaN and infinities never).
    pub fn accepts(self, v: f64) -> bool {
        match self {
            HyperParam::SigmaMult => v > 0.0 && v <= STANDARDISED_MAX,
            HyperParam::AlphaRel => (0.0..=INV_G_MAX).contains(&v),
            HyperParam::DeadBandPm => (0.0..=INPUT_MAX).contains(&v),
        }
    }

    /// The accepted range in words (`in 0..=1e12`), after "must be".
    pub fn range(self) -> String {
        match self {
            HyperParam::SigmaMult => format!("above 0 and at most {STANDARDISED_MAX:e}"),
            HyperParam::AlphaRel => format!("in 0..={INV_G_MAX:e}"),
            HyperParam::DeadBandPm => format!("in 0..={INPUT_MAX:e}"),
        }
    }

    /// `Ok` when `v` is accepted, else an option's error naming it as `name` (`--alpha-rel`,
    /// Python's `fixed['alpha_rel']`): `NAME must be in 0..=1e12 (got -1)`.
    pub fn check(self, v: f64, name: &str) -> Result<(), TrainerError> {
        if self.accepts(v) {
            return Ok(());
        }
        Err(TrainerError::options(format!("{name} must be {} (got {})", self.range(), ShortNumber(v))))
    }

    /// The [`CvGrid`] entry holding its candidates (`alpha_rels`).
    pub fn grid_entry(self) -> &'static str {
        match self {
            HyperParam::SigmaMult => "sigma_mults",
            HyperParam::AlphaRel => "alpha_rels",
            HyperParam::DeadBandPm => "dead_bands_pm",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fbg_shared::{Error, ModelParams};

    /// The field the blob's check refuses first when the one hyper-parameter `param` is `v`
    /// and the others (σ, its multiple, α, the dead band) are valid.
    fn blob_refuses(param: HyperParam, v: f64) -> bool {
        let mut p = ModelParams::<f64, 4>::empty();
        (p.hyper.sigma, p.hyper.sigma_mult, p.hyper.alpha, p.hyper.dead_band_pm) = (1.0, 1.0, 0.0, 0.0);
        let field = match param {
            HyperParam::SigmaMult => {
                p.hyper.sigma_mult = v;
                "hyper.sigma_mult"
            }
            // α = alpha_rel · n: a single calibration sample carries alpha_rel itself.
            HyperParam::AlphaRel => {
                p.hyper.alpha = v;
                "hyper.alpha"
            }
            HyperParam::DeadBandPm => {
                p.hyper.dead_band_pm = v;
                "hyper.dead_band_pm"
            }
        };
        matches!(p.validate(), Err(Error::BadParameter { field: f }) if f == field)
    }

    #[test]
    fn the_ranges_are_the_blobs() {
        let values = [
            f64::NAN,
            f64::NEG_INFINITY,
            -1.0,
            -0.0,
            0.0,
            1e-12,
            2.0,
            1e6,
            1e6 * (1.0 + f64::EPSILON),
            1e12,
            1.1e12,
            f64::INFINITY,
        ];
        for param in [HyperParam::SigmaMult, HyperParam::AlphaRel, HyperParam::DeadBandPm] {
            for v in values {
                assert_eq!(param.accepts(v), !blob_refuses(param, v), "{param:?} = {v}");
                assert_eq!(param.check(v, "--x").is_ok(), param.accepts(v));
            }
        }
        let e = HyperParam::AlphaRel.check(-1.0, "--alpha-rel").unwrap_err().to_string();
        assert_eq!(e, "--alpha-rel must be in 0..=1e12 (got -1)");
        let e = HyperParam::SigmaMult.check(f64::NAN, "fixed['sigma_mult']").unwrap_err().to_string();
        assert_eq!(e, "fixed['sigma_mult'] must be above 0 and at most 1e6 (got NaN)");
    }
}
