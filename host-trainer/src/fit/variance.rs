//! The predictive variance of the RBF residual: the kept eigen-directions of the ridge
//! system (DESIGN §4), which grow out of distribution.

use fbg_shared::layout::VAR_RANK;

use super::linalg;

/// The kept eigen-directions of (ΨᵀΨ + αI)⁻¹ for the predictive variance.
#[derive(Clone, Debug)]
pub(crate) struct VarianceTerms {
    pub(crate) inv_g: [f64; VAR_RANK],
    pub(crate) inv_g_tail: f64,
    /// Per centre, its components of the kept eigenvectors.
    pub(crate) v: Vec<[f64; VAR_RANK]>,
}

impl VarianceTerms {
    /// The terms of the ridge system `sys` with penalty `alpha`.
    pub(crate) fn from_ridge(sys: &linalg::RidgeSystem, alpha: f64) -> Self {
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
