//! The per-sample inference (Model-H): polynomial core + memory terms + RBF residual + band +
//! flags, from a [`PreparedModel`] over a [`StreamState`].

use super::estimate::Estimate;
use super::prepared::PreparedModel;
use super::rbf::{centre_pass, centre_pass_lanes, psi_all, weak, Lanes, LANES, ZP};
use super::sample::Sample;
use super::state::StreamState;
use crate::affine::{affine, affine_inputs};
use crate::flags::Flags;
use crate::layout::{head, Dims, MAX_ENVELOPE, MAX_GRATINGS, MAX_OUTPUTS, MAX_POLY, VAR_RANK};
use crate::real::Real;
use nalgebra::SVector;

/// RBF inputs of the paper's shape (3 gratings and the ambient input: the most a 3-grating
/// model has) in whole groups of four.
const PAPER_ZP: usize = Dims::PAPER.z_len().div_ceil(4) * 4;

/// A sample let into the stream state, as the RBF pass and the rest of the step need it.
#[derive(Clone, Copy, Debug)]
struct Entered<F> {
    /// Envelope and lead flags so far.
    flags: Flags,
    /// The band's lead time \[s\].
    lead: F,
    /// The core's estimate Bφ (what Model-H fades to).
    core: [F; MAX_OUTPUTS],
    /// Bφ + Γm.
    y: [F; MAX_OUTPUTS],
    /// The direction latches after the sample.
    latch: [F; MAX_GRATINGS],
    /// How much of what Model-H adds is kept.
    fade: F,
    /// ρ², the stream's pace against the calibration's (0 without a pace term).
    pace_sq: F,
}

/// The first part of a step: the sample answered already (non-finite, refused by the gate) or
/// let in.
#[derive(Clone, Copy, Debug)]
enum Entry<F> {
    Done(Estimate<F>),
    In(Entered<F>),
}

/// A sample part way through a batch ([`PreparedModel::begin_batch`]): answered already, or
/// let into the stream state with what the rest of its step needs. Opaque; the default is a
/// placeholder to fill.
#[derive(Clone, Copy, Debug)]
pub struct Pending<F>(Entry<F>);

impl<F: Real> Default for Pending<F> {
    fn default() -> Self {
        Pending(Entry::Done(Estimate::refused(0, Flags::OK)))
    }
}

impl<F: Real, const K: usize> PreparedModel<F, K> {
    /// Compensate one sample of the stream `state` and move the state. Never panics:
    /// non-finite inputs give NaN values, an infinite band and [`Flags::NON_FINITE`], leaving
    /// the state untouched.
    #[inline]
    pub fn step(&self, state: &mut StreamState<F>, s: &Sample<F>) -> Estimate<F> {
        self.step_with(state, s, |_, _| {})
    }

    /// [`PreparedModel::step`] that also hands each RBF activation ψ_j to `sink(j, ψ_j)`: the
    /// trainer builds its design matrix Ψ through the very code the device runs. Not called for
    /// non-finite samples.
    #[inline(always)]
    pub fn step_with(&self, state: &mut StreamState<F>, s: &Sample<F>, sink: impl FnMut(usize, F)) -> Estimate<F> {
        // The paper's shape (3 gratings, 3 outputs) with the loop bounds known at compile
        // time, every other shape with them read from the model: the same result either way
        // (B·φ of another shape also runs over the zero padding, each term an exact 0).
        if self.gratings == 3 && self.outputs == 3 {
            self.step_shaped::<3, 3>(state, s, sink)
        } else {
            self.step_shaped::<0, 0>(state, s, sink)
        }
    }

    /// Move the stream `state` (direction latches, memory operators) by one sample without
    /// compensating it: what `step` does to the state, for samples whose estimate is not
    /// needed. Non-finite samples leave the state as `step` would.
    #[inline]
    pub fn advance(&self, state: &mut StreamState<F>, s: &Sample<F>) {
        if self.accepts(s) && self.let_in(state, s, None) {
            let (latches, memory) = state.moving();
            let _: [F; MAX_GRATINGS] = latches.update(&s.dl_pm, usize::from(self.gratings), self.dead_band);
            self.memory.advance(memory, &s.dl_pm, s.t_amb_c, s.t_s);
        }
    }

    /// What a trainer needs of one sample to build the ridge system (paper Eq. 7): the
    /// core's estimate Bφ + Γm and every RBF activation ψ_j (into `psi`, one per centre),
    /// computed by the same code as [`PreparedModel::step`] and moving the stream state as it
    /// does, but without the residual, band or flags. `None` for a sample `step` would answer
    /// as non-finite (`psi` untouched).
    #[inline]
    pub fn core_and_activations(
        &self,
        state: &mut StreamState<F>,
        s: &Sample<F>,
        psi: &mut [F],
    ) -> Option<[F; MAX_OUTPUTS]> {
        // The paper's shape with compile-time loop bounds, as in `step_with`.
        if self.gratings == 3 && self.outputs == 3 {
            self.core_and_activations_shaped::<3, 3>(state, s, psi)
        } else {
            self.core_and_activations_shaped::<0, 0>(state, s, psi)
        }
    }

    /// [`PreparedModel::core_and_activations`] for a model of `G` gratings and `M` outputs (0:
    /// read from the model).
    #[inline(always)]
    fn core_and_activations_shaped<const G: usize, const M: usize>(
        &self,
        state: &mut StreamState<F>,
        s: &Sample<F>,
        psi: &mut [F],
    ) -> Option<[F; MAX_OUTPUTS]> {
        if !self.accepts_shaped::<G>(s) || !self.let_in(state, s, None) {
            return None;
        }
        let (latch, y) = self.advance_with_core::<G, M>(state, s);
        let mut z = [F::ZERO; ZP];
        let z_sq = self.rbf_inputs::<G>(s, &latch, &mut z);
        psi_all(&self.centres, &z, z_sq, usize::from(self.z_groups), psi);
        Some(y)
    }

    /// The RBF activations ψ_j of sample `s` (into `psi`, one per centre) given the direction
    /// latches after it (as [`StreamState::latch_values`] reads them once the sample is
    /// compensated), without a stream state: the ψ of
    /// [`PreparedModel::core_and_activations`], by the same code, for a trainer that has the
    /// stream's latches already and tries several RBF layers on one stream. `false` (and `psi`
    /// untouched) for a sample `step` would answer as non-finite.
    pub fn activations(&self, s: &Sample<F>, latch: &[F; MAX_GRATINGS], psi: &mut [F]) -> bool {
        if !self.accepts(s) {
            return false;
        }
        let mut z = [F::ZERO; ZP];
        let z_sq = self.rbf_inputs::<0>(s, latch, &mut z);
        psi_all(&self.centres, &z, z_sq, usize::from(self.z_groups), psi);
        true
    }

    /// The gate ([`crate::trust`]) for a finite sample whose envelope inputs are `x_env` (made
    /// here when `None`): whether it may move the stream state, remembered when it may. A model
    /// without a gate lets every sample in without looking at it.
    #[inline(always)]
    fn let_in(&self, state: &mut StreamState<F>, s: &Sample<F>, x_env: Option<&[F; MAX_ENVELOPE]>) -> bool {
        if self.gate.is_off() {
            return true;
        }
        let made;
        let x = match x_env {
            Some(x) => x,
            None => {
                made = affine_inputs(&s.dl_pm, usize::from(self.gratings), self.ambient, s.t_amb_c).0;
                &made
            }
        };
        let ok = self.gate.admits(state.gate(), x, s.t_s);
        if ok {
            self.gate.let_in(state.gate_mut(), x, s.t_s);
        }
        ok
    }

    /// Whether every fitted output of `y` is finite (an overflow in this precision otherwise).
    #[inline(always)]
    fn finite_where_fitted(&self, y: &[F; MAX_OUTPUTS]) -> bool {
        y.iter().zip(self.fitted.iter()).all(|(v, &fit)| !fit || v.is_finite())
    }

    /// Whether a sample has the model's grating count and is finite where this model reads it
    /// (Δλ, T_amb with an ambient input, and t when the feature set, the band or the memory
    /// terms use time); other samples are answered as non-finite and leave the stream state
    /// untouched.
    #[inline(always)]
    fn accepts(&self, s: &Sample<F>) -> bool {
        self.accepts_shaped::<0>(s)
    }

    /// [`PreparedModel::accepts`] for a model of `G` gratings (0: any).
    #[inline(always)]
    fn accepts_shaped<const G: usize>(&self, s: &Sample<F>) -> bool {
        s.gratings == self.gratings
            && head(&s.dl_pm, self.g::<G>()).iter().all(|v| v.is_finite())
            && (!self.ambient || s.t_amb_c.is_finite())
            && (!self.needs_time() || s.t_s.is_finite())
    }

    /// Move the stream state by one accepted sample and add the memory terms Γm to `y`;
    /// returns the latch values.
    #[inline(always)]
    fn advance_state<const G: usize>(
        &self,
        state: &mut StreamState<F>,
        s: &Sample<F>,
        y: &mut [F; MAX_OUTPUTS],
    ) -> [F; MAX_GRATINGS] {
        let (latches, memory) = state.moving();
        let latch: [F; MAX_GRATINGS] = latches.update(&s.dl_pm, self.g::<G>(), self.dead_band);
        if self.memory.is_active() {
            self.memory.accumulate::<MAX_OUTPUTS, G>(memory, &s.dl_pm, s.t_amb_c, s.t_s, &self.gamma, y);
        }
        latch
    }

    /// Move the stream state and compute the core's estimate Bφ + Γm.
    #[inline(always)]
    fn advance_with_core<const G: usize, const M: usize>(
        &self,
        state: &mut StreamState<F>,
        s: &Sample<F>,
    ) -> ([F; MAX_GRATINGS], [F; MAX_OUTPUTS]) {
        let mut y = self.core::<G, M>(s);
        let latch = self.advance_state::<G>(state, s, &mut y);
        (latch, y)
    }

    /// The polynomial core Bφ (Model-P's answer when the model has no memory terms):
    /// stage-1 standardised first guesses, then paper Eq. 3 generalised to M guesses.
    #[inline(always)]
    fn core<const G: usize, const M: usize>(&self, s: &Sample<F>) -> [F; MAX_OUTPUTS] {
        let (x, n_in) = affine_inputs(&s.dl_pm, self.g::<G>(), self.ambient, s.t_amb_c);
        self.core_of::<M>(&x, n_in)
    }

    /// [`PreparedModel::core`] from the sample's affine inputs `x` (`n_in` of them), made once
    /// per step.
    #[inline(always)]
    fn core_of<const M: usize>(&self, x: &[F; MAX_ENVELOPE], n_in: usize) -> [F; MAX_OUTPUTS] {
        let m = self.m::<M>();
        let mut g = [F::ZERO; MAX_OUTPUTS];
        for (gi, row) in g.iter_mut().zip(self.a.iter()).take(m) {
            *gi = affine(x, n_in, row);
        }
        // B·φ (paper Eq. 3) through nalgebra: the paper's shape as a 3 × 10 product with its
        // bounds known at compile time, every other shape as the whole MAX_OUTPUTS × MAX_POLY
        // product (entries beyond the model's outputs and terms are zero, each adding an exact
        // 0). Each row accumulates term by term from 0, as a loop would: the same bits.
        if M == 3 {
            // φ of three guesses built in place (no zeroed MAX_POLY array to fill).
            let [g0, g1, g2, _] = g;
            let phi =
                SVector::<F, 10>::from([F::ONE, g0, g1, g2, g0 * g0, g1 * g1, g2 * g2, g0 * g1, g0 * g2, g1 * g2]);
            let part = self.b.fixed_view::<3, 10>(0, 0) * phi;
            let mut y = [F::ZERO; MAX_OUTPUTS];
            for (o, v) in y.iter_mut().zip(part.iter()) {
                *o = *v;
            }
            y
        } else {
            (self.b * SVector::<F, MAX_POLY>::from(poly_features(&g, m))).into()
        }
    }

    /// The scaled RBF inputs z into `z` (a zeroed array: unused inputs stay 0; written in
    /// place, not returned, so that the array is not copied), and ‖z‖²: z_i = x_i·gain_i + offset_i over
    /// the inputs in the layout's order (Δλ_1..N, T_amb, t, latches; an input the model does
    /// not read counts as 0), summed in that order.
    #[inline(always)]
    fn rbf_inputs<const G: usize>(&self, s: &Sample<F>, latch: &[F; MAX_GRATINGS], z: &mut [F]) -> F {
        let n = self.g::<G>();
        let n_z = usize::from(self.n_z);
        let mut z_sq = F::ZERO;
        let mut scaled = z.iter_mut().zip(self.z_gain.iter().zip(self.z_offset.iter())).take(n_z);
        let mut put = |x: F| {
            if let Some((zi, (&gn, &of))) = scaled.next() {
                *zi = x.mul_add(gn, of);
                z_sq = zi.mul_add(*zi, z_sq);
            }
        };
        for &d in head(&s.dl_pm, n) {
            put(d);
        }
        if self.ambient {
            put(s.t_amb_c);
        }
        put(if self.uses_time { s.t_s } else { F::ZERO });
        for &l in head(latch, n) {
            put(if self.uses_latch { l } else { F::ZERO });
        }
        z_sq
    }

    /// [`PreparedModel::step_with`] for a model of `G` gratings and `M` outputs (0: read from
    /// the model).
    #[inline(always)]
    fn step_shaped<const G: usize, const M: usize>(
        &self,
        state: &mut StreamState<F>,
        s: &Sample<F>,
        mut sink: impl FnMut(usize, F),
    ) -> Estimate<F> {
        let e = match self.enter::<G, M>(state, s) {
            Entry::Done(e) => return e,
            Entry::In(e) => e,
        };
        // The paper's shape has at most 2·3 + 2 RBF inputs: two groups of four, a smaller
        // array to clear than every shape's.
        if G == 3 {
            self.residual::<G, M>(s, &e, &mut [F::ZERO; PAPER_ZP], &mut sink)
        } else {
            self.residual::<G, M>(s, &e, &mut [F::ZERO; ZP], &mut sink)
        }
    }

    /// The rest of a step let in: the RBF residual (paper Eq. 5-6) with the variance
    /// projections in the same pass, over the RBF inputs made in `z` (zeroed, at least the
    /// model's inputs long), then the band and flags.
    #[inline(always)]
    fn residual<const G: usize, const M: usize>(
        &self,
        s: &Sample<F>,
        e: &Entered<F>,
        z: &mut [F],
        sink: &mut impl FnMut(usize, F),
    ) -> Estimate<F> {
        let z_sq = self.rbf_inputs::<G>(s, &e.latch, z);
        // Unused inputs have zero weight in every centre and zero value: each adds an exact 0.
        let (y, proj, psi_sq) = centre_pass::<F, K>(&self.centres, z, z_sq, usize::from(self.z_groups), e.y, sink);
        self.leave::<M>(e, z, z_sq, y, &proj, (psi_sq, None))
    }

    /// Compensate `samples` in order, `out[i]` getting what [`PreparedModel::step`] gives for
    /// `samples[i]` on `state`, bit for bit: the same operations on every sample, arranged so
    /// that a host runs them faster. Only the part that moves the stream state (the gate, the
    /// direction latches, the memory operators, the fade that reads them) runs sample after
    /// sample; the RBF pass (the distances to every centre, ψ, Wψ, the variance projections)
    /// runs over `LANES` samples at a time, centre by centre, each sample's sums taken in the
    /// step's order. Stops at the shorter of the two slices and returns how many samples it
    /// compensated. No heap; never panics.
    ///
    /// The same in two parts, for a caller with room for the samples in between:
    /// [`PreparedModel::begin_batch`] (the stream state, in order) then
    /// [`PreparedModel::end_batch`] (no state: any part of the batch, in any order, on any
    /// thread).
    #[inline(always)]
    pub fn step_batch(&self, state: &mut StreamState<F>, samples: &[Sample<F>], out: &mut [Estimate<F>]) -> usize {
        // The paper's shape with compile-time loop bounds, as in `step_with`.
        if self.gratings == 3 && self.outputs == 3 {
            self.step_batch_shaped::<3, 3>(state, samples, out)
        } else {
            self.step_batch_shaped::<0, 0>(state, samples, out)
        }
    }

    /// The first part of [`PreparedModel::step_batch`]: move `state` by `samples` in order,
    /// leaving in `pending` what the rest of each sample's step needs. Returns how many samples
    /// it took (the shorter slice's length).
    #[inline(always)]
    pub fn begin_batch(&self, state: &mut StreamState<F>, samples: &[Sample<F>], pending: &mut [Pending<F>]) -> usize {
        if self.gratings == 3 && self.outputs == 3 {
            self.begin_shaped::<3, 3>(state, samples, pending)
        } else {
            self.begin_shaped::<0, 0>(state, samples, pending)
        }
    }

    /// The second part of [`PreparedModel::step_batch`]: the estimates of `samples` from what
    /// [`PreparedModel::begin_batch`] left for them in `pending` (the same samples, in the same
    /// order). Moves no state. Returns how many it wrote (the shortest slice's length).
    #[inline(always)]
    pub fn end_batch(&self, samples: &[Sample<F>], pending: &[Pending<F>], out: &mut [Estimate<F>]) -> usize {
        if self.gratings == 3 && self.outputs == 3 {
            self.end_shaped::<3, 3>(samples, pending, out)
        } else {
            self.end_shaped::<0, 0>(samples, pending, out)
        }
    }

    /// [`PreparedModel::step_batch`] for a model of `G` gratings and `M` outputs (0: read from
    /// the model): each block of `LANES` samples begun, then ended.
    #[inline(always)]
    fn step_batch_shaped<const G: usize, const M: usize>(
        &self,
        state: &mut StreamState<F>,
        samples: &[Sample<F>],
        out: &mut [Estimate<F>],
    ) -> usize {
        let mut done = 0;
        for (ss, os) in samples.chunks(LANES).zip(out.chunks_mut(LANES)) {
            // No sample moves the state without its estimate written.
            let ss = ss.get(..os.len()).unwrap_or(ss);
            let mut pending = [Pending::<F>::default(); LANES];
            self.begin_shaped::<G, M>(state, ss, &mut pending);
            done += self.end_block::<G, M>(ss, &pending, os);
        }
        done
    }

    /// [`PreparedModel::begin_batch`] for a model of `G` gratings and `M` outputs.
    #[inline(always)]
    fn begin_shaped<const G: usize, const M: usize>(
        &self,
        state: &mut StreamState<F>,
        samples: &[Sample<F>],
        pending: &mut [Pending<F>],
    ) -> usize {
        let mut n = 0;
        for (s, p) in samples.iter().zip(pending.iter_mut()) {
            *p = Pending(self.enter::<G, M>(state, s));
            n += 1;
        }
        n
    }

    /// [`PreparedModel::end_batch`] for a model of `G` gratings and `M` outputs.
    #[inline(always)]
    fn end_shaped<const G: usize, const M: usize>(
        &self,
        samples: &[Sample<F>],
        pending: &[Pending<F>],
        out: &mut [Estimate<F>],
    ) -> usize {
        let mut done = 0;
        for ((ss, ps), os) in samples.chunks(LANES).zip(pending.chunks(LANES)).zip(out.chunks_mut(LANES)) {
            done += self.end_block::<G, M>(ss, ps, os);
        }
        done
    }

    /// The rest of the steps of at most `LANES` begun samples: their RBF inputs laid out one
    /// lane per sample (a lane whose sample is answered already keeps zeros and its sums are
    /// not read), the RBF pass over the lanes, then each sample's band and flags.
    #[inline(always)]
    fn end_block<const G: usize, const M: usize>(
        &self,
        samples: &[Sample<F>],
        pending: &[Pending<F>],
        out: &mut [Estimate<F>],
    ) -> usize {
        let mut lanes = Lanes::<F>::new();
        let rows = samples.iter().zip(pending.iter()).take(LANES);
        for (lane, (s, p)) in rows.enumerate() {
            if let Entry::In(e) = &p.0 {
                let mut z = [F::ZERO; ZP];
                let z_sq = self.rbf_inputs::<G>(s, &e.latch, &mut z);
                lanes.put(lane, &z, z_sq, &e.y);
            }
        }
        centre_pass_lanes::<F, K>(&self.centres, &mut lanes, usize::from(self.z_groups));
        let mut n = 0;
        for (lane, ((o, p), _)) in out.iter_mut().zip(pending.iter()).zip(samples.iter()).take(LANES).enumerate() {
            *o = match &p.0 {
                Entry::Done(e) => *e,
                Entry::In(e) => {
                    let (z, z_sq, y, proj, psi_sq) = lanes.get(lane);
                    self.leave::<M>(e, &z, z_sq, y, &proj, (psi_sq, Some(lanes.psi_max(lane))))
                }
            };
            n += 1;
        }
        n
    }

    /// The part of a step that moves the stream state: the sample checked (a non-finite one is
    /// answered), the envelope flags, the lead, the core; the gate (a refused sample is answered
    /// by the core with Model-P's band); then the latches and the memory terms (Γm added to the
    /// core) and the fade, which reads the state they leave.
    #[inline(always)]
    fn enter<const G: usize, const M: usize>(&self, state: &mut StreamState<F>, s: &Sample<F>) -> Entry<F> {
        if !self.accepts_shaped::<G>(s) {
            return Entry::Done(Estimate::refused(self.outputs, Flags::NON_FINITE));
        }
        let (x_env, n_env) = affine_inputs(&s.dl_pm, self.g::<G>(), self.ambient, s.t_amb_c);
        let mut flags = Flags::OK;
        for ((&x, &lo), &hi) in head(&x_env, n_env).iter().zip(self.env_lo.iter()).zip(self.env_hi.iter()) {
            if x < lo || x > hi {
                flags.insert(Flags::OUT_OF_ENVELOPE);
            }
        }
        let lead = self.lead(state, s, &mut flags);
        let core = self.core_of::<M>(&x_env, n_env);

        // A sample the gate refuses leaves the stream state as it was and is answered by
        // Model-P's core with Model-P's band (widened as a fault).
        if !self.let_in(state, s, Some(&x_env)) {
            flags.insert(Flags::OUT_OF_ENVELOPE.union(Flags::FALLBACK));
            if !self.finite_where_fitted(&core) {
                return Entry::Done(Estimate::refused(self.outputs, flags.union(Flags::NON_FINITE)));
            }
            let scale = self.pace_ratio_sq(state).max(F::ONE);
            return Entry::Done(self.finish::<M>(core, F::ZERO, lead, F::ZERO, scale, flags));
        }
        let mut y = core;
        let latch = self.advance_state::<G>(state, s, &mut y);
        // Beyond the calibration's quiet time or its pace, what Model-H adds to the core fades.
        let (pace_sq, slow_sq) = self.pace_ratios_sq(state);
        let fade = self.fade::<G>(state, s.t_s, pace_sq, slow_sq);
        Entry::In(Entered { flags, lead, core, y, latch, fade, pace_sq })
    }

    /// The rest of a step, after the RBF pass over the sample's inputs `z` (‖z‖² `z_sq`) gave
    /// `y` (core + Γm + Wψ), the variance projections `proj`, ‖ψ‖² `psi_sq` and, when the pass
    /// kept it, max ψ `psi_max`: weak support, leverage, fade, band and flags. Moves no state.
    #[inline(always)]
    fn leave<const M: usize>(
        &self,
        e: &Entered<F>,
        z: &[F],
        z_sq: F,
        y: [F; MAX_OUTPUTS],
        proj: &[F; VAR_RANK],
        (psi_sq, psi_max): (F, Option<F>),
    ) -> Estimate<F> {
        let mut flags = e.flags;
        let groups = usize::from(self.z_groups);
        if !self.centres.is_empty()
            && weak::<F, K>(&self.centres, z, z_sq, groups, (psi_sq, psi_max), self.weak_support)
        {
            flags.insert(Flags::WEAK_SUPPORT);
        }

        // Leverage h = ψᵀ(ΨᵀΨ + αI)⁻¹ψ, exact on the kept directions, bounded on the rest.
        let mut lev = psi_sq * self.inv_g_tail;
        for &pi in proj.iter() {
            lev = pi.mul_add(pi, lev);
        }
        let fade = e.fade;
        let y = if fade < F::ONE {
            flags.insert(Flags::FALLBACK);
            let mut out = e.core;
            for ((o, &full), &c) in out.iter_mut().zip(y.iter()).zip(e.core.iter()) {
                *o = fade.mul_add(full - c, c);
            }
            out
        } else {
            y
        };
        // An overflow in this precision (finite inputs far outside anything calibrated) is
        // reported like a non-finite input rather than passed on as a normal estimate.
        if !self.finite_where_fitted(&y) {
            return Estimate::refused(self.outputs, flags.union(Flags::NON_FINITE));
        }
        self.finish::<M>(y, lev, e.lead, fade, e.pace_sq.max(F::ONE), flags)
    }

    /// ρ², the square of the stream's pace against the calibration's ([`crate::trust`]); 0
    /// without a pace term.
    #[inline(always)]
    fn pace_ratio_sq(&self, state: &StreamState<F>) -> F {
        self.pace_ratios_sq(state).0
    }

    /// ρ² and the slowness σ² of the stream ([`crate::trust`]); both 0 without a pace term.
    #[inline(always)]
    fn pace_ratios_sq(&self, state: &StreamState<F>) -> (F, F) {
        if self.pace.is_off() {
            (F::ZERO, F::ZERO)
        } else {
            self.pace.ratios_sq(state.gate().swing())
        }
    }

    /// The band's lead time \[s\] of sample `s`: since the end of calibration on the stream's
    /// clock, or the largest validated lead (flagged) when the clock is unknown; 0 for a band
    /// that does not grow.
    #[inline(always)]
    fn lead(&self, state: &StreamState<F>, s: &Sample<F>, flags: &mut Flags) -> F {
        if !self.band_grows {
            F::ZERO
        } else if let Some(o) = state.lead_offset_s() {
            (s.t_s + o).max(F::ZERO)
        } else {
            flags.insert(Flags::LEAD_UNKNOWN);
            self.lead_max_s
        }
    }

    /// How much of what Model-H adds to the core is kept at `t_s` with the pace ratio² `pace_sq`
    /// and the slowness² `slow_sq`:
    /// per grating, 1 while its quiet time is within the calibration's largest, then linearly
    /// down to 0 at twice that; 1 while the pace ratio ρ is within 1, then linearly down to 0 at
    /// ρ = 2; the same for the slowness σ; the smallest of them ([`crate::trust`]).
    #[inline(always)]
    fn fade<const G: usize>(&self, state: &StreamState<F>, t_s: F, pace_sq: F, slow_sq: F) -> F {
        let mut fade = F::ONE;
        for ratio_sq in [pace_sq, slow_sq] {
            if ratio_sq > F::ONE {
                let f = fade_beyond(ratio_sq.sqrt());
                if f < fade {
                    fade = f;
                }
            }
        }
        for (g, &q_max) in head(&self.quiet_max_s, self.g::<G>()).iter().enumerate() {
            let q = state.memory().quiet_s(g, t_s);
            if q_max > F::ZERO && q > q_max {
                let f = fade_beyond(q / q_max);
                if f < fade {
                    fade = f;
                }
            }
        }
        fade
    }

    /// The estimate from the values `y`, the leverage, the lead, the fade (1: Model-H's
    /// band; 0: Model-P's, blended in variance between, [`crate::trust`]) and the factor ≥ 1 beyond the
    /// calibration's pace that multiplies the band's variance: the band, and the plausibility of
    /// the value and the band ([`crate::field`]): three compares per output. An output
    /// unchecked or not fitted has ±∞ bounds and an infinite limit: only a band that overflows
    /// flags it (then the leverage did, for every output).
    #[inline(always)]
    fn finish<const M: usize>(
        &self,
        mut y: [F; MAX_OUTPUTS],
        lev: F,
        lead: F,
        fade: F,
        pace_scale: F,
        mut flags: Flags,
    ) -> Estimate<F> {
        let m = self.m::<M>();
        let mut band95 = [F::ZERO; MAX_OUTPUTS];
        let mut implausible = false;
        for ((((bi, (&bv, &bg)), (&v, &lim)), (&lo, &hi)), (&pv, &pg)) in band95
            .iter_mut()
            .zip(self.band_var.iter().zip(self.band_var_growth.iter()))
            .zip(y.iter().zip(self.band_lim.iter()))
            .zip(self.out_lo.iter().zip(self.out_hi.iter()))
            .zip(self.fallback_var.iter().zip(self.fallback_var_growth.iter()))
            .take(m)
        {
            let own = bg.mul_add(lead, bv) * (F::ONE + lev);
            let var = if fade < F::ONE {
                let p = pg.mul_add(lead, pv);
                fade.mul_add(own - p, p)
            } else {
                own
            };
            // Beyond the calibration's pace (scale > 1 only there: the same bits within it).
            let var = if pace_scale > F::ONE { var * pace_scale } else { var };
            *bi = var.sqrt();
            // `!(b < lim)`: true for a NaN band too.
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            let bad = v < lo || v > hi || !(*bi < lim);
            implausible |= bad;
        }
        if implausible {
            flags.insert(Flags::IMPLAUSIBLE);
        }
        // Every fault widens the band, the implausible ones included.
        if flags.is_fault() {
            for bi in band95.iter_mut().take(m) {
                *bi *= self.flagged_band_factor;
            }
        }
        for ((v, b), &fit) in y.iter_mut().zip(band95.iter_mut()).zip(self.fitted.iter()).take(m) {
            if !fit {
                *v = F::NAN;
                *b = F::INFINITY;
            }
        }
        Estimate { values: y, band95, outputs: self.outputs, flags }
    }
}

/// φ(g): [1, g_1..g_M, g_1²..g_M², g_i·g_j for i < j] (the first [`crate::layout::Dims::poly_len`] entries).
#[inline(always)]
fn poly_features<F: Real>(g: &[F; MAX_OUTPUTS], m: usize) -> [F; MAX_POLY] {
    let mut phi = [F::ZERO; MAX_POLY];
    let g = head(g, m);
    let mut k = 0;
    let mut put = |v: F| {
        if let Some(o) = phi.get_mut(k) {
            *o = v;
        }
        k += 1;
    };
    put(F::ONE);
    for &gi in g {
        put(gi);
    }
    for &gi in g {
        put(gi * gi);
    }
    for (i, &gi) in g.iter().enumerate() {
        for &gj in g.iter().skip(i + 1) {
            put(gi * gj);
        }
    }
    phi
}

/// What a fade keeps at `ratio` > 1 times its limit ([`crate::trust`]): linearly from 1 at the
/// limit down to 0 at twice it.
#[inline(always)]
fn fade_beyond<F: Real>(ratio: F) -> F {
    (F::ONE + F::ONE - ratio).max(F::ZERO)
}
