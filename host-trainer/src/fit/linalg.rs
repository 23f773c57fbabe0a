//! Least squares and ridge solvers on nalgebra (f64): Householder QR for the tall polynomial
//! systems (never the raw normal equations), a symmetric eigen-decomposition for the RBF ridge
//! (one decomposition serves every α of the cross-validation grid and the predictive variance).

use nalgebra::{DMatrix, SymmetricEigen};
use rayon::prelude::*;

use crate::error::TrainerError;

/// Rows per block of the tall-skinny QR.
const TSQR_BLOCK: usize = 8192;

/// Sweeps an SVD or a symmetric eigen-decomposition may take before the system is refused
/// (nalgebra's unbounded default iterates forever on a NaN).
const SVD_MAX_ITERATIONS: usize = 10_000;

/// Solve min ‖X·B − Y‖ by Householder QR of X (n × p, n ≥ p) and an SVD of the p × p factor R,
/// so that a rank-deficient design is reported rather than silently amplified.
/// Returns B (p × m).
///
/// Tall systems are factored as a tall-skinny QR: each block of `TSQR_BLOCK` rows of the
/// augmented [X | Y] is reduced to its triangular factor in parallel, and the stacked factors
/// are reduced once more. That is a Householder QR of the whole system (R and QᵀY are the same
/// up to the signs of R's rows), with fixed blocks so the result does not depend on the number
/// of threads.
pub(crate) fn lstsq(x: DMatrix<f64>, y: DMatrix<f64>, what: &str) -> Result<DMatrix<f64>, TrainerError> {
    let (p, m) = (x.ncols(), y.ncols());
    lstsq_rows(x.nrows(), p, m, what, |i, row| {
        for (c, v) in row.iter_mut().enumerate() {
            *v = if c < p { x[(i, c)] } else { y[(i, c - p)] };
        }
    })
}

/// [`lstsq`] for a system given row by row: `row(i, buf)` writes the p regressors of row i
/// followed by its m targets into `buf` (length p + m). Nothing n-sized is held.
pub(crate) fn lstsq_rows(
    n: usize,
    p: usize,
    m: usize,
    what: &str,
    row: impl Fn(usize, &mut [f64]) + Sync,
) -> Result<DMatrix<f64>, TrainerError> {
    if n < p {
        return Err(TrainerError::fit(format!("{what}: {n} samples for {p} unknowns")));
    }
    let r_aug = triangular_rows(n, p + m, row);
    if r_aug.nrows() < p {
        return Err(TrainerError::fit(format!("{what}: {n} samples for {p} unknowns")));
    }
    let r = r_aug.view((0, 0), (p, p)).into_owned();
    let qty = r_aug.view((0, p), (p, m)).into_owned();
    // Equilibrate columns so that the rank test is scale-free: the columns of R have the norms
    // of the columns of X (Q is orthogonal).
    let scale: Vec<f64> = (0..p)
        .map(|j| {
            let c = r.column(j).norm();
            if c > 0.0 {
                c
            } else {
                1.0
            }
        })
        .collect();
    let mut rs = r;
    for (j, s) in scale.iter().enumerate() {
        rs.column_mut(j).scale_mut(1.0 / s);
    }
    // A non-finite R (an input whose square overflows) would keep the SVD iterating forever;
    // the iteration is bounded too, so no design can hang the fit.
    let svd = rs
        .iter()
        .all(|v| v.is_finite())
        .then(|| rs.try_svd(true, true, f64::EPSILON, SVD_MAX_ITERATIONS))
        .flatten()
        .ok_or_else(|| {
            TrainerError::fit(format!(
                "{what}: the design holds non-finite values (an input too large for its square to be represented)"
            ))
        })?;
    let smax = svd.singular_values.max();
    let smin = svd.singular_values.min();
    // Also when a singular value is NaN.
    if smin.partial_cmp(&(smax * 1e-10)) != Some(std::cmp::Ordering::Greater) {
        return Err(TrainerError::fit(format!(
            "{what}: the design is rank-deficient (condition number {:.1e}); the calibration data do not excite every term",
            smax / smin.max(f64::MIN_POSITIVE)
        )));
    }
    let mut b = svd.solve(&qty, 0.0).map_err(|e| TrainerError::fit(format!("{what}: {e}")))?;
    for (j, s) in scale.iter().enumerate() {
        b.row_mut(j).scale_mut(1.0 / s);
    }
    Ok(b)
}

/// The upper-triangular factor R of a tall system given row by row (`row(i, buf)` writes the q
/// columns of row i), as its top min(n, q) rows, by the tall-skinny QR of [`lstsq_rows`]:
/// RᵀR = AᵀA, so any least-squares problem on a subset of A's columns can be solved from R
/// alone (see `fit::memory_core`). Nothing n-sized is held.
pub(crate) fn triangular_rows(n: usize, q: usize, row: impl Fn(usize, &mut [f64]) + Sync) -> DMatrix<f64> {
    // The triangular factor of one block of rows, as its top min(rows, q) rows.
    let reduce = |rows: std::ops::Range<usize>| -> DMatrix<f64> {
        // Rows written as the columns of the transpose (contiguous), then transposed once.
        let mut at = DMatrix::zeros(q, rows.len());
        for (r, i) in rows.enumerate() {
            row(i, at.column_mut(r).as_mut_slice());
        }
        triangular_factor(at.transpose())
    };
    let blocks: Vec<std::ops::Range<usize>> =
        (0..n.div_ceil(TSQR_BLOCK)).map(|b| b * TSQR_BLOCK..((b + 1) * TSQR_BLOCK).min(n)).collect();
    if blocks.len() <= 1 {
        reduce(0..n)
    } else {
        let parts: Vec<DMatrix<f64>> = blocks.into_par_iter().map(reduce).collect();
        let total: usize = parts.iter().map(|r| r.nrows()).sum();
        let mut stacked = DMatrix::zeros(total, q);
        let mut r0 = 0;
        for part in &parts {
            stacked.rows_mut(r0, part.nrows()).copy_from(part);
            r0 += part.nrows();
        }
        triangular_factor(stacked)
    }
}

/// The upper-triangular Householder factor of `a` (rows × q), as its top min(rows, q) rows.
fn triangular_factor(a: DMatrix<f64>) -> DMatrix<f64> {
    let k = a.nrows().min(a.ncols());
    let r = a.qr().r();
    r.rows(0, k).into_owned()
}

/// The ridge system of paper Eq. 7 in eigen form: G = ΨᵀΨ = V Λ Vᵀ and Ψᵀ R, so that
/// W(α) = V (Λ + αI)⁻¹ Vᵀ ΨᵀR costs O(K²) per α.
pub(crate) struct RidgeSystem {
    pub(crate) eigen: SymmetricEigen<f64, nalgebra::Dyn>,
    /// Vᵀ Ψᵀ R (K × outputs).
    pub(crate) vt_psi_r: DMatrix<f64>,
}

impl RidgeSystem {
    /// Build from the design Ψ (n × K) and residual targets R (n × m).
    pub(crate) fn new(psi: &DMatrix<f64>, r: &DMatrix<f64>) -> Result<Self, TrainerError> {
        Self::from_gram(psi.tr_mul(psi), &psi.tr_mul(r))
    }

    /// Build from G = ΨᵀΨ (K × K) and ΨᵀR (K × m); a G with a non-finite entry, or one whose
    /// decomposition does not converge, is an error rather than an endless iteration.
    pub(crate) fn from_gram(g: DMatrix<f64>, psi_r: &DMatrix<f64>) -> Result<Self, TrainerError> {
        let refuse =
            || TrainerError::fit("RBF ridge: the Gram matrix ΨᵀΨ holds non-finite values or does not decompose");
        if !g.iter().all(|v| v.is_finite()) {
            return Err(refuse());
        }
        let eigen = SymmetricEigen::try_new(g, f64::EPSILON, SVD_MAX_ITERATIONS).ok_or_else(refuse)?;
        let vt_psi_r = eigen.eigenvectors.tr_mul(psi_r);
        Ok(RidgeSystem { eigen, vt_psi_r })
    }

    /// Ridge weights W (K × m) for penalty `alpha` (the α of Eq. 7, in ΨᵀΨ units).
    pub(crate) fn weights(&self, alpha: f64) -> DMatrix<f64> {
        let mut t = self.vt_psi_r.clone();
        for (i, mut row) in t.row_iter_mut().enumerate() {
            let lam = self.eigen.eigenvalues[i].max(0.0);
            row.scale_mut(1.0 / (lam + alpha));
        }
        &self.eigen.eigenvectors * t
    }

    /// Eigenvalues of ΨᵀΨ + αI in ascending order, with their eigenvectors as columns.
    pub(crate) fn regularised_spectrum(&self, alpha: f64) -> (Vec<f64>, DMatrix<f64>) {
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

    /// A value whose square overflows makes R non-finite; nalgebra's unbounded SVD never
    /// returned on it.
    #[test]
    fn a_design_that_overflows_is_refused_not_iterated_forever() {
        for big in [1e154, 1e300, f64::NAN] {
            let x = DMatrix::from_fn(
                50,
                3,
                |i, j| if i == 7 && j == 1 { big } else { (i * (j + 1)) as f64 + (j * j) as f64 },
            );
            let y = DMatrix::from_fn(50, 1, |i, _| i as f64);
            let e = lstsq(x, y, "t").unwrap_err().to_string();
            assert!(e.contains("non-finite"), "{e}");
        }
        let g = DMatrix::from_row_slice(2, 2, &[1.0, f64::INFINITY, f64::INFINITY, 1.0]);
        assert!(RidgeSystem::from_gram(g, &DMatrix::zeros(2, 1)).is_err());
    }

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
    fn tall_lstsq_matches_the_single_block_solution() {
        // Several TSQR blocks (and a ragged last one) against the normal equations on a
        // well-conditioned system.
        let n = 3 * TSQR_BLOCK + 123;
        let x = DMatrix::from_fn(n, 4, |i, j| match j {
            0 => 1.0,
            1 => (i as f64 * 0.001).sin() * 50.0,
            2 => ((i * 7919) % 1000) as f64 * 0.01,
            _ => (i as f64 * 0.0003).cos(),
        });
        let y = DMatrix::from_fn(n, 2, |i, j| (i as f64 * 0.013 + j as f64).sin() + x[(i, 1)] * 0.3);
        let b = lstsq(x.clone(), y.clone(), "tall").unwrap();
        let direct = (x.tr_mul(&x)).cholesky().unwrap().solve(&x.tr_mul(&y));
        assert!((&b - &direct).amax() < 1e-9 * direct.amax(), "{b} vs {direct}");
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
        let sys = RidgeSystem::new(&psi, &r).unwrap();
        let alpha = 0.3;
        let w = sys.weights(alpha);
        let g = psi.tr_mul(&psi) + DMatrix::identity(4, 4) * alpha;
        let direct = g.cholesky().unwrap().solve(&psi.tr_mul(&r));
        assert!((w - direct).amax() < 1e-10);
    }
}
