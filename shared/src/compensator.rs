//! The per-sample inference (DESIGN §4): polynomial core + RBF residual + band + flags.
//!
//! [`Compensator::new`] folds the auditable [`ModelParams`] into a per-sample form once:
//! scalers are folded into the stage-1 matrix and the RBF inputs, the RBF width into the
//! centres, the variance eigenvalues into the eigenvectors. [`Compensator::step`] then does only
//! the work that depends on the sample.

use heapless::Vec;

use crate::direction_latch::LatchBank;
use crate::error::Error;
use crate::flags::Flags;
use crate::layout::{
    N_ENVELOPE, N_GRATINGS, N_OUTPUTS, N_POLY, N_STAGE1, VAR_RANK, Z_DIMS, Z_LATCH, Z_TIME,
};
use crate::model::ModelParams;
use crate::real::Real;

/// One measured sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sample<F> {
    /// Measured wavelength shifts Δλ1..3 [pm].
    pub dl_pm: [F; N_GRATINGS],
    /// Ambient reference temperature T_amb [°C].
    pub t_amb_c: F,
    /// Time since the start of the stream [s] (used only by feature sets with time).
    pub t_s: F,
}

/// One compensated estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate<F> {
    /// T [°C], ε [µε], p [kPa].
    pub values: [F; N_OUTPUTS],
    /// Half-width of the 95 % band, same units (infinite for non-finite input).
    pub band95: [F; N_OUTPUTS],
    /// Fault flags.
    pub flags: Flags,
}

/// A centre in per-sample form.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct PreparedCentre<F> {
    /// μ_j / (σ√2): the squared distance to scaled z is the exponent directly.
    mu: [F; Z_DIMS],
    w: [F; N_OUTPUTS],
    /// v_ij · sqrt(1/g_i − 1/g_tail).
    v: [F; VAR_RANK],
}

/// A loaded model with its stream state, ready to compensate samples.
///
/// `K` is the centre capacity; models with fewer centres load too and cost proportionally less.
#[derive(Clone, Debug)]
pub struct Compensator<F, const K: usize> {
    /// Stage-1 rows producing *standardised* guesses.
    a: [[F; N_STAGE1]; N_OUTPUTS],
    b: [[F; N_POLY]; N_OUTPUTS],
    /// z_scaled = x · z_gain + z_offset (gain 0 on unused dimensions).
    z_gain: [F; Z_DIMS],
    z_offset: [F; Z_DIMS],
    centres: Vec<PreparedCentre<F>, K>,
    inv_g_tail: F,
    /// k² · s² per output at the end of calibration.
    band_var: [F; N_OUTPUTS],
    /// k² · ds²/dt per output [unit²/s].
    band_var_growth: [F; N_OUTPUTS],
    t_cal_end_s: F,
    /// Whether the band grows with time (the time input is then required).
    band_grows: bool,
    env_lo: [F; N_ENVELOPE],
    env_hi: [F; N_ENVELOPE],
    weak_support: F,
    flagged_band_factor: F,
    /// Latch dead band in ticks of 1/1024 pm.
    dead_band: i32,
    uses_time: bool,
    uses_latch: bool,
    fitted: [bool; N_OUTPUTS],
    latches: LatchBank,
}

impl<F: Real, const K: usize> Compensator<F, K> {
    /// Validate `params` and fold them into per-sample form. Any scalar type and capacity of
    /// the params is accepted; centres beyond `K` are an error.
    pub fn new<G: Real, const K2: usize>(params: &ModelParams<G, K2>) -> Result<Self, Error> {
        params.validate()?;
        if params.centres.len() > K {
            return Err(Error::TooManyCentres { found: params.centres.len(), capacity: K });
        }
        let f = |v: G| v.to_f64();
        let h = &params.hyper;

        // Stage 1 with the guess standardisation folded in.
        let mut a = [[F::ZERO; N_STAGE1]; N_OUTPUTS];
        for (((row, src), &m), &s) in a
            .iter_mut()
            .zip(params.stage1.iter())
            .zip(params.guess_mean.iter())
            .zip(params.guess_std.iter())
        {
            let inv = 1.0 / f(s);
            for (k, (o, &v)) in row.iter_mut().zip(src.iter()).enumerate() {
                let v = if k == N_STAGE1 - 1 { f(v) - f(m) } else { f(v) };
                *o = F::from_f64(v * inv);
            }
        }
        let mut b = [[F::ZERO; N_POLY]; N_OUTPUTS];
        for (row, src) in b.iter_mut().zip(params.poly.iter()) {
            for (o, &v) in row.iter_mut().zip(src.iter()) {
                *o = F::from_f64(f(v));
            }
        }

        // RBF input scaling with 1/(σ√2) folded in.
        let k_sigma = 1.0 / (f(h.sigma) * core::f64::consts::SQRT_2);
        let active = h.feature_set.active();
        let mut z_gain = [F::ZERO; Z_DIMS];
        let mut z_offset = [F::ZERO; Z_DIMS];
        for (((g, o), (&m, &s)), &on) in z_gain
            .iter_mut()
            .zip(z_offset.iter_mut())
            .zip(params.z_mean.iter().zip(params.z_std.iter()))
            .zip(active.iter())
        {
            if on {
                let gain = k_sigma / f(s);
                *g = F::from_f64(gain);
                *o = F::from_f64(-f(m) * gain);
            }
        }

        let inv_tail = f(params.var_inv_g_tail);
        let mut v_scale = [0.0f64; VAR_RANK];
        for (o, &ig) in v_scale.iter_mut().zip(params.var_inv_g.iter()) {
            let d = f(ig) - inv_tail;
            *o = if d > 0.0 { libm::sqrt(d) } else { 0.0 };
        }
        let mut centres = Vec::new();
        for c in params.centres.iter() {
            let mut pc = PreparedCentre::<F>::default();
            for ((o, &mu), &on) in pc.mu.iter_mut().zip(c.mu.iter()).zip(active.iter()) {
                if on {
                    *o = F::from_f64(f(mu) * k_sigma);
                }
            }
            for (o, &w) in pc.w.iter_mut().zip(c.w.iter()) {
                *o = F::from_f64(f(w));
            }
            for ((o, &v), &sc) in pc.v.iter_mut().zip(c.v.iter()).zip(v_scale.iter()) {
                *o = F::from_f64(f(v) * sc);
            }
            // Capacity was checked above; a failed push cannot happen, but never panic.
            centres.push(pc).map_err(|_| Error::TooManyCentres {
                found: params.centres.len(),
                capacity: K,
            })?;
        }

        let mut band_var = [F::ZERO; N_OUTPUTS];
        let mut band_var_growth = [F::ZERO; N_OUTPUTS];
        for (((o, og), (&s2, &q)), &k) in band_var
            .iter_mut()
            .zip(band_var_growth.iter_mut())
            .zip(params.resid_var.iter().zip(params.resid_var_growth.iter()))
            .zip(params.band_k.iter())
        {
            let k2 = f(k) * f(k);
            *o = F::from_f64(k2 * f(s2));
            *og = F::from_f64(k2 * f(q));
        }
        let band_grows = params.resid_var_growth.iter().any(|&q| f(q) > 0.0);
        let conv = |a: &[G; N_ENVELOPE]| {
            let mut out = [F::ZERO; N_ENVELOPE];
            for (o, &v) in out.iter_mut().zip(a.iter()) {
                *o = F::from_f64(f(v));
            }
            out
        };
        // Folding can overflow even when every stored number is finite (e.g. a tiny guess_std
        // scales stage 1 to infinity in f32): refuse such a model rather than answer NaN later.
        let folded_ok = a.iter().flatten().chain(b.iter().flatten()).all(|v| v.is_finite())
            && z_gain.iter().chain(z_offset.iter()).all(|v| v.is_finite())
            && band_var.iter().chain(band_var_growth.iter()).all(|v| v.is_finite())
            && centres.iter().all(|c| {
                c.mu.iter().chain(c.w.iter()).chain(c.v.iter()).all(|v| v.is_finite())
            });
        if !folded_ok {
            return Err(Error::BadParameter { field: "folded coefficients (overflow in this precision)" });
        }
        Ok(Compensator {
            a,
            b,
            z_gain,
            z_offset,
            centres,
            inv_g_tail: F::from_f64(inv_tail),
            band_var,
            band_var_growth,
            t_cal_end_s: F::from_f64(f(params.t_cal_end_s)),
            band_grows,
            env_lo: conv(&params.envelope_lo),
            env_hi: conv(&params.envelope_hi),
            weak_support: F::from_f64(f(h.weak_support)),
            flagged_band_factor: F::from_f64(f(h.flagged_band_factor)),
            dead_band: crate::direction_latch::ticks(f(h.dead_band_pm)),
            uses_time: h.feature_set.uses_time(),
            uses_latch: h.feature_set.uses_latch(),
            fitted: params.fitted,
            latches: LatchBank::new(),
        })
    }

    /// Number of RBF centres in use.
    pub fn n_centres(&self) -> usize {
        self.centres.len()
    }

    /// Forget the stream state (direction latches) before a new acquisition.
    pub fn reset(&mut self) {
        self.latches.reset();
    }

    /// Current direction-latch values (−1, 0, +1 per grating).
    pub fn latch_values(&self) -> [F; N_GRATINGS] {
        self.latches.values()
    }

    /// Compensate one sample. Never panics: non-finite inputs give NaN values, an infinite band
    /// and [`Flags::NON_FINITE`], leaving the stream state untouched.
    #[inline]
    pub fn step(&mut self, s: &Sample<F>) -> Estimate<F> {
        self.step_with(s, |_, _| {})
    }

    /// [`Compensator::step`] that also hands each RBF activation ψ_j to `sink(j, ψ_j)`: the
    /// trainer builds its design matrix Ψ through the very code the device runs. Not called for
    /// non-finite samples.
    #[inline(always)]
    pub fn step_with(&mut self, s: &Sample<F>, mut sink: impl FnMut(usize, F)) -> Estimate<F> {
        let finite = s.dl_pm.iter().all(|v| v.is_finite())
            && s.t_amb_c.is_finite()
            && (!(self.uses_time || self.band_grows) || s.t_s.is_finite());
        if !finite {
            return Estimate {
                values: [F::NAN; N_OUTPUTS],
                band95: [F::INFINITY; N_OUTPUTS],
                flags: Flags::NON_FINITE,
            };
        }
        let latch: [F; N_GRATINGS] = self.latches.update(&s.dl_pm, self.dead_band);
        let [d1, d2, d3] = s.dl_pm;
        let x_env = [d1, d2, d3, s.t_amb_c];

        let mut flags = Flags::OK;
        for ((&x, &lo), &hi) in x_env.iter().zip(self.env_lo.iter()).zip(self.env_hi.iter()) {
            if x < lo || x > hi {
                flags.insert(Flags::OUT_OF_ENVELOPE);
            }
        }

        // Stage 1: standardised first guesses.
        let mut g = [F::ZERO; N_OUTPUTS];
        for (gi, row) in g.iter_mut().zip(self.a.iter()) {
            let [a0, a1, a2, a3, a4] = *row;
            *gi = d1.mul_add(a0, d2.mul_add(a1, d3.mul_add(a2, s.t_amb_c.mul_add(a3, a4))));
        }
        // Stage 2: polynomial core (paper Eq. 3).
        let [t, e, p] = g;
        let phi = [F::ONE, t, e, p, t * t, e * e, p * p, t * e, t * p, e * p];
        let mut y = [F::ZERO; N_OUTPUTS];
        for (yi, row) in y.iter_mut().zip(self.b.iter()) {
            let mut acc = F::ZERO;
            for (&c, &ph) in row.iter().zip(phi.iter()) {
                acc = c.mul_add(ph, acc);
            }
            *yi = acc;
        }

        // RBF residual (paper Eq. 5-6) with the variance projections in the same pass.
        let t_in = if self.uses_time { s.t_s } else { F::ZERO };
        let (l1, l2, l3) =
            if self.uses_latch { (latch[0], latch[1], latch[2]) } else { (F::ZERO, F::ZERO, F::ZERO) };
        let x_z = [d1, d2, d3, s.t_amb_c, t_in, l1, l2, l3];
        let _ = (Z_TIME, Z_LATCH); // layout indices documented in `layout`
        let mut z = [F::ZERO; Z_DIMS];
        for (((zi, &x), &gn), &of) in
            z.iter_mut().zip(x_z.iter()).zip(self.z_gain.iter()).zip(self.z_offset.iter())
        {
            *zi = x.mul_add(gn, of);
        }
        let mut proj = [F::ZERO; VAR_RANK];
        let mut psi_sq = F::ZERO;
        let mut psi_max = F::ZERO;
        for (j, c) in self.centres.iter().enumerate() {
            let psi = rbf_activation(&z, &c.mu);
            sink(j, psi);
            for (yi, &w) in y.iter_mut().zip(c.w.iter()) {
                *yi = w.mul_add(psi, *yi);
            }
            for (pi, &v) in proj.iter_mut().zip(c.v.iter()) {
                *pi = v.mul_add(psi, *pi);
            }
            psi_sq = psi.mul_add(psi, psi_sq);
            psi_max = psi_max.max(psi);
        }
        if !self.centres.is_empty() && psi_max < self.weak_support {
            flags.insert(Flags::WEAK_SUPPORT);
        }

        // Leverage h = ψᵀ(ΨᵀΨ + αI)⁻¹ψ, exact on the kept directions, bounded on the rest.
        let mut lev = psi_sq * self.inv_g_tail;
        for &pi in proj.iter() {
            lev = pi.mul_add(pi, lev);
        }
        // An overflow in this precision (finite inputs far outside anything calibrated) is
        // reported like a non-finite input rather than passed on as a normal estimate.
        if !y.iter().zip(self.fitted.iter()).all(|(v, &fit)| !fit || v.is_finite()) {
            return Estimate {
                values: [F::NAN; N_OUTPUTS],
                band95: [F::INFINITY; N_OUTPUTS],
                flags: flags.union(Flags::NON_FINITE),
            };
        }
        let widen = if flags.is_ok() { F::ONE } else { self.flagged_band_factor };
        let lead = if self.band_grows { (s.t_s - self.t_cal_end_s).max(F::ZERO) } else { F::ZERO };
        let mut band95 = [F::ZERO; N_OUTPUTS];
        for ((bi, &bv), &bg) in band95.iter_mut().zip(self.band_var.iter()).zip(self.band_var_growth.iter()) {
            *bi = (bg.mul_add(lead, bv) * (F::ONE + lev)).sqrt() * widen;
        }
        for ((v, b), &fit) in y.iter_mut().zip(band95.iter_mut()).zip(self.fitted.iter()) {
            if !fit {
                *v = F::NAN;
                *b = F::INFINITY;
            }
        }
        Estimate { values: y, band95, flags }
    }
}

/// Gaussian RBF activation ψ = exp(−‖z − μ‖²) of inputs and a centre already scaled by
/// 1/(σ√2). The trainer builds its design matrix with this same function.
#[inline(always)]
pub fn rbf_activation<F: Real>(z: &[F; Z_DIMS], mu: &[F; Z_DIMS]) -> F {
    let mut d2 = F::ZERO;
    for (&zi, &mi) in z.iter().zip(mu.iter()) {
        let d = zi - mi;
        d2 = d.mul_add(d, d2);
    }
    d2.exp_neg()
}
