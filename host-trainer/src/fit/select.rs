//! Hyper-parameter selection by blocked time-series cross-validation inside the calibration
//! batch (DESIGN §4). The hold-out is never touched here.
//!
//! The calibration samples are cut into `blocks` contiguous blocks in time; fold f trains on
//! blocks 0..f and validates on all later blocks (forward chaining, f = min_train_blocks..
//! blocks), so every validation lies later in time than its training data, as the hold-out
//! does, and at lead times up to most of the calibration span. The score of a configuration
//! is Σ over the model's outputs of RMSE_H / RMSE_P over all validation samples (scale free, so
//! no channel dominates).
//!
//! Band variances: for the chosen configuration (and for Model-P) the squared validation errors
//! and their lead times go to [`super::band::VarModel`]; the model carries its a and b and the
//! device widens its band with the time since calibration.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use nalgebra::DMatrix;
use rayon::prelude::*;

use fbg_shared::layout::{Dims, FeatureSet, MAX_OUTPUTS};
use fbg_shared::Provenance;

use super::band::VarModel;
use super::design::{self, CheckpointCache};
use super::grid::Config;
use super::host::HostParams;
use super::linalg;
use super::memory_core::{self, MemoryChoice, MemoryCvRow};
use super::options::TrainOptions;
use super::poly_core::{self, PolyCore};
use super::random_walk::{self, StructureSums, WalkGrowth};
use super::rbf_inputs::{z_sample, ZSample};
use super::residual::residual_targets;
use super::sensitivity;
use super::skeleton::Skeleton;
use crate::data::Dataset;
use crate::error::TrainerError;

/// One evaluated grid point.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CvRow {
    /// The grid point.
    pub config: Config,
    /// Pooled validation RMSE per output.
    pub cv_rmse: Vec<f64>,
    /// Σ_c RMSE_H,c / RMSE_P,c (lower is better; M = no gain).
    pub score: f64,
}

/// The outcome of selection.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Selection {
    /// The grid point cross-validation chose.
    pub chosen: Config,
    /// The memory terms each output uses (none for the `paper` and `latch` variants).
    pub memory: MemoryChoice,
    /// Every memory menu point evaluated, per output, with its pooled validation RMSE.
    pub memory_rows: Vec<MemoryCvRow>,
    /// Every grid point evaluated, best first (the chosen one alone for a one-point grid).
    pub rows: Vec<CvRow>,
    /// Pooled validation RMSE of Model-P and of the chosen Model-H (with memory terms: over the
    /// folds that scored them).
    pub cv_rmse_p: Vec<f64>,
    /// See [`Selection::cv_rmse_p`].
    pub cv_rmse_h: Vec<f64>,
    /// Band variance model s²(τ) = a + b·τ per output (a in unit², b in unit²/s), Model-P and
    /// Model-H.
    pub var_model_p: Vec<VarModel>,
    /// See [`Selection::var_model_p`].
    pub var_model_h: Vec<VarModel>,
    /// The interrogator drift's walk rate read from Model-P's validation errors \[pm²/s\]
    /// (`None`: validation stretches shorter than the structure function's lags), before any
    /// stated floor; the bands grow by at least s_c²·q_d per output.
    pub drift_rate_pm2_per_s: Option<f64>,
    /// The interrogator's stated stability the bands added \[pm/√day\] (`train --drift-spec`;
    /// absent when not given).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stated_drift_pm_per_sqrt_day: Option<f64>,
    /// The drift's stated gain per grating the walk reached each output with (`train
    /// --drift-gains`; absent when not given: every grating alike).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stated_drift_gains: Option<Vec<f64>>,
    /// Folds as (training samples, validation samples).
    pub folds: Vec<(usize, usize)>,
    /// Calibration samples used.
    pub n_cal: usize,
    /// Stride of the rows the cross-validation used (1 = all).
    pub cv_stride: usize,
}

struct Fold {
    train: Vec<usize>,
    val: Vec<usize>,
}

fn folds(cal: &[usize], blocks: usize, min_train: usize) -> Vec<Fold> {
    let n = cal.len();
    let edge = |b: usize| n * b / blocks;
    (min_train..blocks).map(|f| Fold { train: cal[..edge(f)].to_vec(), val: cal[edge(f)..].to_vec() }).collect()
}

/// Key of a grid point for pooling across folds.
fn key(c: &Config) -> (u8, u64, usize, u64, u64) {
    (c.feature_set.code(), c.dead_band_pm.to_bits(), c.k, c.sigma_mult.to_bits(), c.alpha_rel.to_bits())
}

/// One fold's polynomial core and the end of its training.
struct FoldCore {
    core: PolyCore,
    /// Time of the fold's last training sample [s] (validation leads count from it).
    t_end: f64,
}

/// Validation residuals of one configuration on one fold: per output the squared errors of
/// every validation sample.
type FoldErrors = Vec<Vec<f64>>;

/// One fold's structure sums per output (its errors in the output's unit) and, for the last
/// fold, the common-mode sensitivities.
type FoldWalk = (Vec<StructureSums>, Option<Vec<f64>>);

/// Model-P's pass over the folds.
struct ModelPPass {
    /// Each fold's core.
    fold_core: Vec<FoldCore>,
    /// Each fold's squared validation errors.
    sq_p: Vec<FoldErrors>,
    /// The drift's common walk rate q_d \[pm²/s\] (`None`: validation stretches too short).
    drift_rate_pm2_per_s: Option<f64>,
    /// Per output, the band growth the walk adds \[unit²/s\], read and stated.
    walk_growth: Vec<WalkGrowth>,
}

/// Sum of squared errors.
fn pool(sq: &[f64]) -> f64 {
    sq.iter().sum::<f64>()
}

/// Run the cross-validation and pick the best configuration.
pub(crate) fn select(d: &Dataset, cal: &[usize], opts: &TrainOptions) -> Result<Selection, TrainerError> {
    let cv = Cv::new(d, cal, opts)?;
    let m = cv.dims.n_outputs();
    let grid = opts.grid();
    let dbs = grid.distinct_dead_bands();
    // Model-P's answers do not depend on the dead band: take the grid's first, whose
    // checkpoints the RBF tasks need anyway.
    let first_db = dbs.first().copied().ok_or_else(|| TrainerError::fit("empty hyper-parameter grid"))?;
    let ModelPPass { fold_core, sq_p, drift_rate_pm2_per_s, walk_growth: walk } = cv.model_p_pass(first_db)?;
    let MemoryPass { memory, memory_rows, first_long, fold_core } = cv.choose_memory(fold_core)?;
    let n_val: usize = cv.folds.iter().map(|f| f.val.len()).sum();
    let cv_rmse_p: Vec<f64> =
        (0..m).map(|c| (sq_p.iter().map(|e| e[c].iter().sum::<f64>()).sum::<f64>() / n_val as f64).sqrt()).collect();
    let (lead, fold_of, walk_age) = leads(d, &cv.folds, &fold_core);
    // The final models calibrate on every row: the stated walk's offset at their end.
    let cal_span_s = match (cal.first(), cal.last()) {
        (Some(&i), Some(&j)) => d.t_s[j] - d.t_s[i],
        _ => 0.0,
    };
    let var_model_p: Vec<VarModel> = (0..m)
        .map(|c| {
            let sq: Vec<f64> = sq_p.iter().flat_map(|e| e[c].iter().copied()).collect();
            VarModel::fit(&lead, &sq, &fold_of, walk[c], &walk_age, cal_span_s)
        })
        .collect();

    let search = GridSearch::new(&cv, &fold_core, &dbs)?;
    let (rows, chosen) = if grid.len() > 1 {
        search.rank(&cv_rmse_p)?
    } else {
        let chosen = grid.first(opts.cross_terms()).ok_or_else(|| TrainerError::fit("empty hyper-parameter grid"))?;
        (Vec::new(), chosen)
    };

    // Per-sample validation errors of the chosen configuration, against their lead time.
    let sqe_h = search.chosen_errors(&chosen)?;
    let cv_rmse_h: Vec<f64> = (0..m).map(|c| (pool(&sqe_h[c]) / n_val as f64).sqrt()).collect();
    let rows = if rows.is_empty() {
        let score = (0..m).map(|c| cv_rmse_h[c] / cv_rmse_p[c]).sum();
        vec![CvRow { config: chosen, cv_rmse: cv_rmse_h.clone(), score }]
    } else {
        rows
    };
    // With memory terms, Model-H's band is calibrated on the same long folds that scored them:
    // the short folds' memory coefficients are poorly determined, and their larger errors
    // would widen the band of a final model fitted on the whole batch.
    let band_from = if memory.any() { first_long } else { 0 };
    let errors = ValidationErrors {
        lead: &lead,
        fold_of: &fold_of,
        walk_age: &walk_age,
        sq_p: &sq_p,
        sqe_h: &sqe_h,
        cal_span_s,
    };
    let (var_model_h, cv_rmse_p, cv_rmse_h) = errors.band_h(&cv.folds, band_from, &walk, cv_rmse_p, cv_rmse_h);
    Ok(Selection {
        chosen,
        memory,
        memory_rows,
        cv_rmse_p,
        cv_rmse_h,
        var_model_p,
        var_model_h,
        rows,
        drift_rate_pm2_per_s,
        stated_drift_pm_per_sqrt_day: opts.drift_spec_pm_per_sqrt_day(),
        stated_drift_gains: opts.drift_gains().map(<[f64]>::to_vec),
        folds: cv.folds.iter().map(|f| (f.train.len(), f.val.len())).collect(),
        n_cal: cal.len(),
        cv_stride: cv.stride,
    })
}

/// The cross-validation's layout: the (thinned) calibration rows cut into folds, and the
/// checkpoints every fold resumes from.
struct Cv<'a> {
    d: &'a Dataset,
    opts: &'a TrainOptions,
    dims: Dims,
    /// Stride of the thinned rows (1 = all).
    stride: usize,
    /// Number of thinned rows.
    n_thinned: usize,
    folds: Vec<Fold>,
    cache: CheckpointCache,
    prov: Provenance,
}

/// The memory terms chosen on the folds, and each fold's core refitted with them.
struct MemoryPass {
    memory: MemoryChoice,
    memory_rows: Vec<MemoryCvRow>,
    /// The first fold whose training spans enough of the batch to score memory terms.
    first_long: usize,
    fold_core: Vec<FoldCore>,
}

impl<'a> Cv<'a> {
    /// The folds of `cal` (thinned to at most [`TrainOptions::cv_max_samples`] rows), refused
    /// when too short for the CV blocks.
    fn new(d: &'a Dataset, cal: &[usize], opts: &'a TrainOptions) -> Result<Self, TrainerError> {
        let stride = cal.len().div_ceil(opts.cv_max_samples().max(1)).max(1);
        let thinned: Vec<usize> = cal.iter().copied().step_by(stride).collect();
        let folds = folds(&thinned, opts.blocks(), opts.min_train_blocks());
        if folds.iter().any(|f| f.train.len() < 50 || f.val.is_empty()) {
            return Err(TrainerError::Dataset {
                message: format!("{} calibration samples are too few for {} CV blocks", cal.len(), opts.blocks()),
            });
        }
        let dims = d.dims("the dataset")?;
        // Every fold works on the thinned rows: checkpoints before each of them spare the tasks
        // from moving the latches over the samples in between.
        let n_thinned = thinned.len();
        let cache = CheckpointCache::new(cal.last().map(|&i| i + 1).unwrap_or(0), thinned);
        Ok(Cv { d, opts, dims, stride, n_thinned, folds, cache, prov: Provenance::default() })
    }

    /// A fold's Model-P, which also stands for the latch stream of its dead band.
    fn stream_model(&self, core: &PolyCore, train: &[usize], db: f64) -> Result<HostParams, TrainerError> {
        Skeleton::core_only(self.d, train, core, FeatureSet::HysteresisAware, db).bare_params(&self.prov)
    }

    /// Model-P per fold (always with cross terms: the reference errors) and the fold's core
    /// (without them for the ablation), with Model-P's validation errors; `db` is the dead band
    /// of the latch stream Model-P stands for. Also the drift's walk in the errors
    /// ([`super::random_walk`]): per output the growth s_c²·q_d \[unit²/s\], with s_c the
    /// common-mode sensitivity (Σᵢ gᵢ·∂y/∂λᵢ with the stated drift gains, else Σᵢ ∂y/∂λᵢ) of
    /// the fold with the largest training set.
    fn model_p_pass(&self, db: f64) -> Result<ModelPPass, TrainerError> {
        let (d, m, cross_terms) = (self.d, self.dims.n_outputs(), self.opts.cross_terms());
        let (n, gains) = (self.dims.gratings(), self.opts.drift_gains());
        let last = self.folds.len().saturating_sub(1);
        let per_fold: Result<Vec<(FoldCore, FoldErrors, FoldWalk)>, TrainerError> = self
            .folds
            .par_iter()
            .enumerate()
            .map(|(fi, f)| {
                self.opts.check_cancel()?;
                let core = poly_core::fit(d, &f.train, cross_terms)?;
                let core_full = if cross_terms { core.clone() } else { poly_core::fit(d, &f.train, true)? };
                let p = self.stream_model(&core_full, &f.train, db)?;
                let ck = self.cache.get(&p, d)?;
                let est = design::run_with(&p, d, &f.val, Some(&ck))?;
                // A drift moves every grating (by its stated gain, else alike) and leaves the
                // thermometer: T_amb held. The last fold's (the closest to the final model)
                // serves every fold.
                let common: Option<Vec<f64>> = (fi == last).then(|| {
                    sensitivity::core_jacobian(&p, &[0.0; MAX_OUTPUTS])
                        .iter()
                        .map(|row| match gains {
                            Some(g) => row.iter().zip(g).map(|(j, g)| j * g).sum(),
                            None => row.iter().take(n).sum(),
                        })
                        .collect()
                });
                let t_val: Vec<f64> = f.val.iter().map(|&i| d.t_s[i]).collect();
                let mut walk = vec![StructureSums::default(); m];
                let sq = (0..m)
                    .zip(walk.iter_mut())
                    .map(|(c, w)| {
                        let e: Vec<f64> = est.iter().zip(&f.val).map(|(e, &i)| e.values[c] - d.target(c)[i]).collect();
                        w.add(&t_val, &e);
                        e.iter().map(|e| e * e).collect()
                    })
                    .collect();
                let t_end = f.train.last().map(|&i| d.t_s[i]).unwrap_or(0.0);
                Ok((FoldCore { core, t_end }, sq, (walk, common)))
            })
            .collect();
        let mut walk = vec![StructureSums::default(); m];
        let (mut cores, mut errors, mut common) = (Vec::new(), Vec::new(), Vec::new());
        for (core, sq, (w, s)) in per_fold? {
            cores.push(core);
            errors.push(sq);
            walk.iter_mut().zip(&w).for_each(|(a, b)| a.merge(b));
            common = s.unwrap_or(common);
        }
        let (q_d, growth) = random_walk::growth(&walk, &common, self.opts.drift_spec_rate_pm2_per_s());
        Ok(ModelPPass { fold_core: cores, sq_p: errors, drift_rate_pm2_per_s: q_d, walk_growth: growth })
    }

    /// The memory terms, chosen on the folds' own cores, then each fold's core refitted with
    /// them (Γ on what B leaves): the RBF layer learns what that core leaves.
    fn choose_memory(&self, fold_core: Vec<FoldCore>) -> Result<MemoryPass, TrainerError> {
        let (d, menu) = (self.d, self.opts.memory());
        let mem_folds: Vec<memory_core::FoldInput<'_>> = self
            .folds
            .iter()
            .zip(&fold_core)
            .map(|(f, fc)| memory_core::FoldInput { core: &fc.core, train: &f.train, val: &f.val })
            .collect();
        // Memory terms are scored on the folds whose training spans most of the batch (long
        // time constants and the drift observer need the span; see
        // `MemoryOptions::min_train_fraction`).
        let long = (menu.min_train_fraction * self.n_thinned as f64).ceil() as usize;
        let first_long =
            mem_folds.iter().position(|f| f.train.len() >= long).unwrap_or(mem_folds.len().saturating_sub(1));
        let (memory, memory_rows) = memory_core::select(d, &mem_folds[first_long..], menu)?;
        let fold_core: Vec<FoldCore> = fold_core
            .into_par_iter()
            .zip(self.folds.par_iter())
            .map(|(fc, f)| {
                self.opts.check_cancel()?;
                Ok(FoldCore { core: memory_core::fit(d, &f.train, &fc.core, &menu.menu, &memory)?, t_end: fc.t_end })
            })
            .collect::<Result<_, TrainerError>>()?;
        Ok(MemoryPass { memory, memory_rows, first_long, fold_core })
    }
}

/// A fold's core values and latches at its training and validation rows.
type FoldStreams = (Arc<design::CoreStream>, Arc<design::CoreStream>);

/// The search of the (feature set, dead band, K, σ, α) grid over the folds, with what its
/// tasks share: per fold and dead band the RBF inputs' sample and the fold's streams.
struct GridSearch<'c, 'a> {
    cv: &'c Cv<'a>,
    fold_core: &'c [FoldCore],
    zsamples: HashMap<(usize, u64), ZSample>,
    train_streams: HashMap<(usize, u64), Arc<design::CoreStream>>,
    /// The core's values and the latches at each fold's training and validation rows, per dead
    /// band and stream rule: the same for every K and σ of the grid, and for every feature set
    /// of the same rule. Made by the first task that needs one (two tasks racing may both make
    /// it: the same numbers either way).
    streams: HashMap<(usize, u64), Mutex<Vec<FoldStreams>>>,
}

impl<'c, 'a> GridSearch<'c, 'a> {
    /// What the RBF layer learns from each fold's training rows, per dead band of `dbs`.
    fn new(cv: &'c Cv<'a>, fold_core: &'c [FoldCore], dbs: &[f64]) -> Result<Self, TrainerError> {
        let d = cv.d;
        let mut zjobs = Vec::new();
        for fi in 0..cv.folds.len() {
            for &db in dbs {
                zjobs.push((fi, db));
            }
        }
        // Each fold's training stream per dead band (its core's values and latches, the stream
        // rule of the Model-P that stands for the dead band), run once: the k-means sample
        // comes from its latches, and grid tasks of the same rule take it as it is.
        let seeded: Result<Vec<(Arc<design::CoreStream>, ZSample)>, TrainerError> = zjobs
            .par_iter()
            .map(|&(fi, db)| {
                let f = &cv.folds[fi];
                let sm = cv.stream_model(&fold_core[fi].core, &f.train, db)?;
                let ck = cv.cache.get(&sm, d)?;
                let train = Arc::new(design::CoreStream::new(&sm, d, &f.train, Some(&ck))?);
                let zs = z_sample(&sm, d, design::Rows::Cached(&train))?;
                Ok((train, zs))
            })
            .collect();
        let (train_streams, zsamples): (Vec<_>, Vec<_>) = seeded?.into_iter().unzip();
        let keys: Vec<(usize, u64)> = zjobs.iter().map(|&(fi, db)| (fi, db.to_bits())).collect();
        Ok(GridSearch {
            cv,
            fold_core,
            zsamples: keys.iter().copied().zip(zsamples).collect(),
            train_streams: keys.iter().copied().zip(train_streams).collect(),
            streams: keys.iter().map(|&k| (k, Mutex::new(Vec::new()))).collect(),
        })
    }

    /// The streams of fold `fi` under the stream rule of `p` (dead band `db`).
    fn fold_streams(&self, fi: usize, db: f64, p: &HostParams) -> Result<FoldStreams, TrainerError> {
        let key = (fi, db.to_bits());
        let slot = self.streams.get(&key).ok_or_else(|| TrainerError::fit("fold stream missing"))?;
        let lock = || slot.lock().map_err(|_| TrainerError::fit("fold stream cache poisoned"));
        for s in lock()?.iter() {
            if s.0.serves(p)? {
                return Ok(s.clone());
            }
        }
        let (d, f) = (self.cv.d, &self.cv.folds[fi]);
        let ck = self.cv.cache.get(p, d)?;
        let train = match self.train_streams.get(&key) {
            Some(t) if t.serves(p)? => t.clone(),
            _ => Arc::new(design::CoreStream::new(p, d, &f.train, Some(&ck))?),
        };
        let made = (train, Arc::new(design::CoreStream::new(p, d, &f.val, Some(&ck))?));
        lock()?.push(made.clone());
        Ok(made)
    }

    /// Per-sample squared validation errors of every (σ, α) of one fold, feature set, dead
    /// band and K.
    fn fold_task(
        &self,
        fi: usize,
        (set, db, k): (FeatureSet, f64, usize),
        sigma_mults: &[f64],
        alpha_rels: &[f64],
    ) -> Result<Vec<(Config, FoldErrors)>, TrainerError> {
        let (cv, d) = (self.cv, self.cv.d);
        cv.opts.check_cancel()?;
        let (f, m) = (&cv.folds[fi], cv.dims.n_outputs());
        let fc = &self.fold_core[fi];
        let zs = &self.zsamples[&(fi, db.to_bits())];
        let base_cfg = Config {
            feature_set: set,
            dead_band_pm: db,
            k,
            sigma_mult: 1.0,
            alpha_rel: 0.0,
            cross_terms: cv.opts.cross_terms(),
        };
        let mut sk = Skeleton::build(d, &f.train, &fc.core, zs, &base_cfg, cv.opts.seed());
        let nn = sk.sigma;
        let mut out: Vec<(Config, FoldErrors)> = Vec::new();
        let mut held: Option<FoldStreams> = None;
        for &sm in sigma_mults {
            sk.sigma_mult = sm;
            sk.sigma = sm * nn;
            let p = sk.bare_params(&cv.prov)?;
            // σ does not change the stream rule: one lookup per task.
            let looked_up = match held.take() {
                Some(h) => h,
                None => self.fold_streams(fi, db, &p)?,
            };
            let (train_s, val_s) = held.insert(looked_up);
            let gram = design::gram_rows(&p, d, design::Rows::Cached(train_s))?;
            let (psi_v, est_v) = design::design_rows(&p, d, design::Rows::Cached(val_s))?;
            let r_v = residual_targets(d, &cv.dims, &f.val, &est_v);
            let sys = linalg::RidgeSystem::from_gram(gram.g, &gram.psi_r)?;
            for &ar in alpha_rels {
                let w = sys.weights(ar * f.train.len() as f64);
                let resid: DMatrix<f64> = &r_v - &psi_v * &w;
                let sq = (0..m).map(|c| resid.column(c).iter().map(|e| e * e).collect()).collect();
                out.push((Config { sigma_mult: sm, alpha_rel: ar, ..base_cfg }, sq));
            }
        }
        Ok(out)
    }

    /// Every grid point scored over all folds (pooled validation RMSE against Model-P's
    /// `cv_rmse_p`), best first, and the best.
    fn rank(&self, cv_rmse_p: &[f64]) -> Result<(Vec<CvRow>, Config), TrainerError> {
        let (cv, grid) = (self.cv, self.cv.opts.grid());
        let m = cv.dims.n_outputs();
        let mut tasks = Vec::new();
        for fi in 0..cv.folds.len() {
            for &(set, db) in &grid.bands() {
                for &k in grid.centres() {
                    tasks.push((fi, set, db, k));
                }
            }
        }
        let bar = crate::progress::bar(cv.opts.progress(), tasks.len() as u64, "cross-validation");
        type Acc = Vec<(Config, Vec<f64>, usize)>;
        let results: Result<Vec<Acc>, TrainerError> = tasks
            .par_iter()
            .map(|&(fi, set, db, k)| {
                let out = self.fold_task(fi, (set, db, k), grid.sigma_mults(), grid.alpha_rels())?;
                bar.inc(1);
                Ok(out
                    .into_iter()
                    .map(|(cfg, sq)| {
                        let n = sq[0].len();
                        (cfg, sq.iter().map(|v| pool(v)).collect(), n)
                    })
                    .collect())
            })
            .collect();
        bar.finish_and_clear();
        let mut pooled: HashMap<_, (Config, Vec<f64>, usize)> = HashMap::new();
        for (cfg, sq, n) in results?.into_iter().flatten() {
            let e = pooled.entry(key(&cfg)).or_insert((cfg, vec![0.0; m], 0));
            for (acc, s) in e.1.iter_mut().zip(sq) {
                *acc += s;
            }
            e.2 += n;
        }
        let mut rows: Vec<CvRow> = pooled
            .into_values()
            .map(|(config, sq, n)| {
                let cv_rmse: Vec<f64> = sq.iter().map(|s| (s / n as f64).sqrt()).collect();
                let score = (0..m).map(|c| cv_rmse[c] / cv_rmse_p[c]).sum();
                CvRow { config, cv_rmse, score }
            })
            .collect();
        // Deterministic order: by score, ties by the key.
        rows.sort_by(|a, b| a.score.total_cmp(&b.score).then_with(|| key(&a.config).cmp(&key(&b.config))));
        let chosen = rows.first().map(|r| r.config).ok_or_else(|| TrainerError::fit("empty hyper-parameter grid"))?;
        Ok((rows, chosen))
    }

    /// Per output, the squared validation errors of `chosen` over every fold, in fold order.
    fn chosen_errors(&self, chosen: &Config) -> Result<Vec<Vec<f64>>, TrainerError> {
        let per_fold: Result<Vec<FoldErrors>, TrainerError> = (0..self.cv.folds.len())
            .into_par_iter()
            .map(|fi| {
                let at = (chosen.feature_set, chosen.dead_band_pm, chosen.k);
                let mut out = self.fold_task(fi, at, &[chosen.sigma_mult], &[chosen.alpha_rel])?;
                out.pop().map(|(_, sq)| sq).ok_or_else(|| TrainerError::fit("no validation errors"))
            })
            .collect();
        let per_fold = per_fold?;
        let m = self.cv.dims.n_outputs();
        Ok((0..m).map(|c| per_fold.iter().flat_map(|e| e[c].iter().copied()).collect()).collect())
    }
}

/// The validation errors of both models with their lead times and folds.
struct ValidationErrors<'e> {
    /// Lead of every validation sample after its fold's training [s], in fold order.
    lead: &'e [f64],
    /// Fold of every validation sample.
    fold_of: &'e [usize],
    /// Every validation sample's walk age T/3 + lead [s] (T its fold's training span).
    walk_age: &'e [f64],
    /// Time from the first to the last calibration row [s].
    cal_span_s: f64,
    /// Model-P's squared errors per fold and output.
    sq_p: &'e [FoldErrors],
    /// The chosen Model-H's squared errors per output, over all folds in order.
    sqe_h: &'e [Vec<f64>],
}

impl ValidationErrors<'_> {
    /// Model-H's band model from the folds `band_from..` (too short to show the drift's walk:
    /// its growth is at least `walk`, Model-P's, since the drift moves the gratings under both
    /// models alike), and both models' validation RMSE
    /// (`cv_rmse_p`, `cv_rmse_h` over every fold) as reported: over the same folds.
    fn band_h(
        &self,
        folds: &[Fold],
        band_from: usize,
        walk: &[WalkGrowth],
        cv_rmse_p: Vec<f64>,
        cv_rmse_h: Vec<f64>,
    ) -> (Vec<VarModel>, Vec<f64>, Vec<f64>) {
        let m = self.sqe_h.len();
        let keep: Vec<usize> = (0..self.fold_of.len()).filter(|&r| self.fold_of[r] >= band_from).collect();
        let lead_h: Vec<f64> = keep.iter().map(|&r| self.lead[r]).collect();
        let fold_h: Vec<usize> = keep.iter().map(|&r| self.fold_of[r] - band_from).collect();
        let age_h: Vec<f64> = keep.iter().map(|&r| self.walk_age[r]).collect();
        let var_model_h: Vec<VarModel> = (0..m)
            .map(|c| {
                let sq: Vec<f64> = keep.iter().map(|&r| self.sqe_h[c][r]).collect();
                VarModel::fit(&lead_h, &sq, &fold_h, walk.get(c).copied().unwrap_or_default(), &age_h, self.cal_span_s)
            })
            .collect();
        // The reported validation RMSE of both models (what `train` prints and warns on) comes
        // from the same folds, so that it describes a model fitted on most of the batch.
        if band_from == 0 {
            return (var_model_h, cv_rmse_p, cv_rmse_h);
        }
        let n: usize = folds.iter().skip(band_from).map(|f| f.val.len()).sum();
        let p: Vec<f64> = (0..m)
            .map(|c| {
                (self.sq_p.iter().skip(band_from).map(|e| e[c].iter().sum::<f64>()).sum::<f64>() / n.max(1) as f64)
                    .sqrt()
            })
            .collect();
        let h: Vec<f64> =
            (0..m).map(|c| (keep.iter().map(|&r| self.sqe_h[c][r]).sum::<f64>() / n.max(1) as f64).sqrt()).collect();
        (var_model_h, p, h)
    }
}

/// Lead time of every validation sample after the end of its fold's training, its fold, and
/// its stated walk's age (the fold's training span / 3 + lead: the variance factor of a walk
/// whose mean over the training the fold's model absorbed), in fold order.
fn leads(d: &Dataset, fs: &[Fold], cores: &[FoldCore]) -> (Vec<f64>, Vec<usize>, Vec<f64>) {
    let (mut lead, mut fold_of, mut walk_age) = (Vec::new(), Vec::new(), Vec::new());
    for (fi, (f, c)) in fs.iter().zip(cores).enumerate() {
        let span = f.train.first().map_or(0.0, |&i| c.t_end - d.t_s[i]);
        for &i in &f.val {
            let l = d.t_s[i] - c.t_end;
            lead.push(l);
            fold_of.push(fi);
            walk_age.push(span / 3.0 + l.max(0.0));
        }
    }
    (lead, fold_of, walk_age)
}
