//! Loading a model into a [`PreparedModel`]: validated, folded, checked in this precision, and
//! only then written, so that a refused model leaves the old one serving.

use super::fold::Folded;
use super::gate::Gate;
use super::prepared::PreparedModel;
use super::swing::Pace;
use crate::blob::SplitBlob;
use crate::error::Error;
use crate::model::{Centre, ModelParams};
use crate::real::Real;

impl<F: Real, const K: usize> PreparedModel<F, K> {
    /// The model of `params` (any scalar type and capacity), validated and folded. Centres
    /// beyond `K` are an error; so is a model whose folded coefficients overflow this
    /// precision.
    pub fn new<G: Real, const K2: usize>(params: &ModelParams<G, K2>) -> Result<Self, Error> {
        let mut m = Self::unloaded();
        m.reload(params)?;
        Ok(m)
    }

    /// Replace the model in place, atomically: `params` is validated and every folded number
    /// checked first; on error the old model stays.
    pub fn reload<G: Real, const K2: usize>(&mut self, params: &ModelParams<G, K2>) -> Result<(), Error> {
        params.validate()?;
        self.reload_parts(params, params.centres.len(), || params.centres.iter().copied(), gamma_of(params))
    }

    /// Decode a blob ([`crate::blob::decode_split`]: everything but the centres and Γ into a
    /// parameter slot without either on this frame) and load it, the centres read from `bytes`
    /// twice, one at a time (once to check every folded number, once to write them), and Γ
    /// from `bytes` likewise: what a device does to load a model, with about a fifth of a whole
    /// [`ModelParams`] on its stack. The same folding, checks and atomicity as
    /// [`PreparedModel::reload`].
    pub fn reload_blob(&mut self, bytes: &[u8]) -> Result<(), Error> {
        let mut head = ModelParams::<f32, 0, 0>::empty();
        let SplitBlob { centres, gamma } = crate::blob::decode_split::<K, 0>(bytes, &mut head)?;
        self.reload_parts(&head, centres.len(), || centres.clone(), |o, k| gamma.get(o, k))
    }

    /// The shared part of the reloads: `n` centres, `centres()` yields them (each time anew),
    /// `gamma(o, k)` is Γ's entry for output `o` and memory term `k`.
    #[inline(always)]
    fn reload_parts<G: Real, const K2: usize, const M2: usize, I: Iterator<Item = Centre<G>>>(
        &mut self,
        params: &ModelParams<G, K2, M2>,
        n: usize,
        centres: impl Fn() -> I,
        gamma: impl Fn(usize, usize) -> G,
    ) -> Result<(), Error> {
        let folded = Self::checked(params, n, &centres, &gamma)?;
        // From here nothing can fail.
        self.write(params, &folded, centres(), &gamma);
        Ok(())
    }

    /// `params` folded in this precision, or why it cannot serve: more than `K` centres, or a
    /// folded number (centres included) that overflows.
    // Inlined, as the two halves below: one frame for a load, with one folded copy (a device
    // loads with little stack to spare).
    #[inline(always)]
    fn checked<G: Real, const K2: usize, const M2: usize, I: Iterator<Item = Centre<G>>>(
        params: &ModelParams<G, K2, M2>,
        n: usize,
        centres: &impl Fn() -> I,
        gamma: &impl Fn(usize, usize) -> G,
    ) -> Result<Folded<F>, Error> {
        if n > K {
            return Err(Error::TooManyCentres { found: n, capacity: K });
        }
        // Folding can overflow even when every stored number is finite (e.g. a tiny guess_std
        // scales stage 1 to infinity in f32): refuse such a model before touching anything.
        let folded = Folded::<F>::of(params);
        let dims = params.dims;
        let active = dims.z_active(params.hyper.feature_set);
        let f = |v: G| F::from_real(v);
        let env_ok = params.envelope_lo.iter().chain(params.envelope_hi.iter()).all(|&v| f(v).is_finite());
        let (m_out, n_mem) = (dims.n_outputs(), dims.memory_len());
        let gamma_ok = (0..m_out).all(|o| (0..n_mem).all(|k| f(gamma(o, k)).is_finite()));
        // A τ or r that overflows this precision would switch its slot off here but not in the
        // trainer's precision.
        let memory_ok = params.memory.convert::<F>().validate(&dims).is_ok();
        if !folded.is_finite()
            || !env_ok
            || !gamma_ok
            || !memory_ok
            || !centres().all(|c| folded.centre(&c, &active, dims.n_outputs()).is_finite())
            || !f(params.t_cal_end_s).is_finite()
            || !F::from_real(params.field.lead_max_s).is_finite()
        {
            return Err(Error::BadParameter { field: "folded coefficients (overflow in this precision)" });
        }
        Ok(folded)
    }

    /// Write a model [`PreparedModel::checked`] accepted (its `centres` at most `K`).
    #[inline(always)]
    fn write<G: Real, const K2: usize, const M2: usize>(
        &mut self,
        params: &ModelParams<G, K2, M2>,
        folded: &Folded<F>,
        centres: impl Iterator<Item = Centre<G>>,
        gamma: &impl Fn(usize, usize) -> G,
    ) {
        let dims = params.dims;
        let m_out = dims.n_outputs();
        let active = dims.z_active(params.hyper.feature_set);
        self.centres.clear();
        for c in centres {
            // Capacity was checked; a failed push cannot happen.
            let _ = self.centres.push(folded.centre(&c, &active, m_out));
        }
        let f = |v: G| F::from_real(v);
        self.dims = dims;
        self.gratings = dims.gratings() as u8;
        self.ambient = dims.ambient();
        self.outputs = m_out as u8;
        self.n_z = dims.z_len() as u8;
        self.z_groups = dims.z_len().div_ceil(4) as u8;
        self.a = folded.a;
        for (mut row, src) in self.b.row_iter_mut().zip(folded.b.iter()) {
            for (e, &v) in row.iter_mut().zip(src.iter()) {
                *e = v;
            }
        }
        let n_mem = dims.memory_len();
        for (k, col) in self.gamma.iter_mut().enumerate() {
            for (i, o) in col.iter_mut().enumerate() {
                *o = if i < m_out && k < n_mem { f(gamma(i, k)) } else { F::ZERO };
            }
        }
        self.memory = crate::memory::MemoryOperators::new(&params.memory, &dims);
        self.z_gain = folded.z_gain;
        self.z_offset = folded.z_offset;
        self.inv_g_tail = f(params.var_inv_g_tail);
        self.band_var = folded.band_var;
        self.band_var_growth = folded.band_var_growth;
        self.t_cal_end_s = f(params.t_cal_end_s);
        self.band_grows = params.resid_var_growth.iter().any(|&q| q > G::ZERO);
        self.cal_end_unix_s = params.field.cal_end_unix_s;
        self.lead_max_s = F::from_real(params.field.lead_max_s);
        self.write_bounds(params);
        let h = &params.hyper;
        self.weak_support = f(h.weak_support);
        self.flagged_band_factor = f(h.flagged_band_factor);
        self.dead_band = crate::direction_latch::ticks(h.dead_band_pm);
        self.uses_time = h.feature_set.uses_time();
        self.uses_latch = h.feature_set.uses_latch();
        for (k, (o, &v)) in self.fitted.iter_mut().zip(params.fitted.iter()).enumerate() {
            *o = k < m_out && v;
        }
        self.write_trust(params);
    }

    /// The gate, the fade and the band faded to ([`crate::trust`]). Only a model with memory
    /// terms and a trust spec (the trainer's Model-H) has them: the direction latches alone
    /// hold a bounded state that the next reversal renews. An output without a fallback band
    /// fades to its own.
    #[inline(always)]
    fn write_trust<G: Real, const K2: usize, const M2: usize>(&mut self, params: &ModelParams<G, K2, M2>) {
        let tr = &params.trust;
        let guarded = self.memory.is_active() && tr.rate_max.iter().any(|&r| r > G::ZERO);
        self.gate =
            if guarded { Gate::new(&self.env_lo, &self.env_hi, params.dims.envelope_len(), tr) } else { Gate::off() };
        self.pace = if guarded { Pace::new(tr, params.dims.envelope_len()) } else { Pace::off() };
        let on = self.memory.is_active();
        for (o, &q) in self.quiet_max_s.iter_mut().zip(tr.quiet_max_s.iter()) {
            *o = if on { F::from_real(q) } else { F::ZERO };
        }
        let fallback = self.fallback_var.iter_mut().zip(self.fallback_var_growth.iter_mut());
        let own = self.band_var.iter().zip(self.band_var_growth.iter());
        let given = tr.fallback_var.iter().zip(tr.fallback_var_growth.iter());
        for ((fb, (&bv, &bg)), (&v, &g)) in fallback.zip(own).zip(given) {
            let (v, g) = (F::from_real(v), F::from_real(g));
            // No fallback band given (0, or NaN): the output fades to its own.
            let given = v > F::ZERO;
            *fb.0 = if given { v } else { bv };
            *fb.1 = if given { g } else { bg };
        }
    }

    /// The envelope and each output's plausible range and band limit (±∞ and ∞ for an output
    /// the model does not have or did not fit).
    #[inline(always)]
    fn write_bounds<G: Real, const K2: usize, const M2: usize>(&mut self, params: &ModelParams<G, K2, M2>) {
        let n_env = params.dims.envelope_len();
        let m_out = params.dims.n_outputs();
        for (k, (o, &v)) in self.env_lo.iter_mut().zip(params.envelope_lo.iter()).enumerate() {
            *o = if k < n_env { F::from_real(v) } else { F::ZERO };
        }
        for (k, (o, &v)) in self.env_hi.iter_mut().zip(params.envelope_hi.iter()).enumerate() {
            *o = if k < n_env { F::from_real(v) } else { F::ZERO };
        }
        for (o, ((lo, hi), lim)) in
            self.out_lo.iter_mut().zip(self.out_hi.iter_mut()).zip(self.band_lim.iter_mut()).enumerate()
        {
            let (l, h, b) = if o < m_out && params.fitted.get(o).copied().unwrap_or(false) {
                params.field.plausible(o)
            } else {
                (f32::NEG_INFINITY, f32::INFINITY, f32::INFINITY)
            };
            (*lo, *hi, *lim) = (F::from_real(l), F::from_real(h), F::from_real(b));
        }
    }
}

/// Γ's entries of a parameter set that holds them (0 beyond its rows and columns).
fn gamma_of<G: Real, const K2: usize>(params: &ModelParams<G, K2>) -> impl Fn(usize, usize) -> G + '_ {
    |o, k| params.gamma.get(o).and_then(|r| r.get(k)).copied().unwrap_or(G::ZERO)
}
