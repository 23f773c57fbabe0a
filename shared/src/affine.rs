//! Affine rows over the regressors [Δλ_1..N, T_amb (with ambient), 1]: stage 1 of the core,
//! the envelope check and the drift observer's grating temperature read the same inputs.

use crate::layout::{head, MAX_ENVELOPE, MAX_GRATINGS, MAX_STAGE1};
use crate::real::Real;

/// The regressors [Δλ_1..N, T_amb (with ambient)] of an affine row, and their count.
#[inline(always)]
pub(crate) fn affine_inputs<F: Real>(
    dl_pm: &[F; MAX_GRATINGS],
    gratings: usize,
    ambient: bool,
    t_amb_c: F,
) -> ([F; MAX_ENVELOPE], usize) {
    let mut x = [F::ZERO; MAX_ENVELOPE];
    for (o, &d) in x.iter_mut().zip(dl_pm.iter()) {
        *o = d;
    }
    let n = gratings.min(MAX_GRATINGS);
    if ambient {
        if let Some(o) = x.get_mut(n) {
            *o = t_amb_c;
        }
        (x, n + 1)
    } else {
        (x, n)
    }
}

/// row · [x_0..x_{n-1}, 1], accumulated from the constant backwards (x_{n-1} first), the order
/// of the paper layout's nested multiply-adds.
#[inline(always)]
pub(crate) fn affine<F: Real>(x: &[F; MAX_ENVELOPE], n: usize, row: &[F; MAX_STAGE1]) -> F {
    let mut acc = row.get(n).copied().unwrap_or(F::ZERO);
    for (&xi, &ri) in head(x, n).iter().zip(head(row, n).iter()).rev() {
        acc = xi.mul_add(ri, acc);
    }
    acc
}

const _: () = assert!(MAX_STAGE1 == MAX_ENVELOPE + 1);
