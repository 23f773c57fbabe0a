//! Sensitivities at the calibration point, as a metrologist writes them on a calibration
//! sheet: each grating's sensitivity to each measurand, ∂Δλ_i/∂y_j (pm/°C, pm/µε, pm/kPa),
//! and the model's inverse, ∂ŷ_j/∂Δλ_i (°C/pm, µε/pm, kPa/pm).
//!
//! **The inverse** is the slope of Model-P's static map — its settled reading
//! ([`super::static_fidelity::settled_model`]: high-pass memory terms at 0; Model-P carries no
//! memory terms and no RBF residual, so that is its polynomial core Bφ) — at the calibration's
//! mean input. Stage 1 is linear, so the mean input maps onto the mean first guess, where
//! every standardised guess ĝ_m = (g_m − mean_m)/std_m is 0; the slope is taken there,
//! analytically:
//!
//! ∂ŷ_j/∂x_c = Σ_k B_jk Σ_m ∂φ_k/∂ĝ_m · A_mc / std_m,
//!
//! with A the stage-1 matrix, φ the degree-2 polynomial (at ĝ = 0 only its linear terms have a
//! slope) and x_c an input: a grating's shift, or T_amb when the model has the ambient input.
//!
//! **The ambient thermometer.** With the ambient input, J_Δλ (the gratings' slopes, T_amb
//! held) is not what a calibration sheet means: once settled, the thermometer reads the
//! structure's temperature, so a change of temperature moves T_amb too, and a model that takes
//! part of its temperature from the thermometer (∂T̂/∂T_amb = u_T > 0) would otherwise seem to
//! need more pm per °C from the gratings than they give. With a temperature output T, the
//! inverse is therefore the reading's slope with T_amb following T̂ (Sherman–Morrison on
//! ŷ = J_Δλ·Δλ + u·T̂):
//!
//! J = (I − u·e_Tᵀ)⁻¹ J_Δλ = J_Δλ + u·(row T of J_Δλ) / (1 − u_T),
//!
//! refused when 1 − u_T is near 0 (the model reads the temperature from the thermometer alone:
//! the gratings then carry no temperature). Without a temperature output, T_amb is held.
//! Either way T_amb's own slope with the gratings held, u, is given beside them
//! ([`Sensitivity::ambient`]).
//!
//! **The forward sensitivity** is the inverse's inverse: S = J⁻¹ for as many gratings as
//! outputs, the Moore–Penrose pseudo-inverse J⁺ otherwise (N > M: the least-squares split of
//! a change of the outputs over the gratings; J·J⁺ = I still holds when J has rank M), and
//! [`Sensitivity::method`] says which. It is what the readings do per unit of each measurand
//! in steady state: the gratings' gauge factors, plus whatever the interrogator adds that moves
//! with the measurand (an electronics drift that follows the ambient temperature adds to every
//! grating's temperature sensitivity).

use nalgebra::DMatrix;

use fbg_shared::layout::{MAX_OUTPUTS, MAX_POLY};

use super::host::HostParams;
use crate::data::Measurand;
use crate::error::TrainerError;

/// Relative size (to the largest) below which a singular value of J counts as 0 for the rank
/// and the pseudo-inverse: above the f32 rounding of the blob's coefficients (~1e-7), far below
/// the ratios of physical gauge matrices (the paper's 3 × 3 has ~3e-2).
pub const RANK_TOLERANCE: f64 = 1e-6;

/// Smallest |1 − ∂T̂/∂T_amb| for which the gratings are taken to carry the temperature (see
/// the module docs): below it the model reads T from the thermometer alone.
pub const THERMOMETER_SHARE_LIMIT: f64 = 1e-3;

/// How the forward sensitivity was obtained from the inverse J (M outputs × N gratings).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum ForwardMethod {
    /// N = M and J has full rank: S = J⁻¹.
    Inverse,
    /// N ≠ M, or J is rank-deficient: S = J⁺ (Moore–Penrose).
    PseudoInverse,
}

impl ForwardMethod {
    /// In words, for tables and the terminal.
    pub fn describe(self) -> &'static str {
        match self {
            ForwardMethod::Inverse => "the inverse of ∂ŷ/∂Δλ",
            ForwardMethod::PseudoInverse => "the Moore–Penrose pseudo-inverse of ∂ŷ/∂Δλ",
        }
    }
}

/// The sensitivities of a model at its calibration's mean input.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sensitivity {
    /// Column names of the outputs (`T_C`, `strain_ue`, …), in output order.
    pub outputs: Vec<String>,
    /// Their units (`°C`, `µε`, `kPa`).
    pub units: Vec<String>,
    /// Number of gratings N.
    pub gratings: usize,
    /// ∂ŷ_j/∂Δλ_i: M rows (outputs) × N columns (gratings), in output unit per pm; with the
    /// ambient input and a temperature output, T_amb follows T̂ ([`Sensitivity::ambient_follows`]),
    /// otherwise T_amb is held.
    pub inverse: Vec<Vec<f64>>,
    /// ∂ŷ_j/∂T_amb with the gratings held: per output, in output unit per °C (`None` without
    /// the ambient input).
    pub ambient: Option<Vec<f64>>,
    /// Whether `inverse` lets T_amb follow the temperature output (ambient input and a
    /// temperature output) rather than holding it.
    pub ambient_follows: bool,
    /// ∂Δλ_i/∂y_j: N rows (gratings) × M columns (outputs), in pm per output unit.
    pub forward: Vec<Vec<f64>>,
    /// How `forward` was obtained from `inverse`.
    pub method: ForwardMethod,
    /// Rank of `inverse` (M when every output is determined by the gratings).
    pub rank: usize,
}

impl Sensitivity {
    /// `inverse`'s unit per output: `°C/pm`, …
    pub fn inverse_units(&self) -> Vec<String> {
        self.units.iter().map(|u| format!("{u}/pm")).collect()
    }

    /// `forward`'s unit per output: `pm/°C`, …
    pub fn forward_units(&self) -> Vec<String> {
        self.units.iter().map(|u| format!("pm/{u}")).collect()
    }

    /// One sentence on how the numbers were obtained (for captions and the terminal).
    pub fn how(&self) -> String {
        let m = self.outputs.len();
        let amb = match (&self.ambient, self.ambient_follows) {
            (None, _) => "",
            (Some(_), true) => ", with the ambient thermometer following the temperature as it does once settled",
            (Some(_), false) => ", with T_amb held",
        };
        let mut s = format!(
            "at the calibration's mean input, from Model-P's static map (its polynomial core; high-pass memory terms at 0){amb}; ∂Δλ/∂y is {}",
            self.method.describe()
        );
        if self.method == ForwardMethod::PseudoInverse {
            s.push_str(&format!(" ({} gratings, {m} outputs, rank {})", self.gratings, self.rank));
            if self.rank < m {
                s.push_str(": the gratings do not determine every output, so ∂ŷ/∂Δλ · ∂Δλ/∂y is not the identity");
            }
        }
        s
    }
}

/// ∂φ_k/∂ĝ_m at the standardised guesses `g` (rows k, columns m).
fn dphi(p: &HostParams, g: &[f64; MAX_OUTPUTS]) -> [[f64; MAX_OUTPUTS]; MAX_POLY] {
    let mut d = [[0.0; MAX_OUTPUTS]; MAX_POLY];
    for (k, row) in d.iter_mut().enumerate().take(p.dims.poly_len()) {
        match p.dims.poly_term(k) {
            Some((i, None)) => row[i] = 1.0,
            Some((i, Some(j))) if i == j => row[i] = 2.0 * g[i],
            Some((i, Some(j))) => {
                row[i] = g[j];
                row[j] = g[i];
            }
            None => {}
        }
    }
    d
}

/// ∂ŷ/∂x of `p`'s polynomial core at the standardised guesses `g`: M rows × the stage-1
/// inputs (the N shifts, then T_amb with the ambient input).
pub fn core_jacobian(p: &HostParams, g: &[f64; MAX_OUTPUTS]) -> Vec<Vec<f64>> {
    let dims = &p.dims;
    let (m, n_in) = (dims.n_outputs(), dims.stage1_len() - 1);
    let dp = dphi(p, g);
    // ∂ŷ_j/∂ĝ_m = Σ_k B_jk ∂φ_k/∂ĝ_m.
    let dy_dg: Vec<Vec<f64>> = (0..m)
        .map(|j| (0..m).map(|mm| (0..dims.poly_len()).map(|k| p.poly[j][k] * dp[k][mm]).sum()).collect())
        .collect();
    (0..m)
        .map(|j| {
            (0..n_in).map(|c| (0..m).map(|mm| dy_dg[j][mm] * p.stage1[mm][c] / p.guess_std[mm]).sum::<f64>()).collect()
        })
        .collect()
}

/// The sensitivities of Model-P `p` at its calibration's mean input (see the module docs).
///
/// Errors when a stored first-guess scale is not positive and finite (not a model `train`
/// writes).
pub fn of(p: &HostParams) -> Result<Sensitivity, TrainerError> {
    let dims = &p.dims;
    let (m, n) = (dims.n_outputs(), dims.gratings());
    if let Some(o) = (0..m).find(|&o| !(p.guess_std[o].is_finite() && p.guess_std[o] > 0.0)) {
        return Err(TrainerError::fit(format!(
            "sensitivities: the first-guess scale of output {} is {}, not a positive number",
            o + 1,
            p.guess_std[o]
        )));
    }
    let full = core_jacobian(p, &[0.0; MAX_OUTPUTS]);
    let mut inverse: Vec<Vec<f64>> = full.iter().map(|r| r[..n].to_vec()).collect();
    let ambient: Option<Vec<f64>> = dims.ambient().then(|| full.iter().map(|r| r[n]).collect());
    let t = dims.position(fbg_shared::layout::Quantity::Temperature);
    let ambient_follows = ambient.is_some() && t.is_some();
    if let (Some(u), Some(t)) = (&ambient, t) {
        let rest = 1.0 - u[t];
        if rest.is_nan() || rest.abs() < THERMOMETER_SHARE_LIMIT {
            return Err(TrainerError::fit(format!(
                "sensitivities: the model reads the temperature from the ambient thermometer alone (∂T̂/∂T_amb = {:.4}), so the gratings carry no temperature sensitivity",
                u[t]
            )));
        }
        let row_t = inverse[t].clone();
        for (row, uj) in inverse.iter_mut().zip(u) {
            for (x, rt) in row.iter_mut().zip(&row_t) {
                *x += uj * rt / rest;
            }
        }
    }
    let j = DMatrix::from_fn(m, n, |r, c| inverse[r][c]);
    // Bounded: nalgebra's unbounded SVD never returns on a NaN.
    let svd = j
        .iter()
        .all(|v| v.is_finite())
        .then(|| j.clone().try_svd(true, true, f64::EPSILON, 10_000))
        .flatten()
        .ok_or_else(|| TrainerError::fit("sensitivities: ∂ŷ/∂Δλ holds non-finite values"))?;
    let smax = svd.singular_values.max();
    let rank = svd.singular_values.iter().filter(|&&s| s > RANK_TOLERANCE * smax).count();
    let s = svd
        .pseudo_inverse(RANK_TOLERANCE * smax)
        .map_err(|e| TrainerError::fit(format!("sensitivities: pseudo-inverse of ∂ŷ/∂Δλ: {e}")))?;
    let method = if n == m && rank == m { ForwardMethod::Inverse } else { ForwardMethod::PseudoInverse };
    let forward = (0..n).map(|i| (0..m).map(|c| s[(i, c)]).collect()).collect();
    let outs = Measurand::of_dims(dims);
    Ok(Sensitivity {
        outputs: outs.iter().map(|x| x.column()).collect(),
        units: outs.iter().map(|x| x.unit().to_string()).collect(),
        gratings: n,
        inverse,
        ambient,
        ambient_follows,
        forward,
        method,
        rank,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dphi_has_the_slopes_of_each_term() {
        // Outputs 2: φ = [1, g1, g2, g1², g2², g1·g2].
        let dims = fbg_shared::layout::Dims::new(
            2,
            false,
            &[
                fbg_shared::layout::Output::first(fbg_shared::layout::Quantity::Temperature),
                fbg_shared::layout::Output::first(fbg_shared::layout::Quantity::Strain),
            ],
        )
        .unwrap();
        let p = HostParams { dims, ..HostParams::default() };
        let d = dphi(&p, &[0.5, -2.0, 0.0, 0.0]);
        assert_eq!(&d[0][..2], &[0.0, 0.0]);
        assert_eq!(&d[1][..2], &[1.0, 0.0]);
        assert_eq!(&d[2][..2], &[0.0, 1.0]);
        assert_eq!(&d[3][..2], &[1.0, 0.0]);
        assert_eq!(&d[4][..2], &[0.0, -4.0]);
        assert_eq!(&d[5][..2], &[-2.0, 0.5]);
    }
}
