//! Hold-out evaluation (DESIGN §5): per channel and model RMSE, MAE, R², bias, max |error|,
//! band coverage, flag counts; the gain of Model-H over Model-P; the hysteresis index.

use fbg_shared::layout::Dims;
use fbg_shared::{DirectionLatch, Estimate, Flags};

use crate::data::Dataset;
use crate::error::TrainerError;
use crate::fit::{run, HostParams};

/// Short names of a model's outputs for tables and JSON (`T`, `strain`, `strain2`, `p`).
pub fn channels(dims: &Dims) -> Vec<String> {
    dims.outputs().iter().map(|o| o.channel().as_str().to_string()).collect()
}
/// Units of a model's outputs.
pub fn units(dims: &Dims) -> Vec<String> {
    dims.outputs().iter().map(|o| o.unit().to_string()).collect()
}

/// The grating that tells rising from falling segments of output `c` for the hysteresis
/// index: for the paper's layout the grating designed for it (T ← FBG2, ε ← FBG1, p ← FBG3);
/// otherwise the grating whose shift correlates most with the output's reference over `idx`.
pub fn dominant_grating(dims: &Dims, d: &Dataset, truth: &[f64], idx: &[usize], c: usize) -> usize {
    if *dims == Dims::PAPER {
        return PAPER_GRATING_OF_OUTPUT[c];
    }
    let corr = |g: &[f64]| {
        let n = idx.len() as f64;
        let (mx, my) = (idx.iter().map(|&i| g[i]).sum::<f64>() / n, truth.iter().sum::<f64>() / n);
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        for (&i, &y) in idx.iter().zip(truth) {
            let (dx, dy) = (g[i] - mx, y - my);
            sxy += dx * dy;
            sxx += dx * dx;
            syy += dy * dy;
        }
        correlation(sxy, sxx, syy)
    };
    most_correlated(d.n_gratings(), |g| corr(&d.dl_pm[g]))
}

/// The grating of each output of the paper's layout for the hysteresis index.
pub(crate) const PAPER_GRATING_OF_OUTPUT: [usize; 3] = [1, 0, 2];

/// |r| from the centred sums of products (0 when undefined).
pub(crate) fn correlation(sxy: f64, sxx: f64, syy: f64) -> f64 {
    let r = (sxy / (sxx * syy).sqrt()).abs();
    if r.is_finite() {
        r
    } else {
        0.0
    }
}

/// The grating of `0..n_gratings` with the largest `corr` (the first on a tie).
pub(crate) fn most_correlated(n_gratings: usize, corr: impl Fn(usize) -> f64) -> usize {
    (0..n_gratings).max_by(|&a, &b| corr(a).total_cmp(&corr(b)).then(b.cmp(&a))).unwrap_or(0)
}
/// Dead band of the direction detector of the hysteresis index \[pm\].
pub const HYSTERESIS_INDEX_DEAD_BAND_PM: f64 = 4.0;

pub use fbg_report::{ChannelMetrics, ModelEval};

/// Estimates of `params` at `idx` (the compensator runs from the first sample, so the latches
/// see the whole history).
pub fn estimates(params: &HostParams, d: &Dataset, idx: &[usize]) -> Result<Vec<Estimate<f64>>, TrainerError> {
    run(params, d, idx)
}

/// Direction (+1 rising, −1 falling, 0 undecided) of grating `g` at each of `idx`, from a
/// direction latch on the measured shift.
pub fn directions(d: &Dataset, g: usize, idx: &[usize]) -> Vec<f64> {
    let mut latch = DirectionLatch::new();
    let db = fbg_shared::ticks(HYSTERESIS_INDEX_DEAD_BAND_PM);
    let all: Vec<f64> = d.dl_pm[g].iter().map(|&v| latch.update(v, db)).collect();
    idx.iter().map(|&i| all[i]).collect()
}

/// Evaluate estimates of a model of `dims` against the truth at `idx` (each output's
/// reference found by measurand; NaN metrics for an output the data lack).
pub fn score(dims: &Dims, d: &Dataset, idx: &[usize], est: &[Estimate<f64>]) -> ModelEval {
    let mut channels = vec![ChannelMetrics::default(); dims.n_outputs()];
    for (c, m) in channels.iter_mut().enumerate() {
        let reference = d.reference_of(dims, c);
        if !reference.is_present() {
            *m = ChannelMetrics::ABSENT;
            continue;
        }
        let truth: Vec<f64> = idx.iter().map(|&i| reference[i]).collect();
        let err: Vec<f64> = est.iter().zip(&truth).map(|(e, t)| e.values[c] - t).collect();
        let n = err.len() as f64;
        let mean_t = truth.iter().sum::<f64>() / n;
        let ss_tot: f64 = truth.iter().map(|t| (t - mean_t).powi(2)).sum();
        let ss_res: f64 = err.iter().map(|e| e * e).sum();
        let inside = est.iter().zip(&truth).filter(|(e, t)| (e.values[c] - *t).abs() <= e.band95[c]).count();
        let dirs = directions(d, dominant_grating(dims, d, &truth, idx, c), idx);
        let mean_if = |want: f64| {
            let v: Vec<f64> = err.iter().zip(&dirs).filter(|(_, d)| **d == want).map(|(e, _)| *e).collect();
            if v.is_empty() {
                0.0
            } else {
                v.iter().sum::<f64>() / v.len() as f64
            }
        };
        *m = ChannelMetrics {
            rmse: (ss_res / n).sqrt(),
            mae: err.iter().map(|e| e.abs()).sum::<f64>() / n,
            r2: if ss_tot > 0.0 { 1.0 - ss_res / ss_tot } else { f64::NAN },
            bias: err.iter().sum::<f64>() / n,
            max_abs: err.iter().fold(0.0, |a, e| a.max(e.abs())),
            coverage: inside as f64 / n,
            mean_band: est.iter().map(|e| e.band95[c]).filter(|b| b.is_finite()).sum::<f64>() / n,
            hysteresis_index: mean_if(1.0) - mean_if(-1.0),
            n: err.len(),
        };
    }
    let bits = [Flags::NON_FINITE, Flags::OUT_OF_ENVELOPE, Flags::WEAK_SUPPORT, Flags::IMPLAUSIBLE, Flags::FALLBACK];
    let flag_counts = bits.map(|b| est.iter().filter(|e| e.flags.contains(b)).count());
    let flagged = est.iter().filter(|e| !e.flags.is_ok()).count();
    ModelEval { channels, flag_counts, flagged_fraction: flagged as f64 / est.len().max(1) as f64 }
}

/// Evaluate `params` on the hold-out of `d` (the samples with finite inputs and references;
/// gaps are counted in `skipped`).
///
/// ```
/// use fbg_shared::FeatureSet;
/// use fbg_trainer::eval::score::evaluate_holdout;
/// use fbg_trainer::fit::{train, Config, Origin, TrainOptions};
/// use fbg_trainer::sim::{scenario::Preset, simulate};
///
/// // Two days of the `paper` installation (a calibration batch and a hold-out), one grid point.
/// let mut scenario = Preset::Paper.config();
/// scenario.clock.days = 2.0;
/// let data = simulate(&scenario, 7).data;
/// let cfg = Config {
///     feature_set: FeatureSet::HysteresisAware,
///     dead_band_pm: 2.0,
///     k: 4,
///     sigma_mult: 1.0,
///     alpha_rel: 1e-4,
///     cross_terms: true,
/// };
/// let trained = train(&data, &TrainOptions::fixed(&cfg), &Origin::default())?;
/// let (eval, estimates) = evaluate_holdout(&trained.model_h, &data)?;
/// // One row per output (T, ε, p), each scored on every hold-out estimate.
/// assert_eq!(eval.channels.len(), 3);
/// assert!(eval.channels.iter().all(|c| c.rmse.is_finite() && c.n == estimates.len()));
/// # Ok::<(), fbg_trainer::TrainerError>(())
/// ```
pub fn evaluate_holdout(params: &HostParams, d: &Dataset) -> Result<(ModelEval, Vec<Estimate<f64>>), TrainerError> {
    d.inputs_for(&params.dims, "the dataset", "evaluate")?;
    let idx: Vec<usize> = d.holdout_indices().into_iter().filter(|&i| d.usable(i)).collect();
    if idx.is_empty() {
        return Err(TrainerError::Dataset { message: "no hold-out samples (split column has no `holdout`)".into() });
    }
    let est = estimates(params, d, &idx)?;
    Ok((score(&params.dims, d, &idx, &est), est))
}

/// Gain of Model-H over Model-P in % of Model-P's RMSE.
pub fn gain_pct(p: f64, h: f64) -> f64 {
    100.0 * (p - h) / p
}
