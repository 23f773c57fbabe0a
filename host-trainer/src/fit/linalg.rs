//! Least squares and ridge solvers on nalgebra (f64): Householder QR for the tall polynomial
//! systems (never the raw normal equations), a symmetric eigen-decomposition for the RBF ridge
//! (one decomposition serves every α of the cross-validation grid and the predictive variance).

use nalgebra::{DMatrix, SymmetricEigen};

use crate::error::TrainerError;

/// Solve min ‖X·B − Y‖ by Householder QR of X (n × p, n ≥ p) and an SVD of the p × p factor R,
/// so that a rank-deficient design is reported rather than silently amplified.
/// Returns B (p × m).
pub fn lstsq(x: DMatrix<f64>, y: DMatrix<f64>, what: &str) -> Result<DMatrix<f64>, TrainerError> {
    let (n, p) = x.shape();
    if n < p {
        return Err(TrainerError::fit(format!("{what}: {n} samples for {p} unknowns")));
    }
    // Equilibrate columns so that the rank test is scale-free.
    let scale: Vec<f64> = (0..p)
        .map(|j| {
            let c = x.column(j).norm();
            if c > 0.0 {
                c
            } else {
                1.0
            }
        })
        .collect();
    let mut xs = x;
    for (j, s) in scale.iter().enumerate() {
        xs.column_mut(j).scale_mut(1.0 / s);
    }
    let qr = xs.qr();
    let mut qty = y;
    qr.q_tr_mul(&mut qty);
    let r = qr.r();
    let qty = qty.rows(0, p).into_owned();
    let svd = r.svd(true, true);
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    if !(smin > smax * 1e-10) {
        return Err(TrainerError::fit(format!(
            "{what}: the design is rank-deficient (condition number {:.1e}); the calibration data do not excite every term",
            smax / smin.max(f64::MIN_POSITIVE)
        )));
    }
    let mut b = svd
        .solve(&qty, 0.0)
        .map_err(|e| TrainerError::fit(format!("{what}: {e}")))?;
    for (j, s) in scale.iter().enumerate() {
        b.row_mut(j).scale_mut(1.0 / s);
    }
    Ok(b)
}

/// The ridge system of paper Eq. 7 in eigen form: G = ΨᵀΨ = V Λ Vᵀ and Ψᵀ R, so that
/// W(α) = V (Λ + αI)⁻¹ Vᵀ ΨᵀR costs O(K²) per α.
pub struct RidgeSystem {
    pub eigen: SymmetricEigen<f64, nalgebra::Dyn>,
    /// Vᵀ Ψᵀ R (K × outputs).
    pub vt_psi_r: DMatrix<f64>,
    pub n: usize,
}

impl RidgeSystem {
    /// Build from the design Ψ (n × K) and residual targets R (n × m).
    pub fn new(psi: &DMatrix<f64>, r: &DMatrix<f64>) -> Self {
        let g = psi.tr_mul(psi);
        let eigen = SymmetricEigen::new(g);
        let vt_psi_r = eigen.eigenvectors.tr_mul(&psi.tr_mul(r));
        RidgeSystem { eigen, vt_psi_r, n: psi.nrows() }
    }

    /// Ridge weights W (K × m) for penalty `alpha` (the α of Eq. 7, in ΨᵀΨ units).
    pub fn weights(&self, alpha: f64) -> DMatrix<f64> {
        let mut t = self.vt_psi_r.clone();
        for (i, mut row) in t.row_iter_mut().enumerate() {
            let lam = self.eigen.eigenvalues[i].max(0.0);
            row.scale_mut(1.0 / (lam + alpha));
        }
        &self.eigen.eigenvectors * t
    }

    /// Eigenvalues of ΨᵀΨ + αI in ascending order, with their eigenvectors as columns.
    pub fn regularised_spectrum(&self, alpha: f64) -> (Vec<f64>, DMatrix<f64>) {
        let k = self.eigen.eigenvalues.len();
        let mut order: Vec<usize> = (0..k).collect();
        order.sort_by(|&a, &b| self.eigen.eigenvalues[a].total_cmp(&self.eigen.eigenvalues[b]));
        let vals = order.iter().map(|&i| self.eigen.eigenvalues[i].max(0.0) + alpha).collect();
        let vecs = DMatrix::from_fn(k, k, |r, c| self.eigen.eigenvectors[(r, order[c])]);
        (vals, vecs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lstsq_recovers_exact_coefficients() {
        let n = 200;
        let x = DMatrix::from_fn(n, 3, |i, j| match j {
            0 => 1.0,
            1 => i as f64 * 1e3,
            _ => ((i * 7) % 13) as f64 * 1e-3,
        });
        let b_true = DMatrix::from_row_slice(3, 2, &[1.0, -2.0, 0.5e-3, 3e-3, 40.0, -7.0]);
        let y = &x * &b_true;
        let b = lstsq(x, y, "test").unwrap();
        assert!((b - b_true).amax() < 1e-8);
    }

    #[test]
    fn lstsq_reports_rank_deficiency() {
        let x = DMatrix::from_fn(50, 2, |i, _| i as f64);
        let y = DMatrix::from_fn(50, 1, |i, _| i as f64);
        let e = lstsq(x, y, "stage 1").unwrap_err().to_string();
        assert!(e.contains("stage 1") && e.contains("rank-deficient"), "{e}");
    }

    #[test]
    fn ridge_matches_direct_solve() {
        let psi = DMatrix::from_fn(40, 4, |i, j| ((i * (j + 3)) % 11) as f64 / 11.0);
        let r = DMatrix::from_fn(40, 2, |i, j| (i as f64 * 0.1).sin() + j as f64);
        let sys = RidgeSystem::new(&psi, &r);
        let alpha = 0.3;
        let w = sys.weights(alpha);
        let g = psi.tr_mul(&psi) + DMatrix::identity(4, 4) * alpha;
        let direct = g.cholesky().unwrap().solve(&psi.tr_mul(&r));
        assert!((w - direct).amax() < 1e-10);
    }
}
