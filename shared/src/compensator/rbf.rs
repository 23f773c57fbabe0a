//! The RBF layer in per-sample form: the folded centres and the passes over them.
//!
//! Loops over arrays, not nalgebra vectors: the distance runs over the used input groups only,
//! which nalgebra's iterators and `dot` do slower on the device (docs/DESIGN.md §7.1).

use heapless::Vec;

use crate::layout::{MAX_OUTPUTS, MAX_Z, VAR_RANK};
use crate::real::Real;

/// RBF inputs in per-sample form: [`MAX_Z`] rounded up to whole groups of four, so that the
/// distance runs four inputs at a time (the padding is zero in both z and μ: exact).
pub(super) const ZP: usize = MAX_Z.div_ceil(4) * 4;

/// A centre in per-sample form.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct PreparedCentre<F> {
    /// −2μ_j/(σ√2) (0 on unused inputs): ‖z − μ‖² = ‖z‖² + ‖μ‖² + z·(−2μ) in scaled units.
    pub(super) m2: [F; ZP],
    /// ‖μ_j/(σ√2)‖².
    pub(super) mu_sq: F,
    pub(super) w: [F; MAX_OUTPUTS],
    /// v_ij · sqrt(1/g_i − 1/g_tail).
    pub(super) v: [F; VAR_RANK],
}

impl<F: Real> PreparedCentre<F> {
    pub(super) fn is_finite(&self) -> bool {
        let all = |xs: &[F]| xs.iter().all(|v| v.is_finite());
        all(&self.m2) && self.mu_sq.is_finite() && all(&self.w) && all(&self.v)
    }
}

/// What one pass over the centres gives: y + Wψ, the variance projections and ‖ψ‖².
pub(super) type CentreSums<F> = ([F; MAX_OUTPUTS], [F; VAR_RANK], F);

// Out of line: one copy per variant serves every shape of the step (it does not depend on
// the dims), with the per-centre work inlined in it.
#[inline(never)]
pub(super) fn centre_pass<F: Real, const K: usize>(
    centres: &Vec<PreparedCentre<F>, K>,
    z: &[F],
    z_sq: F,
    groups: usize,
    mut y: [F; MAX_OUTPUTS],
    sink: &mut impl FnMut(usize, F),
) -> CentreSums<F> {
    let mut proj = [F::ZERO; VAR_RANK];
    let mut psi_sq = F::ZERO;
    // Inlined into the loop below (as a closure the compiler kept it out of line: a call per
    // centre).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn one<F: Real>(
        j: usize,
        c: &PreparedCentre<F>,
        z: &[F],
        z_sq: F,
        groups: usize,
        sink: &mut impl FnMut(usize, F),
        y: &mut [F; MAX_OUTPUTS],
        proj: &mut [F; VAR_RANK],
        psi_sq: &mut F,
    ) {
        let psi = psi_of::<F>(c, z, z_sq, groups);
        sink(j, psi);
        for (yi, &w) in y.iter_mut().zip(c.w.iter()) {
            *yi = w.mul_add(psi, *yi);
        }
        for (pi, &v) in proj.iter_mut().zip(c.v.iter()) {
            *pi = v.mul_add(psi, *pi);
        }
        *psi_sq = psi.mul_add(psi, *psi_sq);
    }
    for (j, c) in centres.iter().enumerate() {
        one(j, c, z, z_sq, groups, sink, &mut y, &mut proj, &mut psi_sq);
    }
    (y, proj, psi_sq)
}

/// Samples a batch's RBF pass runs side by side ([`super::PreparedModel::step_batch`]).
pub(super) const LANES: usize = 8;

/// The RBF pass's inputs and sums for [`LANES`] samples, one lane per sample (each quantity an
/// array over the lanes, so that the pass over a centre runs the lanes in step).
#[derive(Clone, Copy)]
pub(super) struct Lanes<F> {
    z: [[F; LANES]; ZP],
    z_sq: [F; LANES],
    y: [[F; LANES]; MAX_OUTPUTS],
    proj: [[F; LANES]; VAR_RANK],
    psi_sq: [F; LANES],
    psi_max: [F; LANES],
}

impl<F: Real> Lanes<F> {
    /// Every lane zero.
    #[inline(always)]
    pub(super) fn new() -> Self {
        Lanes {
            z: [[F::ZERO; LANES]; ZP],
            z_sq: [F::ZERO; LANES],
            y: [[F::ZERO; LANES]; MAX_OUTPUTS],
            proj: [[F::ZERO; LANES]; VAR_RANK],
            psi_sq: [F::ZERO; LANES],
            psi_max: [F::ZERO; LANES],
        }
    }

    /// Lane `lane`'s inputs: z, ‖z‖² and the sums' starting y (its projections and ‖ψ‖² start
    /// at 0, as in [`centre_pass`]).
    #[inline(always)]
    pub(super) fn put(&mut self, lane: usize, z: &[F; ZP], z_sq: F, y: &[F; MAX_OUTPUTS]) {
        for (col, &v) in self.z.iter_mut().zip(z.iter()) {
            if let Some(o) = col.get_mut(lane) {
                *o = v;
            }
        }
        if let Some(o) = self.z_sq.get_mut(lane) {
            *o = z_sq;
        }
        for (col, &v) in self.y.iter_mut().zip(y.iter()) {
            if let Some(o) = col.get_mut(lane) {
                *o = v;
            }
        }
    }

    /// Lane `lane`: z, ‖z‖², and what [`centre_pass`] returns (y + Wψ, the projections, ‖ψ‖²).
    #[inline(always)]
    pub(super) fn get(&self, lane: usize) -> ([F; ZP], F, [F; MAX_OUTPUTS], [F; VAR_RANK], F) {
        let at = |col: &[F; LANES]| col.get(lane).copied().unwrap_or(F::ZERO);
        (
            self.z.each_ref().map(at),
            at(&self.z_sq),
            self.y.each_ref().map(at),
            self.proj.each_ref().map(at),
            at(&self.psi_sq),
        )
    }

    /// Lane `lane`'s max_j ψ_j (from 0, centre after centre): what the weak-support test
    /// would otherwise compute again.
    #[inline(always)]
    pub(super) fn psi_max(&self, lane: usize) -> F {
        self.psi_max.get(lane).copied().unwrap_or(F::ZERO)
    }
}

/// [`centre_pass`] over the lanes: per lane, the same operations in the same order (centre
/// after centre; within a centre the distance over the inputs in order, ψ, then y, the
/// projections and ‖ψ‖²), so each lane's sums are bit for bit those of `centre_pass` on its
/// sample. The lanes are independent, which lets the compiler run them as vectors.
#[inline(always)]
pub(super) fn centre_pass_lanes<F: Real, const K: usize>(
    centres: &Vec<PreparedCentre<F>, K>,
    l: &mut Lanes<F>,
    groups: usize,
) {
    for c in centres.iter() {
        let mut psi = l.z_sq;
        for d in psi.iter_mut() {
            *d += c.mu_sq;
        }
        for (zk, &mk) in l.z.iter().zip(c.m2.iter()).take(groups * 4) {
            for (d, &zv) in psi.iter_mut().zip(zk.iter()) {
                *d = zv.mul_add(mk, *d);
            }
        }
        for p in psi.iter_mut() {
            *p = p.exp_neg();
        }
        for (yo, &w) in l.y.iter_mut().zip(c.w.iter()) {
            for (v, &p) in yo.iter_mut().zip(psi.iter()) {
                *v = w.mul_add(p, *v);
            }
        }
        for (po, &v) in l.proj.iter_mut().zip(c.v.iter()) {
            for (x, &p) in po.iter_mut().zip(psi.iter()) {
                *x = v.mul_add(p, *x);
            }
        }
        for (s, &p) in l.psi_sq.iter_mut().zip(psi.iter()) {
            *s = p.mul_add(p, *s);
        }
        for (m, &p) in l.psi_max.iter_mut().zip(psi.iter()) {
            *m = m.max(p);
        }
    }
}

/// ψ_j = exp(−‖z − μ_j‖²/(2σ²)) over the first `groups` groups of four inputs, in input order
/// (an unused or padding input adds an exact 0).
#[inline(always)]
pub(super) fn psi_of<F: Real>(c: &PreparedCentre<F>, z: &[F], z_sq: F, groups: usize) -> F {
    let mut d2 = z_sq + c.mu_sq;
    for (zc, mc) in z.chunks_exact(4).zip(c.m2.chunks_exact(4)).take(groups) {
        if let ([z0, z1, z2, z3], [m0, m1, m2, m3]) = (zc, mc) {
            d2 = z0.mul_add(*m0, d2);
            d2 = z1.mul_add(*m1, d2);
            d2 = z2.mul_add(*m2, d2);
            d2 = z3.mul_add(*m3, d2);
        }
    }
    d2.exp_neg()
}

/// Every ψ_j of a sample into `psi` (one per centre, the rest untouched).
#[inline(always)]
pub(super) fn psi_all<F: Real, const K: usize>(
    centres: &Vec<PreparedCentre<F>, K>,
    z: &[F],
    z_sq: F,
    groups: usize,
    psi: &mut [F],
) {
    for (o, c) in psi.iter_mut().zip(centres.iter()) {
        *o = psi_of::<F>(c, z, z_sq, groups);
    }
}

/// Whether max_j ψ_j < `w` (the weak-support threshold), decided from ‖ψ‖² when it can be:
/// ψ_j ≥ 0, so max ψ ≤ ‖ψ‖ (weak when ‖ψ‖² < w²) and max ψ ≥ ‖ψ‖/√n (not weak when
/// ‖ψ‖² ≥ n·w², with a margin for the rounding of the sum); otherwise ψ is computed again,
/// identically, for its maximum (samples near the weak-support boundary), unless the caller
/// kept it (`psi_max`: the batch path's lanes do; the device's step does not, to spare a
/// comparison per centre on every sample).
#[inline(always)]
pub(super) fn weak<F: Real, const K: usize>(
    centres: &Vec<PreparedCentre<F>, K>,
    z: &[F],
    z_sq: F,
    groups: usize,
    (psi_sq, psi_max): (F, Option<F>),
    w: F,
) -> bool {
    let w2 = w * w;
    if psi_sq < w2 {
        return true;
    }
    let n = F::from_f64(centres.len() as f64);
    let margin = F::ONE + F::from_f64(1e-4);
    if psi_sq > n * w2 * margin {
        return false;
    }
    psi_max.unwrap_or_else(|| psi_max_pass::<F, K>(centres, z, z_sq, groups)) < w
}

#[inline(never)]
fn psi_max_pass<F: Real, const K: usize>(centres: &Vec<PreparedCentre<F>, K>, z: &[F], z_sq: F, groups: usize) -> F {
    let mut m = F::ZERO;
    for c in centres.iter() {
        m = m.max(psi_of::<F>(c, z, z_sq, groups));
    }
    m
}
