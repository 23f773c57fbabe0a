//! A model's skeleton: everything that defines it except the residual weights and the variance
//! terms (the polynomial core, the RBF inputs' scaling, the centres and σ, the envelope), and
//! its assembly into [`HostParams`] once those are known.

use heapless::Vec as HVec;
use nalgebra::DMatrix;

use fbg_shared::layout::{FeatureSet, MAX_ENVELOPE, MAX_OUTPUTS, MAX_Z, VAR_RANK};
use fbg_shared::{Centre, Hyper, ModelParams, Provenance};

use super::band::VarModel;
use super::envelope::{envelope, ENVELOPE_MARGIN};
use super::grid::Config;
use super::host::{HostParams, HOST_CAP};
use super::poly_core::PolyCore;
use super::rbf_inputs::{centres, median_nn_distance, ZSample};
use super::variance::VarianceTerms;
use crate::data::Dataset;
use crate::error::TrainerError;

/// Band factor for flagged samples.
pub(crate) const FLAGGED_BAND_FACTOR: f64 = 2.0;

/// Everything that defines a model except the residual weights and variance terms.
#[derive(Clone, Debug)]
pub(crate) struct Skeleton {
    pub(crate) core: PolyCore,
    pub(crate) feature_set: FeatureSet,
    pub(crate) dead_band_pm: f64,
    pub(crate) z_mean: [f64; MAX_Z],
    pub(crate) z_std: [f64; MAX_Z],
    pub(crate) centres: Vec<[f64; MAX_Z]>,
    pub(crate) sigma_mult: f64,
    pub(crate) sigma: f64,
    pub(crate) envelope: ([f64; MAX_ENVELOPE], [f64; MAX_ENVELOPE]),
}

impl Skeleton {
    /// A model without centres: the polynomial core `core` alone (Model-P), which moves the
    /// direction latches like every model with dead band `dead_band_pm` and the finiteness rule
    /// of `feature_set`, so it also stands for that latch stream (checkpoints, RBF inputs).
    pub(crate) fn core_only(
        d: &Dataset,
        train: &[usize],
        core: &PolyCore,
        feature_set: FeatureSet,
        dead_band_pm: f64,
    ) -> Self {
        Skeleton {
            core: core.clone(),
            feature_set,
            dead_band_pm,
            z_mean: [0.0; MAX_Z],
            z_std: std::array::from_fn(|k| if k < core.dims.z_len() { 1.0 } else { 0.0 }),
            centres: vec![],
            sigma_mult: 1.0,
            sigma: 1.0,
            envelope: envelope(d, train),
        }
    }

    /// The skeleton of a model for `cfg` on the training samples `train`: the RBF inputs'
    /// scaling from `zs` and centres by seeded k-means++.
    pub(crate) fn build(
        d: &Dataset,
        train: &[usize],
        core: &PolyCore,
        zs: &ZSample,
        cfg: &Config,
        seed: u64,
    ) -> Skeleton {
        let active = core.dims.z_active(cfg.feature_set);
        let n_z = core.dims.z_len();
        let z_mean = std::array::from_fn(|k| if active[k] { zs.mean[k] } else { 0.0 });
        let z_std = std::array::from_fn(|k| {
            if active[k] {
                zs.std[k]
            } else if k < n_z {
                1.0
            } else {
                0.0
            }
        });
        let cs = centres(zs, cfg.feature_set, cfg.k, seed);
        let nn = median_nn_distance(&cs);
        Skeleton {
            core: core.clone(),
            feature_set: cfg.feature_set,
            dead_band_pm: cfg.dead_band_pm,
            z_mean,
            z_std,
            centres: cs,
            sigma_mult: cfg.sigma_mult,
            sigma: cfg.sigma_mult * nn,
            envelope: envelope(d, train),
        }
    }

    /// Params with the given weights and variance terms (zeros where `None`), and a constant
    /// residual variance per output (0 for outputs beyond `resid_var`).
    pub(crate) fn params(
        &self,
        weights: Option<&DMatrix<f64>>,
        alpha: f64,
        variance: Option<&VarianceTerms>,
        resid_var: &[f64],
        weak_support: f64,
        provenance: &Provenance,
    ) -> Result<HostParams, TrainerError> {
        let band: Vec<VarModel> = resid_var.iter().map(|&v| VarModel::constant(v)).collect();
        self.params_with_band(weights, alpha, variance, &band, 0.0, weak_support, provenance)
    }

    /// The params of a model without weights: the stream rule alone (checkpoints, RBF inputs,
    /// the core's answers).
    pub(crate) fn bare_params(&self, provenance: &Provenance) -> Result<HostParams, TrainerError> {
        self.params(None, 0.0, None, &[], 0.0, provenance)
    }

    /// [`Skeleton::params`] with a band that grows after `t_cal_end_s`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn params_with_band(
        &self,
        weights: Option<&DMatrix<f64>>,
        alpha: f64,
        variance: Option<&VarianceTerms>,
        band: &[VarModel],
        t_cal_end_s: f64,
        weak_support: f64,
        provenance: &Provenance,
    ) -> Result<HostParams, TrainerError> {
        let dims = self.core.dims;
        let m = dims.n_outputs();
        let mut cs: HVec<Centre<f64>, HOST_CAP> = HVec::new();
        for (j, mu) in self.centres.iter().enumerate() {
            let w = weights
                .map(|w| std::array::from_fn(|o| if o < m { w[(j, o)] } else { 0.0 }))
                .unwrap_or([0.0; MAX_OUTPUTS]);
            let v = variance.map(|v| v.v[j]).unwrap_or([0.0; VAR_RANK]);
            cs.push(Centre { mu: *mu, w, v }).map_err(|_| {
                TrainerError::fit(format!("{} centres exceed the host capacity {HOST_CAP}", self.centres.len()))
            })?;
        }
        // An output without a band model gets the constant one of zero variance.
        let zero = VarModel::constant(0.0);
        let per_output = |f: &dyn Fn(&VarModel) -> f64| -> [f64; MAX_OUTPUTS] {
            std::array::from_fn(|o| if o < m { f(band.get(o).unwrap_or(&zero)) } else { 0.0 })
        };
        let p = ModelParams {
            dims,
            hyper: Hyper {
                feature_set: self.feature_set,
                sigma_mult: self.sigma_mult,
                sigma: self.sigma,
                alpha,
                dead_band_pm: self.dead_band_pm,
                weak_support,
                envelope_margin: ENVELOPE_MARGIN,
                flagged_band_factor: FLAGGED_BAND_FACTOR,
            },
            stage1: self.core.stage1,
            guess_mean: self.core.guess_mean,
            guess_std: self.core.guess_std,
            poly: self.core.poly,
            memory: self.core.memory,
            gamma: self.core.gamma,
            z_mean: self.z_mean,
            z_std: self.z_std,
            centres: cs,
            var_inv_g: variance.map(|v| v.inv_g).unwrap_or([0.0; VAR_RANK]),
            var_inv_g_tail: variance.map(|v| v.inv_g_tail).unwrap_or(0.0),
            resid_var: per_output(&|v| v.a),
            resid_var_growth: per_output(&|v| v.b),
            t_cal_end_s,
            band_k: per_output(&|v| v.k95),
            envelope_lo: self.envelope.0,
            envelope_hi: self.envelope.1,
            fitted: std::array::from_fn(|o| o < m),
            provenance: provenance.clone(),
            // Filled in by `train` once the model is final (`field::context`).
            field: fbg_shared::FieldContext::unknown(),
            // Filled in by `train` for Model-H (`trust::spec`).
            trust: fbg_shared::TrustSpec::off(),
        };
        p.validate().map_err(|e| TrainerError::fit(format!("assembled model is invalid: {e}")))?;
        Ok(p)
    }
}
