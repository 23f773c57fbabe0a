//! Fitting Model-P and Model-H (DESIGN §4) with hyper-parameter selection by blocked
//! time-series cross-validation inside the calibration batch.
//!
//! All predictions go through `fbg_shared::Compensator<f64, _>`, the same code the device runs
//! in f32: the trainer never implements inference a second time. The design matrix Ψ is
//! collected from that code too (`Compensator::core_and_activations`, see [`design`]).

pub mod band;
pub mod design;
pub mod features;
pub mod field;
pub mod kmeans;
pub mod linalg;
pub mod memory_core;
pub mod outcome;
pub mod poly_core;
pub mod recalibrate;
pub mod select;
pub mod sensitivity;
pub mod static_fidelity;

use heapless::Vec as HVec;
use nalgebra::DMatrix;
use rayon::prelude::*;

use fbg_shared::layout::{Dims, FeatureSet, MAX_ENVELOPE, MAX_GRATINGS, MAX_OUTPUTS, MAX_Z, VAR_RANK};
use fbg_shared::{Centre, Compensator, Hyper, ModelParams, Provenance};

use crate::data::import::OnError;
use crate::data::outliers::{self, Outlier};
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::rng::{Rng, Stream};
pub use band::VarModel;
pub use design::{design_matrix, run, run_on_clock, CheckpointCache, Checkpoints, Gram};
pub use features::FeatureChoice;
pub use outcome::Chosen;
pub use poly_core::PolyCore;
pub use select::{Selection, TrainOptions};

/// Centre capacity of host-side models (the device's capacity is its own const generic).
pub const HOST_CAP: usize = 128;
/// A model on the host: f64, up to [`HOST_CAP`] centres.
pub type HostParams = ModelParams<f64, HOST_CAP>;
/// A compensator on the host.
pub type HostCompensator = Compensator<f64, HOST_CAP>;

/// Envelope margin: fraction of the calibration range added on each side.
pub const ENVELOPE_MARGIN: f64 = 0.10;
/// Band factor for flagged samples.
pub const FLAGGED_BAND_FACTOR: f64 = 2.0;
/// At most this many points go into k-means (an even stride through the training set).
pub const KMEANS_MAX_POINTS: usize = 20_000;

/// One point of the hyper-parameter grid.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Config {
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

/// What the training knows about its data, for the model's provenance.
#[derive(Clone, Debug, Default)]
pub struct Origin {
    pub scenario: String,
    pub seed: u64,
}

/// The RBF inputs [Δλ_1..N, T_amb (with ambient), t, latch_1..N] of sample `i` with its latch
/// values (0 beyond [`Dims::z_len`]).
pub fn z_of(dims: &Dims, d: &Dataset, i: usize, latch: &[f64; MAX_GRATINGS]) -> [f64; MAX_Z] {
    let n = dims.gratings();
    let mut z = [0.0; MAX_Z];
    for (o, c) in z.iter_mut().zip(&d.dl_pm).take(n) {
        *o = c[i];
    }
    if dims.ambient() {
        z[n] = d.ambient()[i];
    }
    z[dims.z_time()] = d.t_s[i];
    z[dims.z_latch()..dims.z_latch() + n].copy_from_slice(&latch[..n]);
    z
}

/// What the RBF layer learns from a training set before any centre exists: the mean and
/// standard deviation of every RBF input over the training rows, and the raw inputs of the
/// rows k-means clusters (every `stride`-th training row, at most [`KMEANS_MAX_POINTS`]).
#[derive(Clone, Debug)]
pub struct ZSample {
    /// The inputs' layout.
    pub dims: Dims,
    pub mean: [f64; MAX_Z],
    /// Population standard deviation (1 where an input is constant or beyond the inputs).
    pub std: [f64; MAX_Z],
    pub points: Vec<[f64; MAX_Z]>,
}

/// [`ZSample`] of the training rows `src` (sorted), the latches moved by `stream` (a model
/// with the dead band in question) over every sample from the first, exactly as the
/// compensator moves them (or taken from a [`design::CoreStream`] of that stream).
pub fn z_sample(stream: &HostParams, d: &Dataset, src: design::Rows<'_>) -> Result<ZSample, TrainerError> {
    let train = src.rows();
    let stride = train.len().div_ceil(KMEANS_MAX_POINTS).max(1);
    // Per stretch: count, mean and sum of squared deviations (combined below in stretch order
    // by Chan's formula), and the k-means points.
    type Part = (f64, [f64; MAX_Z], [f64; MAX_Z], Vec<[f64; MAX_Z]>);
    let dims = stream.dims;
    let parts: Vec<Part> = design::map_rows(stream, d, src, |o| {
        let p0 = train.partition_point(|&i| i < o.rows[0]);
        let zs: Vec<[f64; MAX_Z]> = o.rows.iter().zip(o.latches).map(|(&i, l)| z_of(&dims, d, i, l)).collect();
        let n = zs.len() as f64;
        let mean: [f64; MAX_Z] = std::array::from_fn(|k| zs.iter().map(|z| z[k]).sum::<f64>() / n);
        let m2: [f64; MAX_Z] = std::array::from_fn(|k| zs.iter().map(|z| (z[k] - mean[k]).powi(2)).sum::<f64>());
        let pts = zs.iter().enumerate().filter(|(r, _)| (p0 + r) % stride == 0).map(|(_, z)| *z).collect();
        (n, mean, m2, pts)
    })?;
    let (mut n, mut mean, mut m2) = (0.0f64, [0.0; MAX_Z], [0.0; MAX_Z]);
    let mut points = Vec::new();
    for (nb, mb, m2b, pts) in parts {
        let tot = n + nb;
        for k in 0..dims.z_len() {
            let delta = mb[k] - mean[k];
            mean[k] += delta * nb / tot;
            m2[k] += m2b[k] + delta * delta * n * nb / tot;
        }
        n = tot;
        points.extend(pts);
    }
    let std = std::array::from_fn(|k| if m2[k] > 0.0 { (m2[k] / n).sqrt() } else { 1.0 });
    Ok(ZSample { dims, mean, std, points })
}

/// Centres by k-means++ (seeded) over the standardised k-means points of `zs`, on the inputs
/// the feature set uses.
pub fn centres(zs: &ZSample, fs: FeatureSet, k: usize, seed: u64) -> Vec<[f64; MAX_Z]> {
    let active = zs.dims.z_active(fs);
    let used: Vec<usize> = (0..MAX_Z).filter(|&d| active[d]).collect();
    let mut rng = Rng::new(seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15), Stream::Kmeans);
    // k-means on the used inputs only, packed in order (the unused ones would only add exact
    // zeros to every distance): a paper-shaped model clusters in 8 dimensions, not MAX_Z.
    if used.len() <= 8 {
        packed_centres::<8>(zs, &used, k, &mut rng)
    } else if used.len() <= 12 {
        packed_centres::<12>(zs, &used, k, &mut rng)
    } else {
        packed_centres::<MAX_Z>(zs, &used, k, &mut rng)
    }
}

/// [`centres`] with the `used` inputs packed into `D` dimensions, unpacked into the model's
/// layout afterwards.
fn packed_centres<const D: usize>(zs: &ZSample, used: &[usize], k: usize, rng: &mut Rng) -> Vec<[f64; MAX_Z]> {
    let pts: Vec<[f64; D]> = zs
        .points
        .iter()
        .map(|z| {
            let mut p = [0.0; D];
            for (o, &d) in p.iter_mut().zip(used) {
                *o = (z[d] - zs.mean[d]) / zs.std[d];
            }
            p
        })
        .collect();
    kmeans::kmeans_pp(&pts, k.min(pts.len()), rng, 100)
        .into_iter()
        .map(|c| {
            let mut full = [0.0; MAX_Z];
            for (&v, &d) in c.iter().zip(used) {
                full[d] = v;
            }
            full
        })
        .collect()
}

/// Median (the upper one for an even count) distance from each centre to its nearest other
/// centre (standardised units).
pub fn median_nn_distance(cs: &[[f64; MAX_Z]]) -> f64 {
    if cs.len() < 2 {
        return 1.0;
    }
    let nn: Vec<f64> = cs
        .iter()
        .enumerate()
        .map(|(i, a)| {
            cs.iter()
                .enumerate()
                .filter(|(j, _)| *j != i)
                .map(|(_, b)| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>().sqrt())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let m = crate::stats::upper_median(&nn);
    if m > 0.0 {
        m
    } else {
        1.0
    }
}

/// Calibration envelope of [Δλ_1..N, T_amb (with ambient)] over `idx` with
/// [`ENVELOPE_MARGIN`], rounded outwards to f32 so that host and device compare against the
/// same bounds (0 beyond [`Dims::envelope_len`]).
pub fn envelope(d: &Dataset, idx: &[usize]) -> ([f64; MAX_ENVELOPE], [f64; MAX_ENVELOPE]) {
    let mut cols: Vec<&[f64]> = d.dl_pm.iter().map(|c| c.as_slice()).collect();
    if let Some(a) = &d.t_amb_c {
        cols.push(a);
    }
    let (mn, mx) = idx
        .par_chunks(16_384)
        .map(|ch| {
            let mut mn = [f64::INFINITY; MAX_ENVELOPE];
            let mut mx = [f64::NEG_INFINITY; MAX_ENVELOPE];
            for &i in ch {
                for (c, col) in cols.iter().enumerate() {
                    mn[c] = mn[c].min(col[i]);
                    mx[c] = mx[c].max(col[i]);
                }
            }
            (mn, mx)
        })
        .reduce(
            || ([f64::INFINITY; MAX_ENVELOPE], [f64::NEG_INFINITY; MAX_ENVELOPE]),
            |a, b| (std::array::from_fn(|c| a.0[c].min(b.0[c])), std::array::from_fn(|c| a.1[c].max(b.1[c]))),
        );
    let mut lo = [0.0; MAX_ENVELOPE];
    let mut hi = [0.0; MAX_ENVELOPE];
    for c in 0..cols.len() {
        let m = ENVELOPE_MARGIN * (mx[c] - mn[c]);
        lo[c] = f32_down(mn[c] - m);
        hi[c] = f32_up(mx[c] + m);
    }
    (lo, hi)
}

fn f32_down(v: f64) -> f64 {
    let f = v as f32;
    if (f as f64) > v {
        f.next_down() as f64
    } else {
        f as f64
    }
}
fn f32_up(v: f64) -> f64 {
    let f = v as f32;
    if (f as f64) < v {
        f.next_up() as f64
    } else {
        f as f64
    }
}

/// Everything that defines a model except the residual weights and variance terms.
#[derive(Clone, Debug)]
pub struct Skeleton {
    pub core: PolyCore,
    pub feature_set: FeatureSet,
    pub dead_band_pm: f64,
    pub z_mean: [f64; MAX_Z],
    pub z_std: [f64; MAX_Z],
    pub centres: Vec<[f64; MAX_Z]>,
    pub sigma_mult: f64,
    pub sigma: f64,
    pub envelope: ([f64; MAX_ENVELOPE], [f64; MAX_ENVELOPE]),
}

impl Skeleton {
    /// A model without centres: the polynomial core `core` alone (Model-P), which moves the
    /// direction latches like every model with dead band `dead_band_pm` and the finiteness rule
    /// of `feature_set`, so it also stands for that latch stream (checkpoints, RBF inputs).
    pub fn core_only(
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

    /// Params with the given weights and variance terms (zeros where `None`), and a constant
    /// residual variance per output (0 for outputs beyond `resid_var`).
    pub fn params(
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

    /// [`Skeleton::params`] with a band that grows after `t_cal_end_s`.
    #[allow(clippy::too_many_arguments)]
    pub fn params_with_band(
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
        };
        p.validate().map_err(|e| TrainerError::fit(format!("assembled model is invalid: {e}")))?;
        Ok(p)
    }
}

/// The kept eigen-directions of (ΨᵀΨ + αI)⁻¹ for the predictive variance.
#[derive(Clone, Debug)]
pub struct VarianceTerms {
    pub inv_g: [f64; VAR_RANK],
    pub inv_g_tail: f64,
    /// Per centre, its components of the kept eigenvectors.
    pub v: Vec<[f64; VAR_RANK]>,
}

impl VarianceTerms {
    pub fn from_ridge(sys: &linalg::RidgeSystem, alpha: f64) -> Self {
        let (vals, vecs) = sys.regularised_spectrum(alpha);
        let k = vals.len();
        let kept = k.min(VAR_RANK);
        let mut inv_g = [0.0; VAR_RANK];
        for (o, g) in inv_g.iter_mut().zip(vals.iter()).take(kept) {
            *o = 1.0 / g;
        }
        // The remaining directions are well determined by the calibration data (large g); on
        // in-distribution samples they add about dof/N to the leverage (~0.002 on the paper
        // preset, < 0.5 % of the band), and an upper bound on them is uselessly loose when many
        // eigenvalues sit near α. So they are left out: the kept directions are the ones that
        // grow out of distribution. `evaluate` reports the gap to the exact leverage.
        let inv_g_tail = 0.0;
        let v = (0..k).map(|j| std::array::from_fn(|r| if r < kept { vecs[(j, r)] } else { 0.0 })).collect();
        VarianceTerms { inv_g, inv_g_tail, v }
    }
}

/// Build the skeleton of a model for `cfg` on the training samples `train`.
pub fn skeleton(d: &Dataset, train: &[usize], core: &PolyCore, zs: &ZSample, cfg: &Config, seed: u64) -> Skeleton {
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

/// Residual targets R = y − Model-P(x) on `rows` (n × M) for a model of `dims`, from the core's
/// values there (0 for an output whose reference `d` lacks).
pub fn residual_targets(d: &Dataset, dims: &Dims, rows: &[usize], core_values: &[[f64; MAX_OUTPUTS]]) -> DMatrix<f64> {
    let refs = d.references_of(dims);
    DMatrix::from_fn(rows.len(), dims.n_outputs(), |r, c| design::residual(&refs, rows[r], c, &core_values[r]))
}

/// Weak-support threshold: half the 0.1 % quantile of max ψ over the calibration samples,
/// clamped to [1e-6, 0.1], so that essentially no calibration sample is flagged and a
/// sample less supported than 99.9 % of them is.
pub fn weak_support_threshold(max_psi: &[f64]) -> f64 {
    if max_psi.is_empty() {
        return 0.0;
    }
    let mut mx = max_psi.to_vec();
    let at = (mx.len() as f64 * 0.001) as usize;
    let (_, &mut q, _) = mx.select_nth_unstable_by(at, f64::total_cmp);
    (0.5 * q).clamp(1e-6, 0.1)
}

/// A trained pair of models and how they were chosen.
#[derive(Clone, Debug)]
pub struct Trained {
    pub model_p: HostParams,
    pub model_h: HostParams,
    pub core: PolyCore,
    pub selection: Selection,
    /// Wall time of each phase of the fit \[s\], in order (empty when not fitted here).
    pub phase_seconds: Vec<(&'static str, f64)>,
    /// Both models' static gains and what Model-H's dynamic terms contribute, over the
    /// calibration batch.
    pub static_audit: static_fidelity::StaticAudit,
    /// The outlying reference cells whose calibration rows were left out of the fit
    /// ([`TrainOptions::on_outlier`] skip; empty otherwise).
    pub skipped: Vec<Outlier>,
    /// What the fit finds worth a user's attention ([`outcome::train_warnings`]).
    pub warnings: Vec<crate::warning::Warning>,
}

impl Trained {
    /// What cross-validation chose, with σ, α and the memory terms of the final fit.
    pub fn chosen(&self) -> Chosen {
        Chosen::of(&self.selection, &self.model_h)
    }
}

/// Largest span of a column over the calibration batch still taken as constant: the dataset
/// CSV's resolution (6 decimals).
pub const CONSTANT_SPAN: f64 = 1e-6;

/// A reference that never changes, or a grating that never moves, over the calibration batch
/// leaves the fit without the information it needs (a rank-deficient design whose failure would
/// only name a condition number): refuse it by column name, before any work.
pub fn refuse_constant_columns(d: &Dataset, cal: &[usize]) -> Result<(), TrainerError> {
    let span = |v: &[f64]| {
        let (lo, hi) =
            cal.iter().map(|&i| v[i]).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(x), b.max(x)));
        (hi - lo, lo)
    };
    for r in &d.refs {
        let (name, unit) = (r.measurand.column(), r.measurand.unit());
        let (s, v) = span(&r.values);
        if s <= CONSTANT_SPAN {
            return Err(TrainerError::Dataset {
                message: format!(
                    "column `{name}` is constant ({v} {unit}) over the {} calibration rows: nothing to calibrate that measurand against; \
                     leave the column out (references are optional) or calibrate on a batch where it varies",
                    cal.len()
                ),
            });
        }
    }
    for (g, v) in d.dl_pm.iter().enumerate() {
        let (s, x) = span(v);
        if s <= CONSTANT_SPAN {
            return Err(TrainerError::Dataset {
                message: format!(
                    "column `dl{}_pm` never moves ({x} pm on all {} calibration rows): the grating is dead, unplugged or not in the \
                     map; fix the export or the map",
                    g + 1,
                    cal.len()
                ),
            });
        }
    }
    Ok(())
}

/// The refusal of a calibration batch with outlying reference cells (`found`, by row) from
/// `source`: its first cell's line and column, value and running median, and how many more.
pub fn refuse_outliers(source: &str, found: &[Outlier]) -> TrainerError {
    let Some(first) = found.first() else {
        return TrainerError::Dataset { message: "no reference outliers".into() };
    };
    let rows = outliers::rows_of(found).len();
    TrainerError::data(
        source,
        first.line,
        &first.column,
        format!(
            "reference outlier: {}; {} calibration row{} with outlying reference cells (line{} {}): correct them or empty the cells (an empty reference cell is a missing reference), or train with `--on-error skip` to leave those rows out",
            first.describe(),
            rows,
            if rows == 1 { "" } else { "s" },
            if rows == 1 { "" } else { "s" },
            outliers::first_lines(found)
        ),
    )
}

/// [`train_source`] of a dataset with no file name ("the dataset" in messages).
pub fn train(d: &Dataset, opts: &TrainOptions, origin: &Origin) -> Result<Trained, TrainerError> {
    train_source(d, "the dataset", opts, origin)
}

/// Fit Model-P and Model-H on the calibration samples of `d`, read from `source` (named by the
/// refusal of reference outliers, with the CSV line: [`crate::data::outliers`]). Reference
/// outliers in the calibration rows refuse the batch, or with [`TrainOptions::on_outlier`]
/// skip leave their rows out ([`Trained::skipped`] and a warning say which).
pub fn train_source(d: &Dataset, source: &str, opts: &TrainOptions, origin: &Origin) -> Result<Trained, TrainerError> {
    // The model's dimensions are the data's: a dataset without references cannot be fitted.
    let dims = d.dims(source)?;
    let cal_rows = d.cal_indices();
    let found = outliers::find(d, &cal_rows);
    if !found.is_empty() && opts.on_outlier == OnError::Fail {
        return Err(refuse_outliers(source, &found));
    }
    let skip = outliers::rows_of(&found);
    // Fit on the calibration rows with finite inputs and every available reference, outliers
    // left out.
    let cal: Vec<usize> = cal_rows.into_iter().filter(|&i| d.usable(i) && skip.binary_search(&i).is_err()).collect();
    if cal.len() < 200 {
        let left_out =
            if skip.is_empty() { String::new() } else { format!(", {} with reference outliers left out", skip.len()) };
        return Err(TrainerError::Dataset {
            message: format!(
                "{} usable calibration samples (finite inputs and references{left_out}); at least 200 are needed",
                cal.len()
            ),
        });
    }
    refuse_constant_columns(d, &cal)?;
    let mut phases = PhaseClock::start();
    let selection = select::select(d, &cal, opts)?;
    phases.lap("cross-validation");
    let cfg = selection.chosen;
    let provenance = provenance(origin, cal.len());

    // Final fit on the whole calibration batch.
    let core0 = poly_core::fit(d, &cal, cfg.cross_terms)?;
    let core = memory_core::fit(d, &cal, &core0, &opts.memory.menu, &selection.memory)?;
    let core_p = if cfg.cross_terms { core0 } else { poly_core::fit(d, &cal, true)? };
    phases.lap("polynomial core");
    // The latch stream of the chosen dead band, once for the RBF inputs and the design.
    let stream = Skeleton::core_only(d, &cal, &core, cfg.feature_set, cfg.dead_band_pm).params(
        None,
        0.0,
        None,
        &[],
        0.0,
        &provenance,
    )?;
    let end = cal.last().map(|&i| i + 1).unwrap_or(0);
    let ck = Checkpoints::new(&stream, d, end, &[])?;
    let zs = z_sample(&stream, d, design::Rows::Live(&cal, Some(&ck)))?;
    let sk = skeleton(d, &cal, &core, &zs, &cfg, opts.seed);
    phases.lap("RBF inputs and centres");
    let base = sk.params(None, 0.0, None, &[], 0.0, &provenance)?;
    let gram = design::gram(&base, d, &cal, Some(&ck))?;
    phases.lap("RBF design and ridge");
    let sys = linalg::RidgeSystem::from_gram(gram.g, &gram.psi_r, gram.n);
    let alpha = cfg.alpha_rel * cal.len() as f64;
    let w = sys.weights(alpha);
    let var = VarianceTerms::from_ridge(&sys, alpha);
    let thr = if sk.centres.is_empty() { 0.0 } else { weak_support_threshold(&gram.max_psi) };
    let t_end = cal.last().map(|&i| d.t_s[i]).unwrap_or(0.0);
    let mut model_h =
        sk.params_with_band(Some(&w), alpha, Some(&var), &selection.var_model_h, t_end, thr, &provenance)?;

    let sk_p = Skeleton { core: core_p.clone(), centres: vec![], ..sk };
    let mut model_p = sk_p.params_with_band(None, 0.0, None, &selection.var_model_p, t_end, 0.0, &provenance)?;
    model_h.field = field::context(&model_h, d, &cal, &selection.var_model_h, &selection.cv_rmse_h);
    model_p.field = field::context(&model_p, d, &cal, &selection.var_model_p, &selection.cv_rmse_p);
    for m in [&model_h, &model_p] {
        m.validate().map_err(|e| TrainerError::fit(format!("assembled model is invalid: {e}")))?;
    }
    let static_audit = static_fidelity::StaticAudit::of(&model_p, &model_h, d, &cal)?;
    phases.lap("assembly and static audit");
    let warnings = outcome::train_warnings(&dims, &selection, &static_audit, &found);
    Ok(Trained {
        model_p,
        model_h,
        core: core_p,
        selection,
        phase_seconds: phases.laps,
        static_audit,
        skipped: found,
        warnings,
    })
}

/// Wall time per phase.
struct PhaseClock {
    last: std::time::Instant,
    laps: Vec<(&'static str, f64)>,
}

impl PhaseClock {
    fn start() -> Self {
        PhaseClock { last: std::time::Instant::now(), laps: Vec::new() }
    }
    /// Close the phase that ran since the last lap.
    fn lap(&mut self, what: &'static str) {
        let now = std::time::Instant::now();
        self.laps.push((what, (now - self.last).as_secs_f64()));
        self.last = now;
    }
}

fn provenance(origin: &Origin, n_cal: usize) -> Provenance {
    let mut scenario = heapless::String::new();
    for ch in origin.scenario.chars() {
        if scenario.push(ch).is_err() {
            break;
        }
    }
    let mut trainer_version = heapless::String::new();
    for ch in env!("CARGO_PKG_VERSION").chars() {
        if trainer_version.push(ch).is_err() {
            break;
        }
    }
    Provenance { seed: origin.seed, scenario, trainer_version, date_yyyymmdd: today_yyyymmdd(), n_cal: n_cal as u32 }
}

/// Today's date (UTC) as YYYYMMDD, or `SOURCE_DATE_EPOCH`'s for reproducible builds.
pub fn today_yyyymmdd() -> u32 {
    let secs = std::env::var("SOURCE_DATE_EPOCH").ok().and_then(|s| s.parse::<u64>().ok()).unwrap_or_else(|| {
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs()).unwrap_or(0)
    });
    let days = (secs / 86_400) as i64;
    // Civil-from-days (H. Hinnant).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let dd = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = if m <= 2 { y + 1 } else { y };
    (y * 10_000 + m * 100 + dd) as u32
}

/// Parallel map helper used by selection and sweeps (rayon, order preserved).
pub fn par_map<T: Sync, U: Send>(items: &[T], f: impl Fn(&T) -> U + Sync + Send) -> Vec<U> {
    items.par_iter().map(f).collect()
}
