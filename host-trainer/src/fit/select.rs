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

use fbg_shared::layout::FeatureSet;
use fbg_shared::Provenance;

use super::band::VarModel;
use super::memory_core::{self, MemoryChoice, MemoryCvRow, MemoryOptions};
use super::{
    design, linalg, poly_core, residual_targets, skeleton, z_sample, CheckpointCache, Config, HostParams, ZSample,
};
use crate::data::import::OnError;
use crate::data::Dataset;
use crate::error::TrainerError;

/// The grid and the CV layout.
#[derive(Clone, Debug, serde::Serialize)]
pub struct TrainOptions {
    pub feature_sets: Vec<FeatureSet>,
    pub centres: Vec<usize>,
    pub sigma_mults: Vec<f64>,
    pub alpha_rels: Vec<f64>,
    pub dead_bands_pm: Vec<f64>,
    /// Keep the quadratic and cross terms of stage 2 (false only for the ablation).
    pub cross_terms: bool,
    /// The memory menu (off for the `paper` and `latch` variants).
    pub memory: MemoryOptions,
    /// Contiguous blocks the calibration batch is cut into.
    pub blocks: usize,
    /// Blocks in the first fold's training set.
    pub min_train_blocks: usize,
    /// Seed of k-means++.
    pub seed: u64,
    /// Largest number of calibration rows the cross-validation works on: beyond it the rows are
    /// thinned by an even stride (time order and span kept; the latches still see every
    /// sample). The final fit always uses every row.
    pub cv_max_samples: usize,
    /// Show a progress bar (only on a terminal).
    #[serde(skip)]
    pub progress: bool,
    /// Reference outliers in the calibration rows (`data::outliers`): refuse the batch
    /// (`Fail`, the default) or leave their rows out of the fit (`Skip`).
    pub on_outlier: OnError,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            feature_sets: vec![FeatureSet::HysteresisAware],
            // The device step's 2 500-instruction budget holds the default model's memory bank
            // with up to 8 centres, not 16 (`cargo xtask bench`, device part), and on the `paper`
            // seeds K = 16 gained about a per cent of RMSE over K <= 8: the default grid stops at
            // 8.
            centres: vec![4, 8],
            sigma_mults: vec![0.5, 1.0, 2.0, 4.0],
            alpha_rels: vec![1e-6, 1e-5, 1e-4, 1e-3, 1e-2],
            dead_bands_pm: vec![1.0, 2.0, 4.0, 8.0],
            cross_terms: true,
            memory: MemoryOptions::default_menu(),
            blocks: 5,
            min_train_blocks: 2,
            seed: 1,
            cv_max_samples: 40_000,
            progress: false,
            on_outlier: OnError::Fail,
        }
    }
}

impl TrainOptions {
    /// A one-point grid: no choice left to make (CV still runs, for s²).
    pub fn fixed(cfg: &Config) -> Self {
        TrainOptions {
            feature_sets: vec![cfg.feature_set],
            centres: vec![cfg.k],
            sigma_mults: vec![cfg.sigma_mult],
            alpha_rels: vec![cfg.alpha_rel],
            dead_bands_pm: vec![cfg.dead_band_pm],
            cross_terms: cfg.cross_terms,
            ..TrainOptions::default()
        }
    }

    /// [`TrainOptions::fixed`] keeping this grid's memory menu (cross-validation still chooses
    /// the memory terms: it costs one pass of the bank per fold).
    pub fn fixed_like(&self, cfg: &Config) -> Self {
        TrainOptions { memory: self.memory.clone(), ..TrainOptions::fixed(cfg) }
    }
    /// Restrict the feature sets (`paper` → only the paper set; `hysteresis-aware` → the latch
    /// sets, with time left to cross-validation).
    pub fn with_features(mut self, sets: Vec<FeatureSet>) -> Self {
        self.feature_sets = sets;
        self
    }
}

/// One evaluated grid point.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CvRow {
    pub config: Config,
    /// Pooled validation RMSE per output.
    pub cv_rmse: Vec<f64>,
    /// Σ_c RMSE_H,c / RMSE_P,c (lower is better; M = no gain).
    pub score: f64,
}

/// The outcome of selection.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Selection {
    pub chosen: Config,
    /// The memory terms each output uses (none for the `paper` and `latch` variants).
    pub memory: MemoryChoice,
    /// Every memory menu point evaluated, per output, with its pooled validation RMSE.
    pub memory_rows: Vec<MemoryCvRow>,
    pub rows: Vec<CvRow>,
    /// Pooled validation RMSE of Model-P and of the chosen Model-H (with memory terms: over the
    /// folds that scored them).
    pub cv_rmse_p: Vec<f64>,
    pub cv_rmse_h: Vec<f64>,
    /// Band variance model s²(τ) = a + b·τ per output (a in unit², b in unit²/s), Model-P and
    /// Model-H.
    pub var_model_p: Vec<VarModel>,
    pub var_model_h: Vec<VarModel>,
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
    core: poly_core::PolyCore,
    /// Time of the fold's last training sample [s] (validation leads count from it).
    t_end: f64,
}

/// Validation residuals of one configuration on one fold: per output the squared errors of
/// every validation sample.
type FoldErrors = Vec<Vec<f64>>;

/// Run the cross-validation and pick the best configuration.
pub fn select(d: &Dataset, cal: &[usize], opts: &TrainOptions) -> Result<Selection, TrainerError> {
    if opts.blocks < 2 || opts.min_train_blocks == 0 || opts.min_train_blocks >= opts.blocks {
        return Err(TrainerError::fit("cross-validation needs 1 <= min_train_blocks < blocks"));
    }
    let stride = cal.len().div_ceil(opts.cv_max_samples.max(1)).max(1);
    let thinned: Vec<usize> = cal.iter().copied().step_by(stride).collect();
    let fs = folds(&thinned, opts.blocks, opts.min_train_blocks);
    if fs.iter().any(|f| f.train.len() < 50 || f.val.is_empty()) {
        return Err(TrainerError::Dataset {
            message: format!("{} calibration samples are too few for {} CV blocks", cal.len(), opts.blocks),
        });
    }
    let prov = Provenance::default();
    let dims = d.dims("the dataset")?;
    let m = dims.n_outputs();
    // Every fold works on the thinned rows: checkpoints before each of them spare the tasks
    // from moving the latches over the samples in between.
    let cache = CheckpointCache::new(cal.last().map(|&i| i + 1).unwrap_or(0), thinned.clone());

    // The (feature set, dead band) pairs of the grid (the paper set ignores the dead band: one
    // suffices) and the grid size.
    let mut bands: Vec<(FeatureSet, f64)> = Vec::new();
    for &set in &opts.feature_sets {
        if set.uses_latch() {
            for &db in &opts.dead_bands_pm {
                bands.push((set, db));
            }
        } else {
            bands.push((set, opts.dead_bands_pm.first().copied().unwrap_or(2.0)));
        }
    }
    let grid_points = bands.len() * opts.centres.len() * opts.sigma_mults.len() * opts.alpha_rels.len();
    if grid_points == 0 {
        return Err(TrainerError::fit("empty hyper-parameter grid"));
    }
    let mut dbs: Vec<f64> = bands.iter().map(|b| b.1).collect();
    dbs.sort_by(f64::total_cmp);
    dbs.dedup();

    // A fold's Model-P, which also stands for the latch stream of its dead band.
    let stream_model = |core: &poly_core::PolyCore, train: &[usize], db: f64| -> Result<HostParams, TrainerError> {
        super::Skeleton::core_only(d, train, core, FeatureSet::HysteresisAware, db).params(
            None,
            0.0,
            None,
            &[],
            0.0,
            &prov,
        )
    };

    // Model-P per fold (always with cross terms: the reference errors) and the fold's core
    // (without them for the ablation), with Model-P's validation errors.
    let per_fold_p: Result<Vec<(FoldCore, FoldErrors)>, TrainerError> = fs
        .par_iter()
        .map(|f| {
            let core = poly_core::fit(d, &f.train, opts.cross_terms)?;
            let core_full = if opts.cross_terms { core.clone() } else { poly_core::fit(d, &f.train, true)? };
            // Model-P's answers do not depend on the dead band: take the grid's first, whose
            // checkpoints the RBF tasks need anyway.
            let p = stream_model(&core_full, &f.train, dbs[0])?;
            let ck = cache.get(&p, d)?;
            let est = design::run_with(&p, d, &f.val, Some(&ck))?;
            let sq = (0..m)
                .map(|c| est.iter().zip(&f.val).map(|(e, &i)| (e.values[c] - d.target(c)[i]).powi(2)).collect())
                .collect();
            let t_end = f.train.last().map(|&i| d.t_s[i]).unwrap_or(0.0);
            Ok((FoldCore { core, t_end }, sq))
        })
        .collect();
    let (fold_core, sq_p): (Vec<FoldCore>, Vec<FoldErrors>) = per_fold_p?.into_iter().unzip();
    // The memory terms, chosen on the folds' own cores, then each fold's core refitted with
    // them (Γ on what B leaves): the RBF layer below learns what that core leaves.
    let mem_folds: Vec<memory_core::FoldInput<'_>> = fs
        .iter()
        .zip(&fold_core)
        .map(|(f, fc)| memory_core::FoldInput { core: &fc.core, train: &f.train, val: &f.val })
        .collect();
    // Memory terms are scored on the folds whose training spans most of the batch (long time
    // constants and the drift observer need the span; see `MemoryOptions::min_train_fraction`).
    let long = (opts.memory.min_train_fraction * thinned.len() as f64).ceil() as usize;
    let first_long = mem_folds.iter().position(|f| f.train.len() >= long).unwrap_or(mem_folds.len().saturating_sub(1));
    let (memory, memory_rows) = memory_core::select(d, &mem_folds[first_long..], &opts.memory)?;
    let fold_core: Vec<FoldCore> = fold_core
        .into_par_iter()
        .zip(fs.par_iter())
        .map(|(fc, f)| {
            Ok(FoldCore { core: memory_core::fit(d, &f.train, &fc.core, &opts.memory.menu, &memory)?, t_end: fc.t_end })
        })
        .collect::<Result<_, TrainerError>>()?;
    let n_val: usize = fs.iter().map(|f| f.val.len()).sum();
    let cv_rmse_p: Vec<f64> =
        (0..m).map(|c| (sq_p.iter().map(|e| e[c].iter().sum::<f64>()).sum::<f64>() / n_val as f64).sqrt()).collect();
    let (lead, fold_of) = leads(d, &fs, &fold_core);
    let var_model_p: Vec<VarModel> = (0..m)
        .map(|c| VarModel::fit(&lead, &sq_p.iter().flat_map(|e| e[c].iter().copied()).collect::<Vec<_>>(), &fold_of))
        .collect();

    // What the RBF layer learns from each fold's training rows, per dead band.
    let mut zjobs = Vec::new();
    for fi in 0..fs.len() {
        for &db in &dbs {
            zjobs.push((fi, db));
        }
    }
    // Each fold's training stream per dead band (its core's values and latches, the stream
    // rule of the Model-P that stands for the dead band), run once: the k-means sample comes
    // from its latches, and grid tasks of the same rule take it as it is.
    let seeded: Result<Vec<(Arc<design::CoreStream>, ZSample)>, TrainerError> = zjobs
        .par_iter()
        .map(|&(fi, db)| {
            let f = &fs[fi];
            let sm = stream_model(&fold_core[fi].core, &f.train, db)?;
            let ck = cache.get(&sm, d)?;
            let train = Arc::new(design::CoreStream::new(&sm, d, &f.train, Some(&ck))?);
            let zs = z_sample(&sm, d, design::Rows::Cached(&train))?;
            Ok((train, zs))
        })
        .collect();
    let (train_streams, zsamples): (Vec<_>, Vec<_>) = seeded?.into_iter().unzip();
    let keys: Vec<(usize, u64)> = zjobs.iter().map(|&(fi, db)| (fi, db.to_bits())).collect();
    let zsamples: HashMap<(usize, u64), ZSample> = keys.iter().copied().zip(zsamples).collect();
    let train_streams: HashMap<(usize, u64), Arc<design::CoreStream>> =
        keys.iter().copied().zip(train_streams).collect();
    // The core's values and the latches at each fold's training and validation rows, per dead
    // band and stream rule: the same for every K and σ of the grid, and for every feature set
    // of the same rule. Made by the first task that needs one (two tasks racing may both make
    // it: the same numbers either way).
    type FoldStreams = (Arc<design::CoreStream>, Arc<design::CoreStream>);
    let streams: HashMap<(usize, u64), Mutex<Vec<FoldStreams>>> =
        keys.iter().map(|&k| (k, Mutex::new(Vec::new()))).collect();
    let fold_streams = |fi: usize, db: f64, p: &HostParams| -> Result<FoldStreams, TrainerError> {
        let key = (fi, db.to_bits());
        let slot = streams.get(&key).ok_or_else(|| TrainerError::fit("fold stream missing"))?;
        let lock = || slot.lock().map_err(|_| TrainerError::fit("fold stream cache poisoned"));
        for s in lock()?.iter() {
            if s.0.serves(p)? {
                return Ok(s.clone());
            }
        }
        let f = &fs[fi];
        let ck = cache.get(p, d)?;
        let train = match train_streams.get(&key) {
            Some(t) if t.serves(p)? => t.clone(),
            _ => Arc::new(design::CoreStream::new(p, d, &f.train, Some(&ck))?),
        };
        let made = (train, Arc::new(design::CoreStream::new(p, d, &f.val, Some(&ck))?));
        lock()?.push(made.clone());
        Ok(made)
    };

    // Per-sample squared validation errors of every (σ, α) of one fold, feature set, dead band
    // and K.
    let fold_task = |fi: usize, set: FeatureSet, db: f64, k: usize, sigma_mults: &[f64], alpha_rels: &[f64]| {
        let f = &fs[fi];
        let fc = &fold_core[fi];
        let zs = &zsamples[&(fi, db.to_bits())];
        let base_cfg = Config {
            feature_set: set,
            dead_band_pm: db,
            k,
            sigma_mult: 1.0,
            alpha_rel: 0.0,
            cross_terms: opts.cross_terms,
        };
        let mut sk = skeleton(d, &f.train, &fc.core, zs, &base_cfg, opts.seed);
        let nn = sk.sigma;
        let mut out: Vec<(Config, FoldErrors)> = Vec::new();
        let mut held: Option<FoldStreams> = None;
        for &sm in sigma_mults {
            sk.sigma_mult = sm;
            sk.sigma = sm * nn;
            let p = sk.params(None, 0.0, None, &[], 0.0, &prov)?;
            // σ does not change the stream rule: one lookup per task.
            let looked_up = match held.take() {
                Some(h) => h,
                None => fold_streams(fi, db, &p)?,
            };
            let (train_s, val_s) = held.insert(looked_up);
            let gram = design::gram_rows(&p, d, design::Rows::Cached(train_s))?;
            let (psi_v, est_v) = design::design_rows(&p, d, design::Rows::Cached(val_s))?;
            let r_v = residual_targets(d, &dims, &f.val, &est_v);
            let sys = linalg::RidgeSystem::from_gram(gram.g, &gram.psi_r, gram.n);
            for &ar in alpha_rels {
                let w = sys.weights(ar * f.train.len() as f64);
                let resid: DMatrix<f64> = &r_v - &psi_v * &w;
                let sq = (0..m).map(|c| resid.column(c).iter().map(|e| e * e).collect()).collect();
                out.push((Config { sigma_mult: sm, alpha_rel: ar, ..base_cfg }, sq));
            }
        }
        Ok::<_, TrainerError>(out)
    };

    let pool = |sq: &[f64]| sq.iter().sum::<f64>();
    let (rows, chosen) = if grid_points > 1 {
        let mut tasks = Vec::new();
        for fi in 0..fs.len() {
            for &(set, db) in &bands {
                for &k in &opts.centres {
                    tasks.push((fi, set, db, k));
                }
            }
        }
        let bar = crate::progress::bar(opts.progress, tasks.len() as u64, "cross-validation");
        type Acc = Vec<(Config, Vec<f64>, usize)>;
        let results: Result<Vec<Acc>, TrainerError> = tasks
            .par_iter()
            .map(|&(fi, set, db, k)| {
                let out = fold_task(fi, set, db, k, &opts.sigma_mults, &opts.alpha_rels)?;
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
        (rows, chosen)
    } else {
        let (set, db) = bands[0];
        let chosen = Config {
            feature_set: set,
            dead_band_pm: db,
            k: opts.centres[0],
            sigma_mult: opts.sigma_mults[0],
            alpha_rel: opts.alpha_rels[0],
            cross_terms: opts.cross_terms,
        };
        (Vec::new(), chosen)
    };

    // Per-sample validation errors of the chosen configuration, against their lead time.
    let per_fold: Result<Vec<FoldErrors>, TrainerError> = (0..fs.len())
        .into_par_iter()
        .map(|fi| {
            let mut out = fold_task(
                fi,
                chosen.feature_set,
                chosen.dead_band_pm,
                chosen.k,
                &[chosen.sigma_mult],
                &[chosen.alpha_rel],
            )?;
            out.pop().map(|(_, sq)| sq).ok_or_else(|| TrainerError::fit("no validation errors"))
        })
        .collect();
    let per_fold = per_fold?;
    let sqe_h: Vec<Vec<f64>> = (0..m).map(|c| per_fold.iter().flat_map(|e| e[c].iter().copied()).collect()).collect();
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
    let keep: Vec<usize> = (0..fold_of.len()).filter(|&r| fold_of[r] >= band_from).collect();
    let lead_h: Vec<f64> = keep.iter().map(|&r| lead[r]).collect();
    let fold_h: Vec<usize> = keep.iter().map(|&r| fold_of[r] - band_from).collect();
    let var_model_h: Vec<VarModel> = (0..m)
        .map(|c| {
            let sq: Vec<f64> = keep.iter().map(|&r| sqe_h[c][r]).collect();
            VarModel::fit(&lead_h, &sq, &fold_h)
        })
        .collect();
    // The reported validation RMSE of both models (what `train` prints and warns on) comes
    // from the same folds, so that it describes a model fitted on most of the batch.
    let (cv_rmse_p, cv_rmse_h) = if band_from > 0 {
        let n: usize = fs.iter().skip(band_from).map(|f| f.val.len()).sum();
        let p: Vec<f64> = (0..m)
            .map(|c| {
                (sq_p.iter().skip(band_from).map(|e| e[c].iter().sum::<f64>()).sum::<f64>() / n.max(1) as f64).sqrt()
            })
            .collect();
        let h: Vec<f64> =
            (0..m).map(|c| (keep.iter().map(|&r| sqe_h[c][r]).sum::<f64>() / n.max(1) as f64).sqrt()).collect();
        (p, h)
    } else {
        (cv_rmse_p, cv_rmse_h)
    };
    Ok(Selection {
        chosen,
        memory,
        memory_rows,
        cv_rmse_p,
        cv_rmse_h,
        var_model_p,
        var_model_h,
        rows,
        folds: fs.iter().map(|f| (f.train.len(), f.val.len())).collect(),
        n_cal: cal.len(),
        cv_stride: stride,
    })
}

/// Lead time of every validation sample after the end of its fold's training, and its fold,
/// in fold order.
fn leads(d: &Dataset, fs: &[Fold], cores: &[FoldCore]) -> (Vec<f64>, Vec<usize>) {
    let mut lead = Vec::new();
    let mut fold_of = Vec::new();
    for (fi, (f, c)) in fs.iter().zip(cores).enumerate() {
        for &i in &f.val {
            lead.push(d.t_s[i] - c.t_end);
            fold_of.push(fi);
        }
    }
    (lead, fold_of)
}
