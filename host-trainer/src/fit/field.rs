//! The field context of a trained model ([`fbg_shared::FieldContext`]): what a reading in the
//! field needs beyond the calibration's arithmetic — each grating's zero λ_ref (from the
//! calibration record), how far a record's zero may differ from it, the absolute end of
//! calibration and the largest validated lead (the band's clock), and the calibration's
//! output envelope and largest band.

use fbg_shared::layout::{MAX_GRATINGS, MAX_OUTPUTS, MAX_STAGE1};
use fbg_shared::{FieldContext, ZeroSource};

use super::band::VarModel;
use super::poly_core::phi;
use super::HostParams;
use crate::data::Dataset;

/// A record's zero may move no output by more than this fraction of its cross-validated RMSE.
pub const ZERO_TOLERANCE_OF_RMSE: f64 = 1.0 / 3.0;

/// Step of the central differences \[pm\] (the core is a quadratic: exact up to rounding).
const DIFF_STEP_PM: f64 = 1.0;

/// The context of `p`, fitted on rows `cal` of `d` (sorted) with `band` per output, whose
/// cross-validated RMSE per output is `cv_rmse`.
pub fn context(p: &HostParams, d: &Dataset, cal: &[usize], band: &[VarModel], cv_rmse: &[f64]) -> FieldContext {
    let dims = p.dims;
    let (n, m) = (dims.gratings(), dims.n_outputs());
    let mut fc = FieldContext::unknown();
    for g in 0..n.min(MAX_GRATINGS) {
        if let Some(z) = d.meta.zero.get(g).filter(|z| z.source != ZeroSource::Unknown) {
            fc.lambda_ref_nm[g] = z.nm;
            fc.lambda_ref_source[g] = z.source;
        }
    }
    let inverse = static_inverse(p, &mean_input(p, d, cal));
    let tol = (0..m)
        .filter_map(|o| {
            let worst = inverse.get(o)?.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let r = cv_rmse.get(o).copied().unwrap_or(f64::NAN);
            (worst > 0.0 && r.is_finite()).then(|| ZERO_TOLERANCE_OF_RMSE * r / worst)
        })
        .fold(f64::INFINITY, f64::min);
    fc.lambda_ref_tol_pm = if tol.is_finite() { tol as f32 } else { 0.0 };
    let t_end = cal.last().map(|&i| d.t_s[i]).unwrap_or(0.0);
    fc.cal_end_unix_s = d.meta.t0_unix_s.map(|t0| t0 + t_end);
    fc.lead_max_s = band.iter().map(|b| b.lead_max_s).filter(|t| t.is_finite()).fold(0.0, f64::max) as f32;
    let refs = d.references_of(&dims);
    for o in 0..m.min(MAX_OUTPUTS) {
        let r = refs[o].as_slice();
        if r.is_empty() {
            continue;
        }
        let (lo, hi) = cal
            .iter()
            .map(|&i| r[i])
            .filter(|v| v.is_finite())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(v), b.max(v)));
        if lo <= hi {
            fc.output_lo[o] = lo as f32;
            fc.output_hi[o] = hi as f32;
        }
        if let Some(b) = band.get(o) {
            let w = b.k95 * b.at(fc.lead_max_s.into()).max(0.0).sqrt();
            fc.band_max[o] = if w.is_finite() { w as f32 } else { 0.0 };
        }
    }
    fc
}

/// The mean stage-1 input [Δλ_1..N, T_amb, 1] over `rows` (finite values only).
pub fn mean_input(p: &HostParams, d: &Dataset, rows: &[usize]) -> [f64; MAX_STAGE1] {
    let dims = p.dims;
    let n = dims.gratings();
    let mut x = [0.0; MAX_STAGE1];
    let mean = |v: &[f64]| {
        let (s, k) =
            rows.iter().map(|&i| v[i]).filter(|v| v.is_finite()).fold((0.0, 0usize), |(s, k), v| (s + v, k + 1));
        if k == 0 {
            0.0
        } else {
            s / k as f64
        }
    };
    for (o, g) in x.iter_mut().zip(&d.dl_pm).take(n) {
        *o = mean(g);
    }
    if dims.ambient() {
        x[n] = mean(d.ambient());
    }
    x[dims.stage1_len() - 1] = 1.0;
    x
}

/// The static calibration's reading at stage-1 input `x` (stage 1 and the polynomial core; the
/// memory terms settle to level-free values and the residual is local).
fn core_reading(p: &HostParams, x: &[f64; MAX_STAGE1]) -> [f64; MAX_OUTPUTS] {
    let dims = p.dims;
    let m = dims.n_outputs();
    let mut z = [0.0; MAX_OUTPUTS];
    for (j, zj) in z.iter_mut().enumerate().take(m) {
        let g: f64 = p.stage1[j].iter().zip(x.iter()).take(dims.stage1_len()).map(|(a, b)| a * b).sum();
        *zj = (g - p.guess_mean[j]) / p.guess_std[j];
    }
    let f = phi(&dims, &z, true);
    std::array::from_fn(|o| if o < m { p.poly[o].iter().zip(f.iter()).map(|(b, v)| b * v).sum() } else { 0.0 })
}

/// ∂ŷ_o/∂Δλ_i of the static calibration at `x` (output unit per pm), `[o][i]`.
pub fn static_inverse(p: &HostParams, x: &[f64; MAX_STAGE1]) -> Vec<Vec<f64>> {
    let dims = p.dims;
    let (n, m) = (dims.gratings(), dims.n_outputs());
    let mut out = vec![vec![0.0; n]; m];
    for i in 0..n {
        let (mut up, mut down) = (*x, *x);
        up[i] += DIFF_STEP_PM;
        down[i] -= DIFF_STEP_PM;
        let (yu, yd) = (core_reading(p, &up), core_reading(p, &down));
        for (o, row) in out.iter_mut().enumerate() {
            row[i] = (yu[o] - yd[o]) / (2.0 * DIFF_STEP_PM);
        }
    }
    out
}
