//! What the RBF residual layer is fitted to, and where it is trusted: the residual targets of
//! the polynomial core and the weak-support threshold on max ψ (DESIGN §4).

use nalgebra::DMatrix;

use fbg_shared::layout::{Dims, MAX_OUTPUTS};

use super::design;
use crate::data::Dataset;

/// Residual targets R = y − Model-P(x) on `rows` (n × M) for a model of `dims`, from the core's
/// values there (0 for an output whose reference `d` lacks).
pub(crate) fn residual_targets(
    d: &Dataset,
    dims: &Dims,
    rows: &[usize],
    core_values: &[[f64; MAX_OUTPUTS]],
) -> DMatrix<f64> {
    let refs = d.references_of(dims);
    DMatrix::from_fn(rows.len(), dims.n_outputs(), |r, c| design::residual(&refs, rows[r], c, &core_values[r]))
}

/// Weak-support threshold: half the 0.1 % quantile of max ψ over the calibration samples,
/// clamped to [1e-6, 0.1], so that essentially no calibration sample is flagged and a
/// sample less supported than 99.9 % of them is.
pub(crate) fn weak_support_threshold(max_psi: &[f64]) -> f64 {
    if max_psi.is_empty() {
        return 0.0;
    }
    let mut mx = max_psi.to_vec();
    let at = (mx.len() as f64 * 0.001) as usize;
    let (_, &mut q, _) = mx.select_nth_unstable_by(at, f64::total_cmp);
    (0.5 * q).clamp(1e-6, 0.1)
}
