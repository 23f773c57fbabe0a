//! Model-P (paper Eq. 3): stage 1, a linear least-squares inverse from [Δλ_1..N, T_amb (with
//! ambient), 1] to first guesses of the M measurands; stage 2, the degree-2 polynomial φ on the
//! standardised guesses (1 + M + M(M+1)/2 terms, the paper's ten for M = 3), fitted by least
//! squares. The dimensions come from the dataset ([`Dataset::dims`]): output `c` is its
//! reference `c`.

use fbg_shared::layout::{Dims, MAX_MEMORY, MAX_OUTPUTS, MAX_POLY, MAX_STAGE1};
use fbg_shared::MemorySpec;

use crate::data::Dataset;
use crate::error::TrainerError;
use rayon::prelude::*;

use super::linalg::lstsq_rows;

/// A fitted polynomial core. Arrays are sized to the capacity; only the entries of `dims`
/// are used (the rest are 0).
#[derive(Clone, Debug, PartialEq)]
pub struct PolyCore {
    /// Gratings, ambient input and measurands.
    pub dims: Dims,
    /// First guesses = stage1 · [Δλ_1..N, T_amb (with ambient), 1].
    pub stage1: [[f64; MAX_STAGE1]; MAX_OUTPUTS],
    pub guess_mean: [f64; MAX_OUTPUTS],
    pub guess_std: [f64; MAX_OUTPUTS],
    /// B on standardised guesses, columns in [`Dims::poly_term`] order.
    pub poly: [[f64; MAX_POLY]; MAX_OUTPUTS],
    /// Memory operators of the core (off for Model-P; see [`crate::fit::memory_core`]).
    pub memory: MemorySpec<f64>,
    /// Γ: per output, the coefficient of each memory term (output unit per term unit).
    pub gamma: [[f64; MAX_MEMORY]; MAX_OUTPUTS],
}

/// φ of paper Eq. 3 generalised to the M guesses `g` of `dims` ([`Dims::poly_term`] order),
/// with the quadratic and cross terms optionally zeroed (the "without cross-terms" ablation
/// keeps [1, g_1..g_M]).
pub(crate) fn phi(dims: &Dims, g: &[f64; MAX_OUTPUTS], cross_terms: bool) -> [f64; MAX_POLY] {
    let mut out = [0.0; MAX_POLY];
    out[0] = 1.0;
    for (k, o) in out.iter_mut().enumerate().take(dims.poly_len()).skip(1) {
        *o = match dims.poly_term(k) {
            Some((i, None)) => g[i],
            Some((i, Some(j))) if cross_terms => g[i] * g[j],
            _ => 0.0,
        };
    }
    out
}

/// The stage-1 regressors [Δλ_1..N, T_amb (with ambient), 1] of sample `i`.
fn stage1_row(dims: &Dims, d: &Dataset, i: usize) -> [f64; MAX_STAGE1] {
    let mut x = [0.0; MAX_STAGE1];
    let n = dims.gratings();
    for (o, c) in x.iter_mut().zip(&d.dl_pm).take(n) {
        *o = c[i];
    }
    if dims.ambient() {
        x[n] = d.ambient()[i];
    }
    x[dims.stage1_len() - 1] = 1.0;
    x
}

/// The stage-1 first guesses (in the outputs' units) of sample `i`.
fn first_guess(dims: &Dims, stage1: &[[f64; MAX_STAGE1]; MAX_OUTPUTS], d: &Dataset, i: usize) -> [f64; MAX_OUTPUTS] {
    let x = stage1_row(dims, d, i);
    let ns = dims.stage1_len();
    std::array::from_fn(|o| {
        if o < dims.n_outputs() {
            x[..ns].iter().zip(&stage1[o][..ns]).map(|(x, a)| x * a).sum()
        } else {
            0.0
        }
    })
}

/// φ of the standardised first guesses of sample `i` (see [`phi`]).
fn phi_at(
    dims: &Dims,
    stage1: &[[f64; MAX_STAGE1]; MAX_OUTPUTS],
    mean: &[f64; MAX_OUTPUTS],
    std: &[f64; MAX_OUTPUTS],
    d: &Dataset,
    i: usize,
    cross_terms: bool,
) -> [f64; MAX_POLY] {
    let g = first_guess(dims, stage1, d, i);
    let m = dims.n_outputs();
    phi(dims, &std::array::from_fn(|o| if o < m { (g[o] - mean[o]) / std[o] } else { 0.0 }), cross_terms)
}

/// Fit Model-P on the samples `idx` of `d`, with the dimensions of `d` ([`Dataset::dims`]).
pub(crate) fn fit(d: &Dataset, idx: &[usize], cross_terms: bool) -> Result<PolyCore, TrainerError> {
    let dims = d.dims("the dataset")?;
    let (ns, m, np) = (dims.stage1_len(), dims.n_outputs(), dims.poly_len());
    let n = idx.len();
    let a = lstsq_rows(n, ns, m, "Model-P stage 1 (linear inverse)", |r, buf| {
        let i = idx[r];
        buf[..ns].copy_from_slice(&stage1_row(&dims, d, i)[..ns]);
        for (o, v) in buf[ns..].iter_mut().enumerate() {
            *v = d.target(o)[i];
        }
    })?;
    let mut stage1 = [[0.0; MAX_STAGE1]; MAX_OUTPUTS];
    for (o, row) in stage1.iter_mut().enumerate().take(m) {
        for (k, v) in row.iter_mut().enumerate().take(ns) {
            *v = a[(k, o)];
        }
    }
    let guess = |i: usize| first_guess(&dims, &stage1, d, i);
    // Mean and standard deviation of the first guesses (two passes, in parallel blocks summed
    // in order).
    let sums = |f: &(dyn Fn([f64; MAX_OUTPUTS]) -> [f64; MAX_OUTPUTS] + Sync)| -> [f64; MAX_OUTPUTS] {
        let parts: Vec<[f64; MAX_OUTPUTS]> = idx
            .par_chunks(8192)
            .map(|ch| {
                let mut s = [0.0; MAX_OUTPUTS];
                for &i in ch {
                    let v = f(guess(i));
                    for o in 0..m {
                        s[o] += v[o];
                    }
                }
                s
            })
            .collect();
        parts.iter().fold([0.0; MAX_OUTPUTS], |a, b| std::array::from_fn(|o| a[o] + b[o]))
    };
    let mean_all = sums(&|g| g).map(|s| s / n as f64);
    let var_all = sums(&|g| std::array::from_fn(|o| (g[o] - mean_all[o]) * (g[o] - mean_all[o])));
    let mut guess_mean = [0.0; MAX_OUTPUTS];
    let mut guess_std = [0.0; MAX_OUTPUTS];
    for o in 0..m {
        let s = (var_all[o] / n as f64).sqrt();
        if s.is_nan() || s <= 0.0 {
            return Err(TrainerError::fit(format!(
                "Model-P: the first guess of output {o} ({}) does not vary over the calibration data",
                dims.outputs()[o].column()
            )));
        }
        guess_mean[o] = mean_all[o];
        guess_std[o] = s;
    }
    // Terms of φ: all of them, or the constant and the linear terms for the ablation.
    let terms: Vec<usize> = (0..np).filter(|&k| cross_terms || k <= m).collect();
    let nt = terms.len();
    let b = lstsq_rows(n, nt, m, "Model-P stage 2 (polynomial core)", |r, buf| {
        let i = idx[r];
        let ph = phi_at(&dims, &stage1, &guess_mean, &guess_std, d, i, cross_terms);
        for (v, &k) in buf.iter_mut().zip(&terms) {
            *v = ph[k];
        }
        for (o, v) in buf[nt..].iter_mut().enumerate() {
            *v = d.target(o)[i];
        }
    })?;
    let mut poly = [[0.0; MAX_POLY]; MAX_OUTPUTS];
    for (o, row) in poly.iter_mut().enumerate().take(m) {
        for (c, &k) in terms.iter().enumerate() {
            row[k] = b[(c, o)];
        }
    }
    Ok(PolyCore {
        dims,
        stage1,
        guess_mean,
        guess_std,
        poly,
        memory: MemorySpec::off(),
        gamma: [[0.0; MAX_MEMORY]; MAX_OUTPUTS],
    })
}

impl PolyCore {
    /// The core of a model's parameters (B, Γ and what they act on).
    pub fn of(p: &super::host::HostParams) -> Self {
        PolyCore {
            dims: p.dims,
            stage1: p.stage1,
            guess_mean: p.guess_mean,
            guess_std: p.guess_std,
            poly: p.poly,
            memory: p.memory,
            gamma: p.gamma,
        }
    }

    /// φ (every term) of the standardised first guesses of sample `i`: the regressors B
    /// multiplies.
    pub(crate) fn phi_at(&self, d: &Dataset, i: usize) -> [f64; MAX_POLY] {
        phi_at(&self.dims, &self.stage1, &self.guess_mean, &self.guess_std, d, i, true)
    }

    /// B re-expressed on the *physical* first guesses (in the outputs' units): the coefficients
    /// a metrologist reads, y = Σ c_k φ_k(g) with φ in [`Dims::poly_term`] order.
    pub fn physical_coefficients(&self) -> [[f64; MAX_POLY]; MAX_OUTPUTS] {
        let (m, s) = (self.guess_mean, self.guess_std);
        let dims = &self.dims;
        let n_out = dims.n_outputs();
        let mut out = [[0.0; MAX_POLY]; MAX_OUTPUTS];
        // u_i = (g_i − m_i)/s_i = a_i g_i + c_i.
        let a: [f64; MAX_OUTPUTS] = std::array::from_fn(|i| if i < n_out { 1.0 / s[i] } else { 0.0 });
        let c: [f64; MAX_OUTPUTS] = std::array::from_fn(|i| if i < n_out { -m[i] / s[i] } else { 0.0 });
        let lin = |i: usize| 1 + i;
        for (o, b) in self.poly.iter().enumerate().take(n_out) {
            let mut p = [0.0; MAX_POLY];
            p[0] += b[0];
            // Expand each term of B·φ(u), in φ order: linear terms, squares, products.
            for k in 1..dims.poly_len() {
                match dims.poly_term(k) {
                    Some((i, None)) => {
                        p[lin(i)] += b[k] * a[i];
                        p[0] += b[k] * c[i];
                    }
                    // u_i² = a_i² g_i² + 2 a_i c_i g_i + c_i²
                    Some((i, Some(j))) if i == j => {
                        p[k] += b[k] * a[i] * a[i];
                        p[lin(i)] += b[k] * 2.0 * a[i] * c[i];
                        p[0] += b[k] * c[i] * c[i];
                    }
                    // u_i u_j = a_i a_j g_i g_j + a_i c_j g_i + c_i a_j g_j + c_i c_j
                    Some((i, Some(j))) => {
                        p[k] += b[k] * a[i] * a[j];
                        p[lin(i)] += b[k] * a[i] * c[j];
                        p[lin(j)] += b[k] * c[i] * a[j];
                        p[0] += b[k] * c[i] * c[j];
                    }
                    None => {}
                }
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
        use fbg_shared::layout::pad;
        let dims = Dims::PAPER;
        let core = PolyCore {
            dims,
            stage1: [[0.0; MAX_STAGE1]; MAX_OUTPUTS],
            guess_mean: pad(&[20.0, -5.0, 150.0]),
            guess_std: pad(&[3.0, 90.0, 18.0]),
            poly: fbg_shared::layout::pad2(&[
                [1.0, 2.0, 3.0, 4.0, 0.5, 0.25, 0.125, 0.1, 0.2, 0.3],
                [-1.0, 0.5, 0.0, 2.0, 0.0, 1.0, 0.0, -0.4, 0.0, 0.7],
                [0.0; 10],
            ]),
            memory: MemorySpec::off(),
            gamma: [[0.0; MAX_MEMORY]; MAX_OUTPUTS],
        };
        let phys = core.physical_coefficients();
        for g in [[21.0, 40.0, 160.0], [15.5, -120.0, 130.0]] {
            let g: [f64; MAX_OUTPUTS] = pad(&g);
            let u = std::array::from_fn(|i| if i < 3 { (g[i] - core.guess_mean[i]) / core.guess_std[i] } else { 0.0 });
            for (o, phys_o) in phys.iter().enumerate().take(3) {
                let a: f64 = core.poly[o].iter().zip(phi(&dims, &u, true)).map(|(b, f)| b * f).sum();
                let b: f64 = phys_o.iter().zip(phi(&dims, &g, true)).map(|(b, f)| b * f).sum();
                assert!((a - b).abs() < 1e-9 * (1.0 + a.abs()), "{a} vs {b}");
            }
        }
    }
}
