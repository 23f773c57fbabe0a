//! Every memory operator of a model over one sample stream.

use crate::error::Error;
use crate::layout::{
    head, Dims, MAX_ENVELOPE, MAX_GRATINGS, MAX_MEMORY, MAX_STAGE1, N_AMBIENT_TAUS, N_GRATING_TAUS, N_PLAYS,
};
use crate::memory::{DriftObserver, LowPass, MemorySpec, Play};
use crate::real::Real;

/// The stream state of a [`MemoryBank`]: every low-pass and play position, the observer and the
/// last sample time (sized to the capacity of [`MAX_GRATINGS`] gratings); `Copy`, so a stream can be checkpointed and resumed.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MemoryState<F> {
    grating: [[F; MAX_GRATINGS]; N_GRATING_TAUS],
    ambient: [F; N_AMBIENT_TAUS],
    play: [[F; MAX_GRATINGS]; N_PLAYS],
    observer: [F; 2],
    t_prev_s: F,
    primed: bool,
}

impl<F: Real> MemoryState<F> {
    /// A state that has seen no sample.
    pub const fn new() -> Self {
        MemoryState {
            grating: [[F::ZERO; MAX_GRATINGS]; N_GRATING_TAUS],
            ambient: [F::ZERO; N_AMBIENT_TAUS],
            play: [[F::ZERO; MAX_GRATINGS]; N_PLAYS],
            observer: [F::ZERO; 2],
            t_prev_s: F::ZERO,
            primed: false,
        }
    }
}

impl<F: Real> MemoryState<F> {
    /// Numbers in the packed form of the state of a bank over `gratings` gratings
    /// ([`MemoryState::pack`]): every low-pass and play position of those gratings, the ambient
    /// low-passes, the observer's two stages, the last sample time and whether the bank is primed.
    pub const fn packed_len(gratings: usize) -> usize {
        gratings * (N_GRATING_TAUS + N_PLAYS) + N_AMBIENT_TAUS + 4
    }

    /// Write the state of the first `gratings` gratings into `out` (exactly
    /// [`MemoryState::packed_len`] numbers, exact in any precision): a checkpoint of a long
    /// stream at the model's own size instead of the capacity's. Slots beyond `gratings` are not
    /// kept (a bank over `gratings` never reads them).
    pub fn pack(&self, gratings: usize, out: &mut [F]) -> Result<(), Error> {
        let n = Self::check_packed(gratings, out.len())?;
        let rows = self.grating.iter().chain(self.play.iter());
        let (mut cells, rest) = out.split_at_mut(n * (N_GRATING_TAUS + N_PLAYS));
        for row in rows {
            let (here, later) = cells.split_at_mut(n);
            here.copy_from_slice(head(row, n));
            cells = later;
        }
        let (amb, tail) = rest.split_at_mut(N_AMBIENT_TAUS);
        amb.copy_from_slice(&self.ambient);
        for (o, v) in tail.iter_mut().zip([
            self.observer[0],
            self.observer[1],
            self.t_prev_s,
            if self.primed { F::ONE } else { F::ZERO },
        ]) {
            *o = v;
        }
        Ok(())
    }

    /// The state [`MemoryState::pack`] wrote into `from` (slots beyond `gratings` zero).
    pub fn unpack(gratings: usize, from: &[F]) -> Result<Self, Error> {
        let mut s = Self::new();
        s.unpack_into(gratings, from)?;
        Ok(s)
    }

    /// [`MemoryState::unpack`] in place: the slots of the first `gratings` gratings and the
    /// rest of the state are overwritten, slots beyond `gratings` are left as they are (a bank
    /// over `gratings` never reads them). Nothing is written when `from` is refused.
    pub fn unpack_into(&mut self, gratings: usize, from: &[F]) -> Result<(), Error> {
        let n = Self::check_packed(gratings, from.len())?;
        let s = self;
        let (mut cells, rest) = from.split_at(n * (N_GRATING_TAUS + N_PLAYS));
        for row in s.grating.iter_mut().chain(s.play.iter_mut()) {
            let (here, later) = cells.split_at(n);
            row.iter_mut().zip(here).for_each(|(o, &v)| *o = v);
            cells = later;
        }
        let (amb, tail) = rest.split_at(N_AMBIENT_TAUS);
        s.ambient.iter_mut().zip(amb).for_each(|(o, &v)| *o = v);
        if let [o0, o1, t, primed] = *tail {
            s.observer = [o0, o1];
            s.t_prev_s = t;
            s.primed = primed != F::ZERO;
        }
        Ok(())
    }

    /// `gratings` within capacity and `len` its packed length; returns `gratings`.
    fn check_packed(gratings: usize, len: usize) -> Result<usize, Error> {
        if gratings > MAX_GRATINGS {
            return Err(Error::OverCapacity {
                field: "gratings",
                found: u16::try_from(gratings).unwrap_or(u16::MAX),
                capacity: MAX_GRATINGS as u16,
            });
        }
        let want = Self::packed_len(gratings);
        if len != want {
            return Err(Error::WrongDims {
                field: "packed memory state",
                found: u16::try_from(len).unwrap_or(u16::MAX),
                expected: u16::try_from(want).unwrap_or(u16::MAX),
            });
        }
        Ok(gratings)
    }
}

/// The memory operators of a [`MemorySpec`] with their stream state.
///
/// [`MemoryBank::update`] takes one sample and returns the memory vector m. O(1) work and state
/// per sample. The smoothing factors are recomputed only when Δt changes, so a regularly
/// sampled stream costs no exponential per step.
///
/// **Start and gaps.** The first sample primes every operator at its own value (high-pass and
/// stop terms 0). A later sample Δt after the previous accepted one moves each low-pass by
/// α = 1 − e^(−Δt/τ), as if the input had held the new value over the whole interval: a gap
/// much longer than τ re-primes that low-pass (its high-pass restarts near 0), a short one is
/// simply a longer step. The play operators do not depend on time. A repeated or backward time
/// stamp gives Δt <= 0: the low-passes hold, the plays still move.
///
/// ```
/// use fbg_shared::layout::{pad, Dims};
/// use fbg_shared::memory::{MemoryBank, MemorySpec};
/// let dims = Dims::PAPER;
/// let mut spec = MemorySpec::<f32>::off();
/// spec.grating_tau_s[0] = 600.0; // Δλ − EMA_600s(Δλ) of each grating
/// spec.play_half_width_pm[0] = 2.0; // the stop term of half-width 2 pm
/// let mut bank = MemoryBank::<f32>::new(&spec, &dims);
/// assert!(bank.is_active());
/// let m = bank.update(&[0.0; 8], 20.0, 0.0); // the first sample primes
/// assert!(m.iter().all(|&v| v == 0.0));
/// let m = bank.update(&pad(&[5.0, 0.0, 0.0]), 20.0, 60.0);
/// assert!(m[0] > 0.0 && m[0] < 5.0); // the high-pass of grating 1 follows the step
/// assert_eq!(m[dims.mem_stop()], 2.0); // its stop term is pushed to +r
/// assert!(!MemoryBank::<f32>::new(&MemorySpec::<f32>::off(), &dims).is_active());
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MemoryBank<F> {
    grating_lp: [LowPass<F>; N_GRATING_TAUS],
    ambient_lp: [LowPass<F>; N_AMBIENT_TAUS],
    plays: [Play<F>; N_PLAYS],
    observer: DriftObserver<F>,
    observer_row: [F; MAX_STAGE1],
    /// Gratings N of the model.
    gratings: u8,
    /// Whether the model has the ambient input (the ambient high-passes read it).
    ambient: bool,
    grating_on: [bool; N_GRATING_TAUS],
    ambient_on: [bool; N_AMBIENT_TAUS],
    play_on: [bool; N_PLAYS],
    observer_on: bool,
    any: bool,
    /// Δt of the cached smoothing factors (NaN: none cached).
    cached_dt: F,
    alpha_grating: [F; N_GRATING_TAUS],
    alpha_ambient: [F; N_AMBIENT_TAUS],
    alpha_observer: [F; 2],
    state: MemoryState<F>,
}

impl<F: Real> MemoryBank<F> {
    /// A bank with no operator in use (every term 0), usable in a `static`: all its bytes are
    /// zero (the cached Δt is 0, whose smoothing factors are the zeros already cached).
    pub const fn off() -> Self {
        MemoryBank {
            grating_lp: [LowPass::off(); N_GRATING_TAUS],
            ambient_lp: [LowPass::off(); N_AMBIENT_TAUS],
            plays: [Play::off(); N_PLAYS],
            observer: DriftObserver::off(),
            observer_row: [F::ZERO; MAX_STAGE1],
            gratings: 0,
            ambient: false,
            grating_on: [false; N_GRATING_TAUS],
            ambient_on: [false; N_AMBIENT_TAUS],
            play_on: [false; N_PLAYS],
            observer_on: false,
            any: false,
            cached_dt: F::ZERO,
            alpha_grating: [F::ZERO; N_GRATING_TAUS],
            alpha_ambient: [F::ZERO; N_AMBIENT_TAUS],
            alpha_observer: [F::ZERO; 2],
            state: MemoryState::new(),
        }
    }

    /// A bank for `spec` (any precision; converted here) of a model with `dims` that has seen
    /// no sample. Slots the dims do not have (ambient, observer) stay off.
    pub fn new<G: Real>(spec: &MemorySpec<G>, dims: &Dims) -> Self {
        let s: MemorySpec<F> = spec.convert();
        let mut b = MemoryBank::<F> {
            observer: DriftObserver::new(s.observer_lag_s, s.observer_smooth_s),
            observer_row: s.observer_row,
            observer_on: dims.has_observer() && s.observer_lag_s > F::ZERO && s.observer_smooth_s > F::ZERO,
            gratings: dims.gratings() as u8,
            ambient: dims.ambient(),
            cached_dt: F::NAN,
            ..Self::off()
        };
        for ((lp, on), &tau) in b.grating_lp.iter_mut().zip(b.grating_on.iter_mut()).zip(s.grating_tau_s.iter()) {
            *lp = LowPass::new(tau);
            *on = tau > F::ZERO;
        }
        for ((lp, on), &tau) in b.ambient_lp.iter_mut().zip(b.ambient_on.iter_mut()).zip(s.ambient_tau_s.iter()) {
            *lp = LowPass::new(tau);
            *on = dims.ambient() && tau > F::ZERO;
        }
        for ((op, on), &r) in b.plays.iter_mut().zip(b.play_on.iter_mut()).zip(s.play_half_width_pm.iter()) {
            *op = Play::new(r);
            *on = r > F::ZERO;
        }
        b.any = b.grating_on.iter().chain(b.ambient_on.iter()).chain(b.play_on.iter()).any(|&o| o) || b.observer_on;
        b
    }

    /// Whether the bank computes any term (otherwise [`MemoryBank::update`] returns zeros).
    pub fn is_active(&self) -> bool {
        self.any
    }

    /// The stream state, to checkpoint a stream.
    pub fn state(&self) -> MemoryState<F> {
        self.state
    }

    /// Resume from a state taken by [`MemoryBank::state`] of a bank with the same spec.
    pub fn set_state(&mut self, state: MemoryState<F>) {
        self.state = state;
    }

    /// Resume from a state packed by [`MemoryState::pack`] for this bank's gratings, in place
    /// (see [`MemoryState::unpack_into`]).
    pub fn set_packed_state(&mut self, from: &[F]) -> Result<(), Error> {
        self.state.unpack_into(usize::from(self.gratings), from)
    }

    /// Forget the stream.
    pub fn reset(&mut self) {
        self.state = MemoryState::new();
    }

    /// Whether `other` computes the same terms from the same coefficients (so that a state of
    /// one resumes the other).
    pub fn same_spec(&self, other: &Self) -> bool {
        self.grating_lp == other.grating_lp
            && self.ambient_lp == other.ambient_lp
            && self.plays == other.plays
            && self.observer == other.observer
            && self.observer_row == other.observer_row
            && self.observer_on == other.observer_on
            && self.gratings == other.gratings
            && self.ambient == other.ambient
            && self.grating_on == other.grating_on
            && self.ambient_on == other.ambient_on
            && self.play_on == other.play_on
    }

    #[inline(always)]
    fn refresh_alphas(&mut self, dt: F) {
        // Bitwise-equal Δt reuses the factors; NaN (nothing cached) never compares equal.
        if dt != self.cached_dt {
            self.recompute_alphas(dt);
        }
    }

    /// The smoothing factors for a new Δt: rare on a regular clock, so kept out of line.
    #[inline(never)]
    fn recompute_alphas(&mut self, dt: F) {
        self.cached_dt = dt;
        for ((a, lp), &on) in self.alpha_grating.iter_mut().zip(self.grating_lp.iter()).zip(self.grating_on.iter()) {
            *a = if on { lp.alpha(dt) } else { F::ZERO };
        }
        for ((a, lp), &on) in self.alpha_ambient.iter_mut().zip(self.ambient_lp.iter()).zip(self.ambient_on.iter()) {
            *a = if on { lp.alpha(dt) } else { F::ZERO };
        }
        if self.observer_on {
            let (lag, smooth) = self.observer.low_passes();
            self.alpha_observer = [lag.alpha(dt), smooth.alpha(dt)];
        }
    }

    /// The grating temperature T_g [°C] the observer follows.
    #[inline(always)]
    fn grating_temperature(&self, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F) -> F {
        let (x, n) = affine_inputs(dl_pm, usize::from(self.gratings), self.ambient, t_amb_c);
        affine(&x, n, &self.observer_row)
    }

    /// Feed one finite sample (shifts Δλ \[pm\], ambient T_amb [°C], time t \[s\]) and return the
    /// memory vector m (unused terms 0). The caller screens non-finite samples: they must not
    /// reach the bank (the compensator leaves the whole stream state untouched for them).
    #[inline]
    pub fn update(&mut self, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F, t_s: F) -> [F; MAX_MEMORY] {
        let mut m = [F::ZERO; MAX_MEMORY];
        self.run(dl_pm, t_amb_c, t_s, |k, v| {
            if let Some(o) = m.get_mut(k) {
                *o = v;
            }
        });
        m
    }

    /// [`MemoryBank::update`] without the terms: moves the stream only (a checkpoint pass).
    #[inline]
    pub fn advance(&mut self, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F, t_s: F) {
        self.run(dl_pm, t_amb_c, t_s, |_, _| {});
    }

    /// [`MemoryBank::update`] that adds Γm to `y` instead of returning m (`gamma[k][o]` is the
    /// coefficient of term k on output o, term-major so that one term updates every output
    /// at once; outputs a model does not have carry 0): what the compensator runs per sample,
    /// without the memory vector's round trip through memory.
    // Out of line: one copy serves the compensator's step and stream advances.
    #[inline(never)]
    pub fn accumulate<const O: usize>(
        &mut self,
        dl_pm: &[F; MAX_GRATINGS],
        t_amb_c: F,
        t_s: F,
        gamma: &[[F; O]; MAX_MEMORY],
        y: &mut [F; O],
    ) {
        self.run(dl_pm, t_amb_c, t_s, |k, v| {
            if let Some(col) = gamma.get(k) {
                for (yo, &g) in y.iter_mut().zip(col.iter()) {
                    *yo = g.mul_add(v, *yo);
                }
            }
        });
    }

    /// Move every operator by one sample and hand each used term to `sink(k, m_k)` in
    /// memory-vector order (unused terms are not handed over).
    #[inline(always)]
    fn run(&mut self, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F, t_s: F, mut sink: impl FnMut(usize, F)) {
        if !self.any {
            return;
        }
        let t_g = if self.observer_on { self.grating_temperature(dl_pm, t_amb_c) } else { F::ZERO };
        let n = usize::from(self.gratings);
        let dl = head(dl_pm, n);
        // Memory-vector indices: the layout of `Dims` (grating high-passes, ambient, stop, observer).
        let mem_ambient = n * N_GRATING_TAUS;
        let mem_stop = mem_ambient + if self.ambient { N_AMBIENT_TAUS } else { 0 };
        let mem_observer = mem_stop + n * N_PLAYS;
        if !self.state.primed {
            let st = &mut self.state;
            for row in st.grating.iter_mut().chain(st.play.iter_mut()) {
                *row = *dl_pm;
            }
            st.ambient = [t_amb_c; N_AMBIENT_TAUS];
            DriftObserver::prime(&mut st.observer, t_g, t_amb_c);
            st.t_prev_s = t_s;
            st.primed = true;
            if self.observer_on {
                sink(mem_observer, st.observer[1]);
            }
            return;
        }
        let dt = t_s - self.state.t_prev_s;
        self.state.t_prev_s = t_s;
        self.refresh_alphas(dt);
        let st = &mut self.state;
        let mut k = 0;
        for (((lp, &on), &a), s) in
            self.grating_lp.iter().zip(self.grating_on.iter()).zip(self.alpha_grating.iter()).zip(st.grating.iter_mut())
        {
            if on {
                for (j, (&x, si)) in dl.iter().zip(s.iter_mut()).enumerate() {
                    sink(k + j, x - lp.update(si, x, a));
                }
            }
            k += n;
        }
        for (k, (((lp, &on), &a), si)) in (mem_ambient..).zip(
            self.ambient_lp
                .iter()
                .zip(self.ambient_on.iter())
                .zip(self.alpha_ambient.iter())
                .zip(st.ambient.iter_mut()),
        ) {
            if on {
                sink(k, t_amb_c - lp.update(si, t_amb_c, a));
            }
        }
        let mut k = mem_stop;
        for ((op, &on), s) in self.plays.iter().zip(self.play_on.iter()).zip(st.play.iter_mut()) {
            if on {
                for (j, (&x, si)) in dl.iter().zip(s.iter_mut()).enumerate() {
                    sink(k + j, op.stop(si, x));
                }
            }
            k += n;
        }
        if self.observer_on {
            let v = self.observer.update(&mut st.observer, t_g, t_amb_c, self.alpha_observer);
            sink(mem_observer, v);
        }
    }
}

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
