//! The static gain of an inverse fit made right: classical calibration (DESIGN §4, static
//! fidelity).
//!
//! A least-squares fit of the measurands on the readings (an inverse fit, as every stage of
//! the compensator is) shrinks each gain by the share of the readings' variance that the
//! inputs' own errors make — drift, hysteresis, noise (regression dilution). That is the best
//! mean-square answer at the calibration week's mix of signal and error, but a settled reading
//! then falls short of the truth by that share, at any pace: for the paper's pressure channel
//! by a few per cent. Calibration in metrology fits the response against the standard and
//! inverts it; for a fitted inverse the same result is reached by regressing its readings on
//! the truths, ŷ = a + S·y, and replacing the readings by S⁻¹(ŷ − a), whose slope against
//! the truth is 1. Every part of a model is linear in its coefficients (B, Γ, W), so the
//! correction folds into them.

use nalgebra::DMatrix;

use fbg_shared::layout::{Dims, MAX_OUTPUTS};

use crate::data::Dataset;
use crate::error::TrainerError;
use crate::fit::linalg::lstsq_rows;

/// Largest departure of a diagonal gain S_cc from 1 that is taken as dilution. Beyond it the
/// readings are not a diluted version of the truth (a measurand that barely varies over the
/// batch, or a fit that failed): the correction would amplify noise, so none is made.
pub const MAX_DILUTION: f64 = 0.2;

/// The correction S⁻¹(ŷ − a) of one fit.
#[derive(Clone, Debug, PartialEq)]
pub struct GainCorrection {
    m: usize,
    s_inv: DMatrix<f64>,
    offset: [f64; MAX_OUTPUTS],
}

impl GainCorrection {
    /// The correction of the `readings` (one per row of `rows`, outputs of `dims`) against
    /// their references in `d`; `None` when a gain is beyond [`MAX_DILUTION`] or S is singular.
    pub fn fit(
        d: &Dataset,
        dims: &Dims,
        rows: &[usize],
        readings: &[[f64; MAX_OUTPUTS]],
    ) -> Result<Option<Self>, TrainerError> {
        let m = dims.n_outputs();
        let refs = d.references_of(dims);
        if rows.len() < 4 * (m + 1) || refs.iter().take(m).any(|r| !r.is_present()) {
            return Ok(None);
        }
        // ŷ_c = a_c + Σ_j S_cj y_j: one least squares, columns [1, y_1..y_M | ŷ_1..ŷ_M].
        let coef = lstsq_rows(rows.len(), m + 1, m, "classical gain", |r, buf| {
            let i = rows[r];
            buf[0] = 1.0;
            for j in 0..m {
                buf[1 + j] = refs[j][i];
            }
            buf[m + 1..2 * m + 1].copy_from_slice(&readings[r][..m]);
        })?;
        let s = DMatrix::from_fn(m, m, |c, j| coef[(1 + j, c)]);
        if (0..m).any(|c| !s[(c, c)].is_finite() || (s[(c, c)] - 1.0).abs() > MAX_DILUTION) {
            return Ok(None);
        }
        let Some(s_inv) = s.try_inverse() else {
            return Ok(None);
        };
        Ok(Some(GainCorrection { m, s_inv, offset: std::array::from_fn(|c| if c < m { coef[(0, c)] } else { 0.0 }) }))
    }

    /// Fold the correction into per-output coefficient rows `rows[c]` of a part of the model
    /// that is linear in them; `constant` is the index of the constant term (where the offset
    /// goes), `None` for a part without one.
    pub fn apply_rows<const L: usize>(&self, rows: &mut [[f64; L]; MAX_OUTPUTS], constant: Option<usize>) {
        let old = *rows;
        for (c, row) in rows.iter_mut().enumerate().take(self.m) {
            for (k, v) in row.iter_mut().enumerate() {
                *v = (0..self.m)
                    .map(|j| self.s_inv[(c, j)] * (old[j][k] - if Some(k) == constant { self.offset[j] } else { 0.0 }))
                    .sum();
            }
        }
    }

    /// Fold the correction into a polynomial core's B (constant term first).
    pub fn apply<const L: usize>(&self, poly: &mut [[f64; L]; MAX_OUTPUTS]) {
        self.apply_rows(poly, Some(0));
    }

    /// Fold the correction into one centre's weights (one per output).
    pub fn apply_weights(&self, w: &mut [f64; MAX_OUTPUTS]) {
        let old = *w;
        for (c, v) in w.iter_mut().enumerate().take(self.m) {
            *v = (0..self.m).map(|j| self.s_inv[(c, j)] * old[j]).sum();
        }
    }

    /// The gain matrix's inverse S⁻¹ entry (c, j), for the audit.
    pub fn s_inv(&self, c: usize, j: usize) -> f64 {
        self.s_inv.get((c, j)).copied().unwrap_or(0.0)
    }
}
