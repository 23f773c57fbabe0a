//! The field context of a trained model ([`fbg_shared::FieldContext`]): what a reading in the
//! field needs beyond the calibration's arithmetic — each grating's zero λ_ref (from the
//! calibration record), how far a record's zero may differ from it, the absolute end of
//! calibration and the largest validated lead (the band's clock), and the calibration's
//! output envelope and largest band.

use fbg_shared::layout::{MAX_GRATINGS, MAX_OUTPUTS};
use fbg_shared::{FieldContext, ZeroSource};

use super::band::VarModel;
use super::host::HostParams;
use super::sensitivity::core_jacobian;
use crate::data::Dataset;

/// A record's zero may move no output by more than this fraction of its cross-validated RMSE.
pub(crate) const ZERO_TOLERANCE_OF_RMSE: f64 = 1.0 / 3.0;

/// The context of `p`, fitted on rows `cal` of `d` (sorted) with `band` per output, whose
/// cross-validated RMSE per output is `cv_rmse`.
pub(crate) fn context(p: &HostParams, d: &Dataset, cal: &[usize], band: &[VarModel], cv_rmse: &[f64]) -> FieldContext {
    let dims = p.dims;
    let (n, m) = (dims.gratings(), dims.n_outputs());
    let mut fc = FieldContext::unknown();
    for g in 0..n.min(MAX_GRATINGS) {
        if let Some(z) = d.meta.zero.get(g).filter(|z| z.source != ZeroSource::Unknown) {
            fc.lambda_ref_nm[g] = z.nm;
            fc.lambda_ref_source[g] = z.source;
        }
    }
    // ∂ŷ/∂Δλ of the static calibration at the calibration's mean input (where the
    // standardised first guesses are 0), with T_amb held: a zero error moves the shifts only.
    let inverse = core_jacobian(p, &[0.0; MAX_OUTPUTS]);
    let tol = (0..m)
        .filter_map(|o| {
            let worst = inverse.get(o)?.iter().take(n).fold(0.0f64, |a, v| a.max(v.abs()));
            let r = cv_rmse.get(o).copied().unwrap_or(f64::NAN);
            (worst > 0.0 && r.is_finite()).then(|| ZERO_TOLERANCE_OF_RMSE * r / worst)
        })
        .fold(f64::INFINITY, f64::min);
    fc.lambda_ref_tol_pm = if tol.is_finite() { tol as f32 } else { 0.0 };
    fc.cal_end_unix_s = d.meta.t0_unix_s.map(|t0| t0 + p.t_cal_end_s);
    fc.lead_max_s = band.iter().map(|b| b.lead_max_s).filter(|t| t.is_finite()).fold(0.0, f64::max) as f32;
    let refs = d.references_of(&dims);
    for (o, col) in refs.iter().enumerate().take(m.min(MAX_OUTPUTS)) {
        let r = col.as_slice();
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
