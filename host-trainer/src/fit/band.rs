//! The 95 % band's variance model: s²(τ) = a + b·τ over the lead time τ since the end of
//! training, fitted on cross-validated errors, times a split-conformal multiplier (DESIGN §4),
//! plus the interrogator's stated walk (see `VarModel::fit`).
//!
//! Drift is a random walk, so the error variance grows with the time since calibration. The
//! cross-validation sees leads up to a day or two, the hold-out and the field a week or more:
//! the slope b is extrapolated several times beyond the leads it was fitted on. A slope fitted
//! on one or two strongly autocorrelated validation stretches is noisy, and clamping it at zero
//! biases it upwards, so the band grew too fast where the estimate was noise. The slope is
//! therefore shrunk by its signal-to-noise ratio, b = b̂·t²/(1 + t²) with t = b̂ / se(b̂) (the
//! posterior mean of b under a zero-centred normal prior of variance b̂²): a growth the
//! validation errors clearly show is kept, one within its own noise is mostly dropped. The
//! validation errors are strongly autocorrelated (a minute apart, drift and weather change
//! over hours), so se(b̂) is the ordinary least-squares one inflated by the AR(1)
//! effective-sample-size factor √((1 + ρ)/(1 − ρ)), with ρ the lag-one autocorrelation of the
//! regression residuals within each fold.

use super::random_walk::WalkGrowth;

/// Fraction of each fold's lead range counted as "near zero lead" by [`VarModel::a_floor`].
const ZERO_LEAD_FRACTION: f64 = 0.1;

/// Mean of the squared errors whose lead lies in the first [`ZERO_LEAD_FRACTION`] of their
/// fold's lead range, pooled over folds (NaN without errors).
fn zero_lead_mse(lead_s: &[f64], sq_err: &[f64], fold: &[usize]) -> f64 {
    let n_folds = fold.iter().copied().max().map(|m| m + 1).unwrap_or(0);
    let mut range = vec![(f64::INFINITY, f64::NEG_INFINITY); n_folds];
    for (&t, &f) in lead_s.iter().zip(fold) {
        range[f] = (range[f].0.min(t), range[f].1.max(t));
    }
    crate::stats::mean(lead_s.iter().zip(sq_err).zip(fold).filter_map(|((&t, &e), &f)| {
        let (lo, hi) = range[f];
        (t <= lo + ZERO_LEAD_FRACTION * (hi - lo) && e.is_finite()).then_some(e)
    }))
}

/// Smallest 95 % multiplier of what the errors hold beyond a stated walk.
const K95_MIN_WITH_WALK: f64 = 1.0;

/// Largest lag-one autocorrelation used in the inflation factor (keeps it finite).
const RHO_MAX: f64 = 0.9999;

/// Residual variance as a function of lead time after the end of training.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct VarModel {
    /// Variance at lead 0 \[unit²\].
    pub a: f64,
    /// Growth, after shrinkage [unit²/s]: what the band uses.
    pub b: f64,
    /// 95 % quantile of |e| / s(τ) over the validation residuals: the band multiplier.
    pub k95: f64,
    /// Growth as fitted, before shrinkage (clamped at zero) [unit²/s]: for the audit.
    pub b_fitted: f64,
    /// Standard error of the fitted growth, allowing for autocorrelated errors [unit²/s].
    pub b_se: f64,
    /// Mean squared validation error nearest to zero lead \[unit²\] (each fold's first tenth of
    /// leads, pooled): the floor of `a`, so that the band at the end of calibration is never
    /// narrower than the error the cross-validation saw there.
    pub a_floor: f64,
    /// Largest lead time the validation saw \[s\]: the band's lead when a stream's clock is
    /// unknown.
    pub lead_max_s: f64,
    /// Fraction of the validation errors inside the band at their own lead (the
    /// cross-validated coverage; the conformal multiplier aims it at 95 %).
    pub cv_coverage: f64,
    /// The growth the interrogator's drift adds as read from Model-P's validation errors,
    /// s²·q_d \[unit²/s\] (the `random_walk` module; NaN when not read): the fitted growth is
    /// at least this, and `a` and `k95` are fitted to the validation errors at that growth.
    pub random_walk_rate: f64,
    /// The growth of the interrogator's stated walk, s²·q_s \[unit²/s\] (NaN when none is
    /// stated): added to the band with the normal 95 % multiplier, from the end of calibration
    /// on and as the offset the walk has there (`a` and `b` include it, scaled by (z₉₅/k95)²).
    pub stated_walk_rate: f64,
}

impl VarModel {
    /// A band of constant variance `a` \[unit²\] and the normal 95 % multiplier.
    pub fn constant(a: f64) -> VarModel {
        VarModel { a, k95: fbg_shared::layout::Z95, ..VarModel::default() }
    }

    /// Fit the variance model and calibrate its 95 % multiplier on the same residuals
    /// (split-conformal on the normalised errors). `fold` labels each sample's CV fold, in
    /// order of growing training sets.
    ///
    /// `walk` \[unit²/s\], the drift's random walk ([`super::random_walk`]), in two parts.
    ///
    /// The interrogator's stated walk g_s is Gaussian and known: a model absorbs the walk's
    /// mean over its calibration span T, so at lead τ the walk's part of its error has the
    /// variance g_s·(T/3 + τ). `walk_age_s` is that T/3 + τ for every validation error (its
    /// fold's training span), `span_s` the final models' T. The band is
    ///
    ///   half² = k95²·(a + b·τ) + z₉₅²·g_s·(span/3 + τ),
    ///
    /// with a and b fitted to the errors less the walk's expected share, and k95 the conformal
    /// multiplier of that remainder (the finite-sample 95 % quantile of (e² − z₉₅²·g_s·age)/s²,
    /// at least zero): the walk keeps the normal multiplier, which the validation errors —
    /// where the walk has barely started — cannot calibrate. Returned as one variance model,
    /// a and b each with g_s's part times (z₉₅/k95)².
    ///
    /// The rate read from the errors, less the stated one, is a floor under b, set before the
    /// intercept and the multiplier are fitted at that growth (`None` keeps the fitted growth).
    pub(crate) fn fit(
        lead_s: &[f64],
        sq_err: &[f64],
        fold: &[usize],
        walk: WalkGrowth,
        walk_age_s: &[f64],
        span_s: f64,
    ) -> VarModel {
        let z2 = fbg_shared::layout::Z95 * fbg_shared::layout::Z95;
        let g_s = walk.stated.filter(|g| g.is_finite() && *g >= 0.0);
        let walk_sq = |r: usize| g_s.map_or(0.0, |g| g * walk_age_s.get(r).copied().unwrap_or(0.0).max(0.0));
        // What the validation errors hold beyond the stated walk's expected share.
        let rest: Vec<f64> = sq_err.iter().enumerate().map(|(r, &e)| e - walk_sq(r)).collect();
        let read_floor = walk.read.map(|q| (q - g_s.unwrap_or(0.0)).max(0.0));
        let mut m = Self::fit_variance(lead_s, &rest, fold, read_floor);
        m.random_walk_rate = walk.read.unwrap_or(f64::NAN);
        m.stated_walk_rate = g_s.unwrap_or(f64::NAN);
        // A steep slope can leave a tiny intercept (on a short calibration the fold means are
        // explained by growth alone): the band at the end of calibration must still cover the
        // errors the validation saw at its shortest leads.
        m.a_floor = zero_lead_mse(lead_s, &rest, fold);
        if m.a_floor.is_finite() && m.a_floor > m.a {
            m.a = m.a_floor;
        }
        m.lead_max_s = lead_s.iter().copied().filter(|t| t.is_finite()).fold(0.0, f64::max);
        // Each error's k² at which the band just covers it.
        let mut u: Vec<f64> = lead_s
            .iter()
            .zip(sq_err)
            .enumerate()
            .map(|(r, (&t, &e))| if g_s.is_some() { ((e - z2 * walk_sq(r)) / m.at(t)).max(0.0) } else { e / m.at(t) })
            .collect();
        u.sort_by(f64::total_cmp);
        // Finite-sample conformal quantile: the ceil((n+1)·0.95)-th smallest.
        let n = u.len();
        let r = (((n + 1) as f64) * 0.95).ceil() as usize;
        let chosen = u.get(r.saturating_sub(1).min(n.saturating_sub(1))).copied();
        m.k95 = chosen.map_or(fbg_shared::layout::Z95, f64::sqrt);
        if m.k95.is_nan() || m.k95 <= 0.0 {
            m.k95 = fbg_shared::layout::Z95;
        }
        // Where the stated walk explains nearly every error, a small multiplier would make its
        // share of a and b (times (z₉₅/k95)²) huge in f32: the rest keeps at least one sigma.
        if g_s.is_some() {
            m.k95 = m.k95.max(K95_MIN_WITH_WALK);
        }
        let k2 = m.k95 * m.k95;
        let covered = match chosen {
            Some(c) if c.sqrt() == m.k95 => c,
            _ => k2,
        };
        m.cv_coverage = if n == 0 { f64::NAN } else { u.iter().filter(|&&x| x <= covered).count() as f64 / n as f64 };
        if let Some(g) = g_s {
            let in_k = z2 / k2;
            m.b += in_k * g;
            m.a += in_k * g * span_s.max(0.0) / 3.0;
        }
        m
    }

    /// e² = a_f + b·τ with one intercept per fold and a common slope (the fixed-effects
    /// estimator): early folds train on less data *and* validate at longer leads, so a pooled
    /// slope would mistake the smaller training set for growth. The slope is then shrunk (see
    /// the module doc). `a` is the intercept of the fold with the largest training set, the
    /// closest to the final fit, refitted at the shrunk slope.
    fn fit_variance(lead_s: &[f64], sq_err: &[f64], fold: &[usize], walk: Option<f64>) -> VarModel {
        let n_folds = fold.iter().copied().max().map(|m| m + 1).unwrap_or(0);
        let mut mt = vec![0.0; n_folds];
        let mut me = vec![0.0; n_folds];
        let mut cnt = vec![0usize; n_folds];
        for ((&t, &e), &f) in lead_s.iter().zip(sq_err).zip(fold) {
            mt[f] += t;
            me[f] += e;
            cnt[f] += 1;
        }
        for f in 0..n_folds {
            if cnt[f] > 0 {
                mt[f] /= cnt[f] as f64;
                me[f] /= cnt[f] as f64;
            }
        }
        let (mut stt, mut ste) = (0.0, 0.0);
        for ((&t, &e), &f) in lead_s.iter().zip(sq_err).zip(fold) {
            stt += (t - mt[f]).powi(2);
            ste += (t - mt[f]) * (e - me[f]);
        }
        let slope = if stt > 0.0 { ste / stt } else { 0.0 };
        let se = slope_se(lead_s, sq_err, fold, &mt, &me, slope, stt);
        let b_fitted = slope.max(0.0);
        let b = if b_fitted > 0.0 { b_fitted * b_fitted * b_fitted / (b_fitted * b_fitted + se * se) } else { 0.0 };
        let walk = walk.filter(|q| q.is_finite() && *q >= 0.0);
        let b = walk.map_or(b, |q| b.max(q));
        let last = (0..n_folds).rev().find(|&f| cnt[f] > 0).unwrap_or(0);
        let mean_all = sq_err.iter().sum::<f64>() / sq_err.len().max(1) as f64;
        let floor = 1e-6 * mean_all.max(f64::MIN_POSITIVE);
        let a = me.get(last).copied().unwrap_or(mean_all) - b * mt.get(last).copied().unwrap_or(0.0);
        VarModel { a: a.max(floor), b, k95: fbg_shared::layout::Z95, b_fitted, b_se: se, ..VarModel::default() }
    }

    /// Variance at lead time `tau_s`.
    pub fn at(&self, tau_s: f64) -> f64 {
        self.a + self.b * tau_s.max(0.0)
    }
}

/// Standard error of the fixed-effects slope with AR(1)-correlated residuals:
/// se² = σ²/Sττ · (1 + ρ)/(1 − ρ), σ² the residual variance, ρ the residuals' lag-one
/// autocorrelation within folds (samples are in time order within each fold).
fn slope_se(
    lead_s: &[f64],
    sq_err: &[f64],
    fold: &[usize],
    mean_lead: &[f64],
    mean_sq: &[f64],
    slope: f64,
    stt: f64,
) -> f64 {
    if stt <= 0.0 || lead_s.len() < 3 {
        return 0.0;
    }
    let resid: Vec<(usize, f64)> = lead_s
        .iter()
        .zip(sq_err)
        .zip(fold)
        .map(|((&t, &e), &f)| {
            let (mt, me) = (mean_lead.get(f).copied().unwrap_or(0.0), mean_sq.get(f).copied().unwrap_or(0.0));
            (f, (e - me) - slope * (t - mt))
        })
        .collect();
    let ss: f64 = resid.iter().map(|&(_, r)| r * r).sum();
    let lag1: f64 = resid
        .windows(2)
        .filter_map(|w| match w {
            [(f0, r0), (f1, r1)] if f0 == f1 => Some(r0 * r1),
            _ => None,
        })
        .sum();
    let rho = if ss > 0.0 { (lag1 / ss).clamp(0.0, RHO_MAX) } else { 0.0 };
    let sigma2 = ss / (resid.len() - 2) as f64;
    (sigma2 / stt * (1.0 + rho) / (1.0 - rho)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Squared errors of a deterministic series: variance `a + b·τ` times a fixed pattern of
    /// mean one, with a slow wobble of `wobble` (relative) and period `period_s`.
    fn series(a: f64, b: f64, wobble: f64, period_s: f64, n: usize) -> (Vec<f64>, Vec<f64>, Vec<usize>) {
        let lead: Vec<f64> = (1..=n).map(|i| i as f64 * 60.0).collect();
        let pattern = [0.2, 1.8, 0.6, 1.4, 1.0];
        let sq = lead
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                let w = 1.0 + wobble * (std::f64::consts::TAU * t / period_s).sin();
                (a + b * t) * w * pattern.get(i % pattern.len()).copied().unwrap_or(1.0)
            })
            .collect();
        (lead, sq, vec![0; n])
    }

    #[test]
    fn a_clear_growth_is_kept() {
        // Variance doubles over one day with no wobble: the slope is many standard errors
        // from zero and survives shrinkage within a percent.
        let (lead, sq, fold) = series(1.0, 1.0 / 86_400.0, 0.0, 86_400.0, 2 * 1440);
        let m = VarModel::fit(&lead, &sq, &fold, WalkGrowth::default(), &[], 0.0);
        assert!(m.b_se > 0.0);
        assert!((m.b / m.b_fitted - 1.0).abs() < 0.01, "{m:?}");
        assert!((m.b_fitted * 86_400.0 - 1.0).abs() < 0.05, "{m:?}");
    }

    /// Squared values of a stationary AR(1) series of unit variance and correlation time
    /// `corr_s`, sampled every minute: no growth at all.
    fn slow_noise(seed: u64, corr_s: f64, n: usize) -> (Vec<f64>, Vec<f64>, Vec<usize>) {
        let mut rng = crate::rng::Rng::new(seed, crate::rng::Stream::Drift);
        let rho = (-60.0 / corr_s).exp();
        let mut x = rng.normal();
        let mut sq = Vec::with_capacity(n);
        for _ in 0..n {
            x = rho * x + (1.0 - rho * rho).sqrt() * rng.normal();
            sq.push(x * x);
        }
        ((1..=n).map(|i| i as f64 * 60.0).collect(), sq, vec![0; n])
    }

    #[test]
    fn a_growth_within_its_own_noise_is_mostly_dropped() {
        // No growth, errors correlated over hours, 1.4 days of leads. A clamped least-squares
        // slope reports growth on some seeds; where that slope is within one standard error
        // of zero the band keeps less than half of it, and it never keeps more than fitted.
        let mut weak = 0;
        for seed in 1..=20 {
            let (lead, sq, fold) = slow_noise(seed, 6.0 * 3600.0, 2016);
            let m = VarModel::fit(&lead, &sq, &fold, WalkGrowth::default(), &[], 0.0);
            assert!(m.b <= m.b_fitted, "seed {seed}: {m:?}");
            if m.b_fitted > 0.0 && m.b_fitted < m.b_se {
                weak += 1;
                assert!(m.b < 0.5 * m.b_fitted, "seed {seed}: {m:?}");
            }
        }
        assert!(weak >= 2, "only {weak} seeds with a weak positive slope");
    }

    #[test]
    fn the_band_covers_its_own_validation_errors_at_95_percent() {
        let (lead, sq, fold) = series(1.0, 1.0 / 86_400.0, 0.2, 86_400.0, 2016);
        let m = VarModel::fit(&lead, &sq, &fold, WalkGrowth::default(), &[], 0.0);
        let covered = lead.iter().zip(&sq).filter(|&(&t, &e)| e.sqrt() <= m.k95 * m.at(t).sqrt()).count();
        let frac = covered as f64 / lead.len() as f64;
        assert!((0.95..=0.96).contains(&frac), "{frac}");
    }

    #[test]
    fn the_drift_walk_sets_a_floor_under_the_growth_and_the_intercept_follows_it() {
        // No growth in 1.4 days of correlated errors (this seed's clamped slope reads some
        // within its noise, shrunk); a walk floor five times larger raises it, and the intercept is refitted at that slope (lower: part of
        // the errors at their mean lead is now the walk's), never below the floor a_floor.
        let (lead, sq, fold) = slow_noise(4, 6.0 * 3600.0, 2016);
        let plain = VarModel::fit(&lead, &sq, &fold, WalkGrowth::default(), &[], 0.0);
        let q = 1e-4;
        let walked = VarModel::fit(&lead, &sq, &fold, WalkGrowth { read: Some(q), stated: None }, &[], 0.0);
        assert!(plain.b < q && walked.b == q, "{plain:?} {walked:?}");
        assert!(walked.a <= plain.a && walked.a >= walked.a_floor, "{plain:?} {walked:?}");
        assert_eq!(walked.random_walk_rate, q);
        assert!(plain.random_walk_rate.is_nan());
        // A fitted growth above the floor is kept as it was.
        let (lead, sq, fold) = series(1.0, 1.0 / 86_400.0, 0.0, 86_400.0, 2 * 1440);
        let steep = VarModel::fit(&lead, &sq, &fold, WalkGrowth::default(), &[], 0.0);
        assert_eq!(
            VarModel::fit(&lead, &sq, &fold, WalkGrowth { read: Some(1e-9), stated: None }, &[], 0.0).b,
            steep.b
        );
    }

    /// Coverage, pooled over `paths` drift paths, of the band fitted on one validation fold
    /// (training 5.5 days, validating 1.5) on the week after a 7-day calibration, every
    /// error a walk of 1 unit²/day less its mean over the model's training, plus white noise
    /// of 0.5 units; the band told `walk` (its `stated` part is the walk's true rate).
    fn week_after_coverage(walk: impl Fn(f64) -> WalkGrowth, paths: u64) -> f64 {
        let (dt, day) = (600.0, 86_400.0);
        let q = 1.0 / day;
        let (t_fold, t_cal, t_end) = (5.5 * day, 7.0 * day, 14.0 * day);
        let (mut covered, mut n) = (0usize, 0usize);
        for seed in 0..paths {
            let mut rng = crate::rng::Rng::new(1_000 + seed, crate::rng::Stream::Drift);
            let t: Vec<f64> = (0..(t_end / dt) as usize).map(|i| i as f64 * dt).collect();
            let mut w = 0.0;
            let path: Vec<f64> = t
                .iter()
                .map(|_| {
                    w += (q * dt).sqrt() * rng.normal();
                    w
                })
                .collect();
            let noise: Vec<f64> = t.iter().map(|_| 0.5 * rng.normal()).collect();
            let mean_to =
                |end: f64| crate::stats::mean(t.iter().zip(&path).filter(|(&ti, _)| ti < end).map(|(_, &p)| p));
            let (fold_mean, cal_mean) = (mean_to(t_fold), mean_to(t_cal));
            let val: Vec<usize> = (0..t.len()).filter(|&i| t[i] >= t_fold && t[i] < t_cal).collect();
            let lead: Vec<f64> = val.iter().map(|&i| t[i] - t_fold).collect();
            let sq: Vec<f64> = val.iter().map(|&i| (path[i] - fold_mean + noise[i]).powi(2)).collect();
            let age: Vec<f64> = lead.iter().map(|l| t_fold / 3.0 + l).collect();
            let m = VarModel::fit(&lead, &sq, &vec![0; val.len()], walk(q), &age, t_cal);
            for i in (0..t.len()).filter(|&i| t[i] >= t_cal) {
                let e = path[i] - cal_mean + noise[i];
                covered += usize::from(e.abs() <= m.k95 * m.at(t[i] - t_cal).sqrt());
                n += 1;
            }
        }
        covered as f64 / n as f64
    }

    #[test]
    fn a_stated_walk_gives_the_week_after_calibration_its_95_percent() {
        // The walk's rate stated: the band covers the week after calibration at 95 % over many
        // paths (each path alone may not: one week is one path). Told nothing, it covers far
        // less; with the walk as a floor under a conformally scaled growth (the rule before
        // the stated walk was added as a walk), less too.
        let stated = week_after_coverage(|q| WalkGrowth { read: None, stated: Some(q) }, 200);
        let blind = week_after_coverage(|_| WalkGrowth::default(), 200);
        let floor = week_after_coverage(|q| WalkGrowth { read: Some(q), stated: None }, 200);
        let all = format!("stated {stated}, no walk {blind}, walk as a floor {floor}");
        assert!((0.93..=0.985).contains(&stated), "{all}");
        assert!(blind < 0.85, "{all}");
        assert!(floor < stated - 0.02, "{all}");
    }

    #[test]
    fn without_a_stated_walk_the_band_is_as_fitted() {
        // No stated walk: the walk ages are not read, and the rate read is only a floor.
        let (lead, sq, fold) = slow_noise(4, 6.0 * 3600.0, 2016);
        let ages = vec![1e9; lead.len()];
        let a = VarModel::fit(&lead, &sq, &fold, WalkGrowth { read: Some(1e-4), stated: None }, &[], 0.0);
        let b = VarModel::fit(&lead, &sq, &fold, WalkGrowth { read: Some(1e-4), stated: None }, &ages, 1e9);
        assert_eq!((a.a, a.b, a.k95, a.cv_coverage), (b.a, b.b, b.k95, b.cv_coverage));
        assert!(a.stated_walk_rate.is_nan() && a.b >= 1e-4);
    }

    #[test]
    fn a_constant_band_has_the_normal_multiplier() {
        let m = VarModel::constant(2.0);
        assert_eq!(m.at(1e6), 2.0);
        assert_eq!(m.k95, fbg_shared::layout::Z95);
    }
}
