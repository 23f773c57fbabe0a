//! The per-sample inference (Model-H): polynomial core + RBF residual + band + flags.
//!
//! Loading folds the auditable [`ModelParams`] into a per-sample form once, in the
//! compensator's own precision (no f64 arithmetic on an f32 device): scalers are folded into
//! the stage-1 matrix and the RBF inputs, the RBF width into the centres, the variance
//! eigenvalues into the eigenvectors, and each centre carries −2μ and ‖μ‖² so that the squared
//! distance costs one multiply-add per input. [`Compensator::step`] then does only the work
//! that depends on the sample.
//!
//! [`Compensator::reload`] replaces the model in place and atomically: every folded number is
//! checked before the first one is written, so a refused model leaves the old one serving.

use heapless::Vec;

use crate::direction_latch::LatchBank;
use crate::error::Error;
use crate::flags::Flags;
use crate::layout::{N_ENVELOPE, N_GRATINGS, N_MEMORY, N_OUTPUTS, N_POLY, N_STAGE1, VAR_RANK, Z_DIMS};
use crate::memory::{MemoryBank, MemoryState};
use crate::model::{Centre, ModelParams};
use crate::real::Real;

/// One measured sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sample<F> {
    /// Measured wavelength shifts Δλ1..3 \[pm\].
    pub dl_pm: [F; N_GRATINGS],
    /// Ambient reference temperature T_amb [°C].
    pub t_amb_c: F,
    /// Time on the calibration clock \[s\] (used by feature sets with time and by a band that
    /// grows after calibration).
    pub t_s: F,
}

impl<F: Real> Sample<F> {
    /// Whether the shifts and the ambient temperature are finite: what every model reads (a
    /// model that reads time also needs a finite `t_s`).
    #[inline(always)]
    pub fn inputs_finite(&self) -> bool {
        self.dl_pm.iter().all(|v| v.is_finite()) && self.t_amb_c.is_finite()
    }

    /// The sample in another precision: exact from f32 to f64 (how a host replays what a
    /// device received), rounded to nearest from f64 to f32 (what a device receives).
    ///
    /// ```
    /// use fbg_shared::Sample;
    /// let host = Sample { dl_pm: [0.1f64, 2.0, -3.0], t_amb_c: 20.0, t_s: 60.0 };
    /// let device: Sample<f32> = host.cast();
    /// assert_eq!(device.dl_pm[0], 0.1f32);
    /// assert_eq!(device.cast::<f64>().dl_pm[0], f64::from(0.1f32));
    /// ```
    pub fn cast<G: Real>(&self) -> Sample<G> {
        Sample { dl_pm: self.dl_pm.map(G::from_real), t_amb_c: G::from_real(self.t_amb_c), t_s: G::from_real(self.t_s) }
    }
}

/// One compensated estimate.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Estimate<F> {
    /// T [°C], ε \[µε\], p \[kPa\].
    pub values: [F; N_OUTPUTS],
    /// Half-width of the 95 % band, same units (infinite for non-finite input).
    pub band95: [F; N_OUTPUTS],
    /// Fault flags.
    pub flags: Flags,
}

/// A centre in per-sample form.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct PreparedCentre<F> {
    /// −2μ_j/(σ√2) (0 on unused inputs): ‖z − μ‖² = ‖z‖² + ‖μ‖² + z·(−2μ) in scaled units.
    m2: [F; Z_DIMS],
    /// ‖μ_j/(σ√2)‖².
    mu_sq: F,
    w: [F; N_OUTPUTS],
    /// v_ij · sqrt(1/g_i − 1/g_tail).
    v: [F; VAR_RANK],
}

/// The stream state of a [`Compensator`]: the direction latches and the memory bank's
/// operators. `Copy`, so a stream can be checkpointed and resumed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StreamState<F> {
    latches: LatchBank,
    memory: MemoryState<F>,
}

/// A loaded model with its stream state, ready to compensate samples.
///
/// ```
/// use fbg_shared::{Compensator, FeatureSet, ModelParams, Sample};
/// # let params: ModelParams<f32, 8> =
/// #     fbg_testkit::models::model(8, 1, FeatureSet::HysteresisAware, Default::default());
/// // `params`: a trained model, e.g. `fbg_shared::blob::decode(&bytes)?`.
/// let mut comp = Compensator::<f32, 8>::new(&params)?;
/// let e = comp.step(&Sample { dl_pm: [10.0, -5.0, 2.0], t_amb_c: 21.0, t_s: 60.0 });
/// assert!(e.values.iter().chain(e.band95.iter()).all(|v| v.is_finite()));
/// // A non-finite input is flagged, never a panic.
/// let bad = comp.step(&Sample { dl_pm: [f32::NAN, 0.0, 0.0], t_amb_c: 21.0, t_s: 120.0 });
/// assert!(bad.flags.contains(fbg_shared::Flags::NON_FINITE));
/// comp.reset(); // a new acquisition
/// # Ok::<(), fbg_shared::Error>(())
/// ```
///
/// `K` is the centre capacity; models with fewer centres load too and cost proportionally less.
#[derive(Clone, Debug)]
pub struct Compensator<F, const K: usize> {
    /// Stage-1 rows producing *standardised* guesses.
    a: [[F; N_STAGE1]; N_OUTPUTS],
    b: [[F; N_POLY]; N_OUTPUTS],
    /// Γ (output units per memory-term unit).
    gamma: [[F; N_MEMORY]; N_OUTPUTS],
    /// The memory operators and their state.
    memory: MemoryBank<F>,
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

/// The folded form of everything but the centres, computed in the compensator's precision.
struct Folded<F> {
    a: [[F; N_STAGE1]; N_OUTPUTS],
    b: [[F; N_POLY]; N_OUTPUTS],
    z_gain: [F; Z_DIMS],
    z_offset: [F; Z_DIMS],
    /// 1/(σ√2).
    k_sigma: F,
    v_scale: [F; VAR_RANK],
    band_var: [F; N_OUTPUTS],
    band_var_growth: [F; N_OUTPUTS],
}

fn all_finite<F: Real>(xs: &[F]) -> bool {
    xs.iter().all(|v| v.is_finite())
}

impl<F: Real> Folded<F> {
    fn of<G: Real, const K2: usize>(p: &ModelParams<G, K2>) -> Self {
        let f = |v: G| F::from_real(v);
        let mut a = [[F::ZERO; N_STAGE1]; N_OUTPUTS];
        for (((row, src), &m), &s) in a.iter_mut().zip(p.stage1.iter()).zip(p.guess_mean.iter()).zip(p.guess_std.iter())
        {
            let inv = F::ONE / f(s);
            for (k, (o, &v)) in row.iter_mut().zip(src.iter()).enumerate() {
                let v = if k == N_STAGE1 - 1 { f(v) - f(m) } else { f(v) };
                *o = v * inv;
            }
        }
        let mut b = [[F::ZERO; N_POLY]; N_OUTPUTS];
        for (row, src) in b.iter_mut().zip(p.poly.iter()) {
            for (o, &v) in row.iter_mut().zip(src.iter()) {
                *o = f(v);
            }
        }
        let k_sigma = F::ONE / (f(p.hyper.sigma) * F::SQRT_2);
        let active = p.hyper.feature_set.active();
        let mut z_gain = [F::ZERO; Z_DIMS];
        let mut z_offset = [F::ZERO; Z_DIMS];
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
        let mut band_var = [F::ZERO; N_OUTPUTS];
        let mut band_var_growth = [F::ZERO; N_OUTPUTS];
        for (((o, og), (&s2, &q)), &k) in band_var
            .iter_mut()
            .zip(band_var_growth.iter_mut())
            .zip(p.resid_var.iter().zip(p.resid_var_growth.iter()))
            .zip(p.band_k.iter())
        {
            let k2 = f(k) * f(k);
            *o = k2 * f(s2);
            *og = k2 * f(q);
        }
        Folded { a, b, z_gain, z_offset, k_sigma, v_scale, band_var, band_var_growth }
    }

    fn is_finite(&self) -> bool {
        self.a.iter().all(|r| all_finite(r))
            && self.b.iter().all(|r| all_finite(r))
            && all_finite(&self.z_gain)
            && all_finite(&self.z_offset)
            && all_finite(&self.v_scale)
            && all_finite(&self.band_var)
            && all_finite(&self.band_var_growth)
            && self.k_sigma.is_finite()
    }

    fn centre<G: Real>(&self, c: &Centre<G>, active: &[bool; Z_DIMS]) -> PreparedCentre<F> {
        let mut pc = PreparedCentre::<F>::default();
        let two = F::ONE + F::ONE;
        for ((o, &mu), &on) in pc.m2.iter_mut().zip(c.mu.iter()).zip(active.iter()) {
            if on {
                let m = F::from_real(mu) * self.k_sigma;
                *o = -two * m;
                pc.mu_sq = m.mul_add(m, pc.mu_sq);
            }
        }
        for (o, &w) in pc.w.iter_mut().zip(c.w.iter()) {
            *o = F::from_real(w);
        }
        for ((o, &v), &sc) in pc.v.iter_mut().zip(c.v.iter()).zip(self.v_scale.iter()) {
            *o = F::from_real(v) * sc;
        }
        pc
    }
}

impl<F: Real> PreparedCentre<F> {
    fn is_finite(&self) -> bool {
        all_finite(&self.m2) && self.mu_sq.is_finite() && all_finite(&self.w) && all_finite(&self.v)
    }
}

impl<F: Real, const K: usize> Compensator<F, K> {
    /// A compensator for `params` (any scalar type and capacity), validated and folded. Centres
    /// beyond `K` are an error; so is a model whose folded coefficients overflow this
    /// precision.
    pub fn new<G: Real, const K2: usize>(params: &ModelParams<G, K2>) -> Result<Self, Error> {
        let mut c = Self::unloaded();
        c.reload(params)?;
        Ok(c)
    }

    /// A compensator with no model loaded, usable in a `static` that [`Compensator::reload`]
    /// then fills in place (so a device never builds a compensator-sized value on its stack).
    /// Until a model is loaded it answers every sample with NaN values, an infinite band and no
    /// output fitted.
    pub const fn unloaded() -> Self {
        Compensator {
            a: [[F::ZERO; N_STAGE1]; N_OUTPUTS],
            b: [[F::ZERO; N_POLY]; N_OUTPUTS],
            gamma: [[F::ZERO; N_MEMORY]; N_OUTPUTS],
            memory: MemoryBank::off(),
            z_gain: [F::ZERO; Z_DIMS],
            z_offset: [F::ZERO; Z_DIMS],
            centres: Vec::new(),
            inv_g_tail: F::ZERO,
            band_var: [F::ZERO; N_OUTPUTS],
            band_var_growth: [F::ZERO; N_OUTPUTS],
            t_cal_end_s: F::ZERO,
            band_grows: false,
            env_lo: [F::ZERO; N_ENVELOPE],
            env_hi: [F::ZERO; N_ENVELOPE],
            weak_support: F::ZERO,
            // Never read before a model is loaded (no output is fitted); 0 keeps the value all
            // zero bytes, so a `static` of it lands in `.bss` and costs no flash.
            flagged_band_factor: F::ZERO,
            dead_band: 0,
            uses_time: false,
            uses_latch: false,
            fitted: [false; N_OUTPUTS],
            latches: LatchBank::new(),
        }
    }

    /// Replace the model in place, atomically: `params` is validated and every folded number
    /// checked first; on error the compensator keeps its old model and stream state. On
    /// success the stream state (direction latches) is reset.
    pub fn reload<G: Real, const K2: usize>(&mut self, params: &ModelParams<G, K2>) -> Result<(), Error> {
        params.validate()?;
        if params.centres.len() > K {
            return Err(Error::TooManyCentres { found: params.centres.len(), capacity: K });
        }
        // Folding can overflow even when every stored number is finite (e.g. a tiny guess_std
        // scales stage 1 to infinity in f32): refuse such a model before touching anything.
        let folded = Folded::<F>::of(params);
        let active = params.hyper.feature_set.active();
        let f = |v: G| F::from_real(v);
        let env_ok = params.envelope_lo.iter().chain(params.envelope_hi.iter()).all(|&v| f(v).is_finite());
        let gamma_ok = params.gamma.iter().all(|r| r.iter().all(|&v| f(v).is_finite()));
        // A τ or r that overflows this precision would switch its slot off here but not in the
        // trainer's precision.
        let memory_ok = params.memory.convert::<F>().validate().is_ok();
        if !folded.is_finite()
            || !env_ok
            || !gamma_ok
            || !memory_ok
            || !params.centres.iter().all(|c| folded.centre(c, &active).is_finite())
            || !f(params.t_cal_end_s).is_finite()
        {
            return Err(Error::BadParameter { field: "folded coefficients (overflow in this precision)" });
        }
        // From here nothing can fail.
        self.centres.clear();
        for c in params.centres.iter() {
            // Capacity was checked above; a failed push cannot happen.
            let _ = self.centres.push(folded.centre(c, &active));
        }
        let h = &params.hyper;
        self.a = folded.a;
        self.b = folded.b;
        for (o, r) in self.gamma.iter_mut().zip(params.gamma.iter()) {
            for (o, &v) in o.iter_mut().zip(r.iter()) {
                *o = f(v);
            }
        }
        self.memory = MemoryBank::new(&params.memory);
        self.z_gain = folded.z_gain;
        self.z_offset = folded.z_offset;
        self.inv_g_tail = f(params.var_inv_g_tail);
        self.band_var = folded.band_var;
        self.band_var_growth = folded.band_var_growth;
        self.t_cal_end_s = f(params.t_cal_end_s);
        self.band_grows = params.resid_var_growth.iter().any(|&q| q > G::ZERO);
        for (o, &v) in self.env_lo.iter_mut().zip(params.envelope_lo.iter()) {
            *o = f(v);
        }
        for (o, &v) in self.env_hi.iter_mut().zip(params.envelope_hi.iter()) {
            *o = f(v);
        }
        self.weak_support = f(h.weak_support);
        self.flagged_band_factor = f(h.flagged_band_factor);
        self.dead_band = crate::direction_latch::ticks(h.dead_band_pm);
        self.uses_time = h.feature_set.uses_time();
        self.uses_latch = h.feature_set.uses_latch();
        self.fitted = params.fitted;
        self.latches.reset();
        self.memory.reset();
        Ok(())
    }

    /// Whether max_j ψ_j < weak_support, decided from ‖ψ‖² when it can be: ψ_j ≥ 0, so
    /// max ψ ≤ ‖ψ‖ (weak when ‖ψ‖² < w²) and max ψ ≥ ‖ψ‖/√n (not weak when ‖ψ‖² ≥ n·w², with
    /// a margin for the rounding of the sum); otherwise ψ is computed again, identically, for
    /// its maximum (rare: samples near the weak-support boundary).
    #[inline(always)]
    fn weak(&self, z: &[F; Z_DIMS], z_sq: F, psi_sq: F) -> bool {
        let w = self.weak_support;
        let w2 = w * w;
        if psi_sq < w2 {
            return true;
        }
        let n = F::from_f64(self.centres.len() as f64);
        let margin = F::ONE + F::from_f64(1e-4);
        if psi_sq > n * w2 * margin {
            return false;
        }
        // All inputs: an unused one adds an exact zero (0 · 0), so ψ comes out identical.
        psi_max_pass::<F, K, true, true>(&self.centres, z, z_sq) < w
    }

    /// Number of RBF centres in use.
    pub fn n_centres(&self) -> usize {
        self.centres.len()
    }

    /// Forget the stream state (direction latches, memory operators) before a new acquisition.
    pub fn reset(&mut self) {
        self.latches.reset();
        self.memory.reset();
    }

    /// The stream state (direction latches and memory operators): with
    /// [`Compensator::set_stream_state`], a stream can be checkpointed and resumed, e.g. to
    /// evaluate stretches of a long record in parallel with exactly the answers of one
    /// sequential pass.
    pub fn stream_state(&self) -> StreamState<F> {
        StreamState { latches: self.latches, memory: self.memory.state() }
    }

    /// Resume from a state taken by [`Compensator::stream_state`] (of a compensator for which
    /// [`Compensator::same_stream`] holds, at the sample before the one to be compensated next).
    pub fn set_stream_state(&mut self, state: StreamState<F>) {
        self.latches = state.latches;
        self.memory.set_state(state.memory);
    }

    /// Whether `other` moves its stream state exactly as this one does on every sample (same
    /// dead band, same memory operators, same rule for which samples are finite), so that a
    /// state taken from one can resume the other.
    pub fn same_stream<const K2: usize>(&self, other: &Compensator<F, K2>) -> bool {
        self.dead_band == other.dead_band
            && self.memory.same_spec(&other.memory)
            && self.needs_time() == other.needs_time()
    }

    /// Whether the model reads the time input (feature set, growing band or memory terms).
    #[inline(always)]
    fn needs_time(&self) -> bool {
        self.uses_time || self.band_grows || self.memory.is_active()
    }

    /// Whether the model has memory terms (Γm in the core).
    pub fn has_memory(&self) -> bool {
        self.memory.is_active()
    }

    /// Current direction-latch values (−1, 0, +1 per grating).
    pub fn latch_values(&self) -> [F; N_GRATINGS] {
        self.latches.values()
    }

    /// Advance the stream state by one accepted sample and add the memory terms Γm to `y`;
    /// returns the latch values.
    #[inline(always)]
    fn advance_state(&mut self, s: &Sample<F>, y: &mut [F; N_OUTPUTS]) -> [F; N_GRATINGS] {
        let latch: [F; N_GRATINGS] = self.latches.update(&s.dl_pm, self.dead_band);
        if self.memory.is_active() {
            self.memory.accumulate(&s.dl_pm, s.t_amb_c, s.t_s, &self.gamma, y);
        }
        latch
    }

    /// Advance the stream state and compute the core's estimate Bφ + Γm.
    #[inline(always)]
    fn advance_with_core(&mut self, s: &Sample<F>) -> ([F; N_GRATINGS], [F; N_OUTPUTS]) {
        let mut y = self.core(s);
        let latch = self.advance_state(s, &mut y);
        (latch, y)
    }

    /// Advance the stream state (direction latches, memory operators) by one sample without
    /// compensating it: what `step` does to the state, for samples whose estimate is not
    /// needed. Non-finite samples leave the state as `step` would.
    #[inline]
    pub fn advance(&mut self, s: &Sample<F>) {
        if self.accepts(s) {
            let _: [F; N_GRATINGS] = self.latches.update(&s.dl_pm, self.dead_band);
            self.memory.advance(&s.dl_pm, s.t_amb_c, s.t_s);
        }
    }

    /// Whether a sample is finite where this model reads it (Δλ, T_amb, and t when the
    /// feature set, the band or the memory terms use time); other samples are answered as
    /// non-finite and leave the stream state untouched.
    #[inline(always)]
    fn accepts(&self, s: &Sample<F>) -> bool {
        s.inputs_finite() && (!self.needs_time() || s.t_s.is_finite())
    }

    /// The polynomial core Bφ (Model-P's answer when the model has no memory terms):
    /// stage-1 standardised first guesses, then paper Eq. 3.
    #[inline(always)]
    fn core(&self, s: &Sample<F>) -> [F; N_OUTPUTS] {
        let [d1, d2, d3] = s.dl_pm;
        let mut g = [F::ZERO; N_OUTPUTS];
        for (gi, row) in g.iter_mut().zip(self.a.iter()) {
            let [a0, a1, a2, a3, a4] = *row;
            *gi = d1.mul_add(a0, d2.mul_add(a1, d3.mul_add(a2, s.t_amb_c.mul_add(a3, a4))));
        }
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
        y
    }

    /// The scaled RBF inputs z (unused inputs 0) and ‖z‖².
    #[inline(always)]
    fn rbf_inputs(&self, s: &Sample<F>, latch: [F; N_GRATINGS]) -> ([F; Z_DIMS], F) {
        let [d1, d2, d3] = s.dl_pm;
        let t_in = if self.uses_time { s.t_s } else { F::ZERO };
        let (l1, l2, l3) = if self.uses_latch { (latch[0], latch[1], latch[2]) } else { (F::ZERO, F::ZERO, F::ZERO) };
        let x_z = [d1, d2, d3, s.t_amb_c, t_in, l1, l2, l3];
        let mut z = [F::ZERO; Z_DIMS];
        let mut z_sq = F::ZERO;
        for (((zi, &x), &gn), &of) in z.iter_mut().zip(x_z.iter()).zip(self.z_gain.iter()).zip(self.z_offset.iter()) {
            *zi = x.mul_add(gn, of);
            z_sq = zi.mul_add(*zi, z_sq);
        }
        (z, z_sq)
    }

    /// What a trainer needs of one sample to build the ridge system (paper Eq. 7): the
    /// core's estimate Bφ + Γm and every RBF activation ψ_j (into `psi`, one per centre),
    /// computed by the same code as [`Compensator::step`] and moving the stream state as it
    /// does, but without the residual, band or flags. `None` for a sample `step` would answer
    /// as non-finite (`psi` untouched).
    #[inline]
    pub fn core_and_activations(&mut self, s: &Sample<F>, psi: &mut [F]) -> Option<[F; N_OUTPUTS]> {
        if !self.accepts(s) {
            return None;
        }
        let (latch, y) = self.advance_with_core(s);
        let (z, z_sq) = self.rbf_inputs(s, latch);
        for (o, c) in psi.iter_mut().zip(self.centres.iter()) {
            // All inputs: an unused one adds an exact zero, so ψ is the one `step` computes.
            *o = psi_of::<F, true, true>(c, &z, z_sq);
        }
        Some(y)
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
        if !self.accepts(s) {
            return Estimate {
                values: [F::NAN; N_OUTPUTS],
                band95: [F::INFINITY; N_OUTPUTS],
                flags: Flags::NON_FINITE,
            };
        }
        let (latch, y) = self.advance_with_core(s);
        let [d1, d2, d3] = s.dl_pm;
        let x_env = [d1, d2, d3, s.t_amb_c];

        let mut flags = Flags::OK;
        for ((&x, &lo), &hi) in x_env.iter().zip(self.env_lo.iter()).zip(self.env_hi.iter()) {
            if x < lo || x > hi {
                flags.insert(Flags::OUT_OF_ENVELOPE);
            }
        }

        // RBF residual (paper Eq. 5-6) with the variance projections in the same pass.
        let (z, z_sq) = self.rbf_inputs(s, latch);
        // The centre loop, specialised on the inputs the feature set uses (unused ones have
        // zero weight in every centre, so skipping them is exact).
        let acc = if !self.uses_time && self.uses_latch {
            centre_pass::<F, K, false, true, true>(&self.centres, &z, z_sq, y, &mut sink)
        } else {
            centre_pass::<F, K, true, true, false>(&self.centres, &z, z_sq, y, &mut sink)
        };
        let (y2, proj, psi_sq) = acc;
        let mut y = y2;
        if !self.centres.is_empty() && self.weak(&z, z_sq, psi_sq) {
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

#[inline(always)]
#[allow(clippy::type_complexity)]
fn centre_pass<F: Real, const K: usize, const TIME: bool, const LATCH: bool, const PAIRS: bool>(
    centres: &Vec<PreparedCentre<F>, K>,
    z: &[F; Z_DIMS],
    z_sq: F,
    mut y: [F; N_OUTPUTS],
    sink: &mut impl FnMut(usize, F),
) -> ([F; N_OUTPUTS], [F; VAR_RANK], F) {
    let mut proj = [F::ZERO; VAR_RANK];
    let mut psi_sq = F::ZERO;
    let mut one =
        |j: usize, c: &PreparedCentre<F>, y: &mut [F; N_OUTPUTS], proj: &mut [F; VAR_RANK], psi_sq: &mut F| {
            let psi = psi_of::<F, TIME, LATCH>(c, z, z_sq);
            sink(j, psi);
            for (yi, &w) in y.iter_mut().zip(c.w.iter()) {
                *yi = w.mul_add(psi, *yi);
            }
            for (pi, &v) in proj.iter_mut().zip(c.v.iter()) {
                *pi = v.mul_add(psi, *pi);
            }
            *psi_sq = psi.mul_add(psi, *psi_sq);
        };
    // Two centres per iteration (same order of operations): half the loop overhead, for the
    // default feature set only (the unrolled loop costs flash on the device).
    if !PAIRS {
        for (j, c) in centres.iter().enumerate() {
            one(j, c, &mut y, &mut proj, &mut psi_sq);
        }
        return (y, proj, psi_sq);
    }
    let pairs = centres.chunks_exact(2);
    let rest = pairs.remainder();
    let mut j = 0;
    for pair in pairs {
        if let [a, b] = pair {
            one(j, a, &mut y, &mut proj, &mut psi_sq);
            one(j + 1, b, &mut y, &mut proj, &mut psi_sq);
        }
        j += 2;
    }
    for c in rest {
        one(j, c, &mut y, &mut proj, &mut psi_sq);
        j += 1;
    }
    (y, proj, psi_sq)
}

#[inline(always)]
fn psi_of<F: Real, const TIME: bool, const LATCH: bool>(c: &PreparedCentre<F>, z: &[F; Z_DIMS], z_sq: F) -> F {
    let mut d2 = z_sq + c.mu_sq;
    for (i, (&zi, &mi)) in z.iter().zip(c.m2.iter()).enumerate() {
        let used = if i == crate::layout::Z_TIME {
            TIME
        } else if i >= crate::layout::Z_LATCH {
            LATCH
        } else {
            true
        };
        if used {
            d2 = zi.mul_add(mi, d2);
        }
    }
    d2.exp_neg()
}

#[inline(never)]
fn psi_max_pass<F: Real, const K: usize, const TIME: bool, const LATCH: bool>(
    centres: &Vec<PreparedCentre<F>, K>,
    z: &[F; Z_DIMS],
    z_sq: F,
) -> F {
    let mut m = F::ZERO;
    for c in centres.iter() {
        m = m.max(psi_of::<F, TIME, LATCH>(c, z, z_sq));
    }
    m
}
