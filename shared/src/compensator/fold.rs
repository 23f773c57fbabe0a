//! Load-time folding: the auditable parameters turned into the per-sample form, in the
//! model's own precision (no f64 arithmetic on an f32 device).
//!
//! Scalers are folded into the stage-1 matrix and the RBF inputs, the RBF width into the
//! centres, the variance eigenvalues into the eigenvectors, and each centre carries −2μ and
//! ‖μ‖² so that the squared distance costs one multiply-add per input.

use super::rbf::PreparedCentre;
use crate::layout::{MAX_OUTPUTS, MAX_POLY, MAX_STAGE1, MAX_Z, VAR_RANK};
use crate::model::{Centre, ModelParams};
use crate::real::Real;

/// The folded form of everything but the centres, computed in the compensator's precision.
pub(super) struct Folded<F> {
    pub(super) a: [[F; MAX_STAGE1]; MAX_OUTPUTS],
    pub(super) b: [[F; MAX_POLY]; MAX_OUTPUTS],
    pub(super) z_gain: [F; MAX_Z],
    pub(super) z_offset: [F; MAX_Z],
    /// 1/(σ√2).
    pub(super) k_sigma: F,
    pub(super) v_scale: [F; VAR_RANK],
    pub(super) band_var: [F; MAX_OUTPUTS],
    pub(super) band_var_growth: [F; MAX_OUTPUTS],
}

fn all_finite<F: Real>(xs: &[F]) -> bool {
    xs.iter().all(|v| v.is_finite())
}

impl<F: Real> Folded<F> {
    pub(super) fn of<G: Real, const K2: usize, const M2: usize>(p: &ModelParams<G, K2, M2>) -> Self {
        let f = |v: G| F::from_real(v);
        let d = &p.dims;
        let (m_out, n_s1, n_poly) = (d.n_outputs(), d.stage1_len(), d.poly_len());
        let mut a = [[F::ZERO; MAX_STAGE1]; MAX_OUTPUTS];
        for (((row, src), &m), &s) in
            a.iter_mut().zip(p.stage1.iter()).zip(p.guess_mean.iter()).zip(p.guess_std.iter()).take(m_out)
        {
            let inv = F::ONE / f(s);
            for (k, (o, &v)) in row.iter_mut().zip(src.iter()).enumerate().take(n_s1) {
                let v = if k == n_s1 - 1 { f(v) - f(m) } else { f(v) };
                *o = v * inv;
            }
        }
        let mut b = [[F::ZERO; MAX_POLY]; MAX_OUTPUTS];
        for (row, src) in b.iter_mut().zip(p.poly.iter()).take(m_out) {
            for (o, &v) in row.iter_mut().zip(src.iter()).take(n_poly) {
                *o = f(v);
            }
        }
        let k_sigma = F::ONE / (f(p.hyper.sigma) * F::SQRT_2);
        let active = d.z_active(p.hyper.feature_set);
        let mut z_gain = [F::ZERO; MAX_Z];
        let mut z_offset = [F::ZERO; MAX_Z];
        for (((g, o), (&m, &s)), &on) in
            z_gain.iter_mut().zip(z_offset.iter_mut()).zip(p.z_mean.iter().zip(p.z_std.iter())).zip(active.iter())
        {
            if on {
                let gain = k_sigma / f(s);
                *g = gain;
                *o = -f(m) * gain;
            }
        }
        let inv_tail = f(p.var_inv_g_tail);
        let mut v_scale = [F::ZERO; VAR_RANK];
        for (o, &ig) in v_scale.iter_mut().zip(p.var_inv_g.iter()) {
            let d = f(ig) - inv_tail;
            *o = if d > F::ZERO { d.sqrt() } else { F::ZERO };
        }
        let mut band_var = [F::ZERO; MAX_OUTPUTS];
        let mut band_var_growth = [F::ZERO; MAX_OUTPUTS];
        for (((o, og), (&s2, &q)), &k) in band_var
            .iter_mut()
            .zip(band_var_growth.iter_mut())
            .zip(p.resid_var.iter().zip(p.resid_var_growth.iter()))
            .zip(p.band_k.iter())
            .take(m_out)
        {
            let k2 = f(k) * f(k);
            *o = k2 * f(s2);
            *og = k2 * f(q);
        }
        Folded { a, b, z_gain, z_offset, k_sigma, v_scale, band_var, band_var_growth }
    }

    pub(super) fn is_finite(&self) -> bool {
        self.a.iter().all(|r| all_finite(r))
            && self.b.iter().all(|r| all_finite(r))
            && all_finite(&self.z_gain)
            && all_finite(&self.z_offset)
            && all_finite(&self.v_scale)
            && all_finite(&self.band_var)
            && all_finite(&self.band_var_growth)
            && self.k_sigma.is_finite()
    }

    pub(super) fn centre<G: Real>(&self, c: &Centre<G>, active: &[bool; MAX_Z], outputs: usize) -> PreparedCentre<F> {
        let mut pc = PreparedCentre::<F>::default();
        let two = F::ONE + F::ONE;
        for ((o, &mu), &on) in pc.m2.iter_mut().zip(c.mu.iter()).zip(active.iter()) {
            if on {
                let m = F::from_real(mu) * self.k_sigma;
                *o = -two * m;
                pc.mu_sq = m.mul_add(m, pc.mu_sq);
            }
        }
        for (o, &w) in pc.w.iter_mut().zip(c.w.iter()).take(outputs) {
            *o = F::from_real(w);
        }
        for ((o, &v), &sc) in pc.v.iter_mut().zip(c.v.iter()).zip(self.v_scale.iter()) {
            *o = F::from_real(v) * sc;
        }
        pc
    }
}
