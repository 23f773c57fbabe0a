//! Model-P (paper Eq. 3): stage 1, a linear least-squares inverse from [Δλ1..3, T_amb, 1] to
//! first guesses of (T, ε, p); stage 2, the ten-term polynomial φ on the standardised guesses,
//! fitted by least squares.

use fbg_shared::layout::paper::{N_MEMORY, N_OUTPUTS, N_POLY, N_STAGE1};
use fbg_shared::layout::{pad, pad2};
use fbg_shared::MemorySpec;

use crate::data::Dataset;
use crate::error::TrainerError;
use rayon::prelude::*;

use crate::fit::linalg::lstsq_rows;

/// A fitted polynomial core.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PolyCore {
    /// First guesses = stage1 · [Δλ1, Δλ2, Δλ3, T_amb, 1].
    pub stage1: [[f64; N_STAGE1]; N_OUTPUTS],
    pub guess_mean: [f64; N_OUTPUTS],
    pub guess_std: [f64; N_OUTPUTS],
    /// B on standardised guesses.
    pub poly: [[f64; N_POLY]; N_OUTPUTS],
    /// Memory operators of the core (off for Model-P; see [`crate::fit::memory_core`]).
    pub memory: MemorySpec<f64>,
    /// Γ: per output, the coefficient of each memory term (output unit per term unit).
    pub gamma: [[f64; N_MEMORY]; N_OUTPUTS],
}

/// φ of paper Eq. 3 on standardised guesses, with the cross/quadratic terms optionally zeroed
/// (the "without cross-terms" ablation keeps [1, T, ε, p]).
pub fn phi(g: [f64; 3], cross_terms: bool) -> [f64; N_POLY] {
    let [t, e, p] = g;
    if cross_terms {
        [1.0, t, e, p, t * t, e * e, p * p, t * e, t * p, e * p]
    } else {
        [1.0, t, e, p, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    }
}

/// The first guesses (0 T, 1 ε, 2 p) each term of φ is built from.
const TERM_USES: [&[usize]; N_POLY] = [&[], &[0], &[1], &[2], &[0], &[1], &[2], &[0, 1], &[0, 2], &[1, 2]];

fn stage1_row(d: &Dataset, i: usize) -> [f64; N_STAGE1] {
    [d.dl_pm[0][i], d.dl_pm[1][i], d.dl_pm[2][i], d.ambient()[i], 1.0]
}

/// The stage-1 first guesses (T °C, ε µε, p kPa) of sample `i`.
fn first_guess(stage1: &[[f64; N_STAGE1]; N_OUTPUTS], d: &Dataset, i: usize) -> [f64; N_OUTPUTS] {
    let x = stage1_row(d, i);
    std::array::from_fn(|o| x.iter().zip(&stage1[o]).map(|(x, a)| x * a).sum())
}

/// φ of the standardised first guesses of sample `i` (see [`phi`]).
fn phi_at(
    stage1: &[[f64; N_STAGE1]; N_OUTPUTS],
    mean: &[f64; N_OUTPUTS],
    std: &[f64; N_OUTPUTS],
    d: &Dataset,
    i: usize,
    cross_terms: bool,
) -> [f64; N_POLY] {
    let g = first_guess(stage1, d, i);
    phi(std::array::from_fn(|o| (g[o] - mean[o]) / std[o]), cross_terms)
}

/// The references (T, ε, p) of sample `i`; an output without reference reads 0, which keeps
/// the algebra square and gives it zero coefficients.
fn targets(d: &Dataset, i: usize) -> [f64; N_OUTPUTS] {
    std::array::from_fn(|c| if d.has_target()[c] { d.target(c)[i] } else { 0.0 })
}

/// Fit Model-P on the samples `idx` of `d`.
pub fn fit(d: &Dataset, idx: &[usize], cross_terms: bool) -> Result<PolyCore, TrainerError> {
    let n = idx.len();
    let a = lstsq_rows(n, N_STAGE1, N_OUTPUTS, "Model-P stage 1 (linear inverse)", |r, buf| {
        let i = idx[r];
        buf[..N_STAGE1].copy_from_slice(&stage1_row(d, i));
        buf[N_STAGE1..].copy_from_slice(&targets(d, i));
    })?;
    let mut stage1 = [[0.0; N_STAGE1]; N_OUTPUTS];
    for (o, row) in stage1.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = a[(k, o)];
        }
    }
    let guess = |i: usize| first_guess(&stage1, d, i);
    // Mean and standard deviation of the first guesses (two passes, in parallel blocks summed
    // in order).
    let sums = |f: &(dyn Fn([f64; N_OUTPUTS]) -> [f64; N_OUTPUTS] + Sync)| -> [f64; N_OUTPUTS] {
        let parts: Vec<[f64; N_OUTPUTS]> = idx
            .par_chunks(8192)
            .map(|ch| {
                let mut s = [0.0; N_OUTPUTS];
                for &i in ch {
                    let v = f(guess(i));
                    for o in 0..N_OUTPUTS {
                        s[o] += v[o];
                    }
                }
                s
            })
            .collect();
        parts.iter().fold([0.0; N_OUTPUTS], |a, b| std::array::from_fn(|o| a[o] + b[o]))
    };
    let mean_all = sums(&|g| g).map(|s| s / n as f64);
    let var_all = sums(&|g| std::array::from_fn(|o| (g[o] - mean_all[o]) * (g[o] - mean_all[o])));
    let mut guess_mean = [0.0; N_OUTPUTS];
    let mut guess_std = [0.0; N_OUTPUTS];
    for o in 0..N_OUTPUTS {
        if !d.has_target()[o] {
            guess_mean[o] = 0.0;
            guess_std[o] = 1.0;
            continue;
        }
        let s = (var_all[o] / n as f64).sqrt();
        if s.is_nan() || s <= 0.0 {
            return Err(TrainerError::fit(format!(
                "Model-P: the first guess of output {o} does not vary over the calibration data"
            )));
        }
        guess_mean[o] = mean_all[o];
        guess_std[o] = s;
    }
    // Terms of φ that the data can support: within the ablation's linear set if asked, and
    // built only from guesses of fitted outputs (an unfitted guess is identically 0).
    let terms: Vec<usize> =
        (0..N_POLY).filter(|&k| (cross_terms || k < 4) && TERM_USES[k].iter().all(|&o| d.has_target()[o])).collect();
    let nt = terms.len();
    let b = lstsq_rows(n, nt, N_OUTPUTS, "Model-P stage 2 (polynomial core)", |r, buf| {
        let i = idx[r];
        let ph = phi_at(&stage1, &guess_mean, &guess_std, d, i, cross_terms);
        for (v, &k) in buf.iter_mut().zip(&terms) {
            *v = ph[k];
        }
        buf[nt..].copy_from_slice(&targets(d, i));
    })?;
    let mut poly = [[0.0; N_POLY]; N_OUTPUTS];
    for (o, row) in poly.iter_mut().enumerate() {
        for (c, &k) in terms.iter().enumerate() {
            row[k] = b[(c, o)];
        }
    }
    Ok(PolyCore { stage1, guess_mean, guess_std, poly, memory: MemorySpec::off(), gamma: [[0.0; N_MEMORY]; N_OUTPUTS] })
}

impl PolyCore {
    /// The core of a model's parameters (B, Γ and what they act on).
    pub fn of(p: &crate::fit::HostParams) -> Self {
        PolyCore {
            stage1: pad2(&p.stage1),
            guess_mean: pad(&p.guess_mean),
            guess_std: pad(&p.guess_std),
            poly: pad2(&p.poly),
            memory: p.memory,
            gamma: pad2(&p.gamma),
        }
    }

    /// φ (all ten terms) of the standardised first guesses of sample `i`: the regressors B
    /// multiplies.
    pub fn phi_at(&self, d: &Dataset, i: usize) -> [f64; N_POLY] {
        phi_at(&self.stage1, &self.guess_mean, &self.guess_std, d, i, true)
    }

    /// B re-expressed on the *physical* first guesses (T °C, ε µε, p kPa): the coefficients a
    /// metrologist reads, y = Σ c_k φ_k(g) with φ in [`fbg_shared::layout::paper::POLY_NAMES`] order.
    pub fn physical_coefficients(&self) -> [[f64; N_POLY]; N_OUTPUTS] {
        let (m, s) = (self.guess_mean, self.guess_std);
        let mut out = [[0.0; N_POLY]; N_OUTPUTS];
        for (o, b) in self.poly.iter().enumerate() {
            // u_i = (g_i − m_i)/s_i = g_i/s_i − m_i/s_i. Expand each term of B·φ(u).
            let a: [f64; 3] = std::array::from_fn(|i| 1.0 / s[i]);
            let c: [f64; 3] = std::array::from_fn(|i| -m[i] / s[i]);
            let mut p = [0.0; N_POLY];
            // constant
            p[0] += b[0];
            // linear terms u_i = a_i g_i + c_i
            for i in 0..3 {
                p[1 + i] += b[1 + i] * a[i];
                p[0] += b[1 + i] * c[i];
            }
            // squares u_i² = a_i² g_i² + 2 a_i c_i g_i + c_i²
            for i in 0..3 {
                let bi = b[4 + i];
                p[4 + i] += bi * a[i] * a[i];
                p[1 + i] += bi * 2.0 * a[i] * c[i];
                p[0] += bi * c[i] * c[i];
            }
            // products u_i u_j = a_i a_j g_i g_j + a_i c_j g_i + c_i a_j g_j + c_i c_j
            for (k, (i, j)) in [(0usize, 1usize), (0, 2), (1, 2)].into_iter().enumerate() {
                let bk = b[7 + k];
                p[7 + k] += bk * a[i] * a[j];
                p[1 + i] += bk * a[i] * c[j];
                p[1 + j] += bk * c[i] * a[j];
                p[0] += bk * c[i] * c[j];
            }
            out[o] = p;
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn physical_coefficients_evaluate_like_the_standardised_ones() {
        let core = PolyCore {
            stage1: [[0.0; 5]; 3],
            guess_mean: [20.0, -5.0, 150.0],
            guess_std: [3.0, 90.0, 18.0],
            poly: [
                [1.0, 2.0, 3.0, 4.0, 0.5, 0.25, 0.125, 0.1, 0.2, 0.3],
                [-1.0, 0.5, 0.0, 2.0, 0.0, 1.0, 0.0, -0.4, 0.0, 0.7],
                [0.0; 10],
            ],
            memory: MemorySpec::off(),
            gamma: [[0.0; N_MEMORY]; N_OUTPUTS],
        };
        let phys = core.physical_coefficients();
        for g in [[21.0, 40.0, 160.0], [15.5, -120.0, 130.0]] {
            let u = std::array::from_fn(|i| (g[i] - core.guess_mean[i]) / core.guess_std[i]);
            for (o, phys_o) in phys.iter().enumerate() {
                let a: f64 = core.poly[o].iter().zip(phi(u, true)).map(|(b, f)| b * f).sum();
                let b: f64 = phys_o.iter().zip(phi(g, true)).map(|(b, f)| b * f).sum();
                assert!((a - b).abs() < 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
            }
        }
    }
}
