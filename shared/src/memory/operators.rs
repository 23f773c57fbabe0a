//! The memory operators of a model in per-sample form: coefficients only, stepped over a
//! [`MemoryState`] that the caller keeps (idsp's split of a filter from its state).

use crate::affine::{affine, affine_inputs};
use crate::layout::{head, Dims, MAX_GRATINGS, MAX_MEMORY, MAX_STAGE1, N_AMBIENT_TAUS, N_GRATING_TAUS, N_PLAYS};
use crate::memory::state::Smoothing;
use crate::memory::{DriftObserver, LowPass, MemorySpec, MemoryState, Play};
use crate::real::Real;

// `MemoryOperators::grating_on` holds one bit per grating time constant.
const _: () = assert!(N_GRATING_TAUS <= u8::BITS as usize);

/// Every memory operator of a [`MemorySpec`], ready to step: the low-passes, plays and the drift
/// observer with which of them the model uses. Immutable while a stream runs: one set of
/// operators serves any number of streams, each with its own [`MemoryState`].
///
/// [`MemoryOperators::update`] takes one sample and returns the memory vector m. O(1) work and
/// state per sample. The smoothing factors are recomputed only when Δt changes (they are
/// cached in the state), so a regularly sampled stream costs no exponential per step.
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
/// use fbg_shared::memory::{MemoryOperators, MemorySpec, MemoryState};
/// let mut spec = MemorySpec::<f32>::off();
/// spec.grating_tau_s[0] = 600.0; // Δλ − EMA_600s(Δλ) of each grating
/// let ops = MemoryOperators::<f32>::new(&spec, &Dims::PAPER);
/// let (mut a, mut b) = (MemoryState::new(), MemoryState::new());
/// ops.update(&mut a, &[0.0; 8], 20.0, 0.0); // stream a primes
/// let m = ops.update(&mut a, &pad(&[5.0, 0.0, 0.0]), 20.0, 60.0);
/// assert!(m[0] > 0.0 && m[0] < 5.0);
/// let m = ops.update(&mut b, &[0.0; 8], 20.0, 0.0); // stream b primes on its own
/// assert!(m.iter().all(|&v| v == 0.0));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MemoryOperators<F> {
    grating_lp: [LowPass<F>; N_GRATING_TAUS],
    ambient_lp: [LowPass<F>; N_AMBIENT_TAUS],
    plays: [Play<F>; N_PLAYS],
    observer: DriftObserver<F>,
    observer_row: [F; MAX_STAGE1],
    /// Gratings N of the model.
    gratings: u8,
    /// Whether the model has the ambient input (the ambient high-passes read it).
    ambient: bool,
    /// The grating high-passes in use, as bits (bit i: time constant i), so that a step
    /// visits only those.
    grating_on: u8,
    ambient_on: [bool; N_AMBIENT_TAUS],
    play_on: [bool; N_PLAYS],
    /// The slot of the narrowest play in use (0 when none, then unused: only slots in use
    /// are clocked): its reversals end a grating's quiet time ([`crate::trust`]).
    narrowest: u8,
    observer_on: bool,
    any: bool,
}

impl<F: Real> MemoryOperators<F> {
    /// No operator in use (every term 0), usable in a `static`: all its bytes are zero.
    pub const fn off() -> Self {
        MemoryOperators {
            grating_lp: [LowPass::off(); N_GRATING_TAUS],
            ambient_lp: [LowPass::off(); N_AMBIENT_TAUS],
            plays: [Play::off(); N_PLAYS],
            observer: DriftObserver::off(),
            observer_row: [F::ZERO; MAX_STAGE1],
            gratings: 0,
            ambient: false,
            grating_on: 0,
            ambient_on: [false; N_AMBIENT_TAUS],
            play_on: [false; N_PLAYS],
            // Zero, as every other field: an unloaded bank is all zero bytes (`.bss`).
            narrowest: 0,
            observer_on: false,
            any: false,
        }
    }

    /// The operators of `spec` (any precision; converted here) for a model with `dims`. Slots
    /// the dims do not have (ambient, observer) stay off.
    pub fn new<G: Real>(spec: &MemorySpec<G>, dims: &Dims) -> Self {
        let s: MemorySpec<F> = spec.convert();
        let mut b = MemoryOperators::<F> {
            observer: DriftObserver::new(s.observer_lag_s, s.observer_smooth_s),
            observer_row: s.observer_row,
            observer_on: dims.has_observer() && s.observer_lag_s > F::ZERO && s.observer_smooth_s > F::ZERO,
            gratings: dims.gratings() as u8,
            ambient: dims.ambient(),
            ..Self::off()
        };
        for (i, (lp, &tau)) in b.grating_lp.iter_mut().zip(s.grating_tau_s.iter()).enumerate() {
            *lp = LowPass::new(tau);
            if tau > F::ZERO {
                b.grating_on |= 1 << i;
            }
        }
        for ((lp, on), &tau) in b.ambient_lp.iter_mut().zip(b.ambient_on.iter_mut()).zip(s.ambient_tau_s.iter()) {
            *lp = LowPass::new(tau);
            *on = dims.ambient() && tau > F::ZERO;
        }
        let mut narrowest = F::INFINITY;
        for (j, ((op, on), &r)) in
            b.plays.iter_mut().zip(b.play_on.iter_mut()).zip(s.play_half_width_pm.iter()).enumerate()
        {
            *op = Play::new(r);
            *on = r > F::ZERO;
            if r > F::ZERO && r < narrowest {
                narrowest = r;
                b.narrowest = j as u8;
            }
        }
        b.any = b.grating_on != 0 || b.ambient_on.iter().chain(b.play_on.iter()).any(|&o| o) || b.observer_on;
        b
    }

    /// Whether any term is computed (otherwise [`MemoryOperators::update`] returns zeros).
    pub fn is_active(&self) -> bool {
        self.any
    }

    /// Gratings N of the model (the packed state's size, [`MemoryState::packed_len`]).
    pub fn gratings(&self) -> usize {
        usize::from(self.gratings)
    }

    /// Whether `other` computes the same terms from the same coefficients (so that a state of
    /// one resumes the other).
    pub fn same_spec(&self, other: &Self) -> bool {
        // Every field: `any` follows from the others.
        self == other
    }

    /// The smoothing factors for Δt = `dt`, from the cache when Δt has not changed.
    #[inline(always)]
    fn refresh_alphas(&self, cache: &mut Smoothing<F>, dt: F) {
        // Bitwise-equal Δt reuses the factors (a fresh cache holds Δt = 0's, all 0).
        if dt != cache.dt {
            self.recompute_alphas(cache, dt);
        }
    }

    /// The smoothing factors for a new Δt: rare on a regular clock, so kept out of line.
    #[inline(never)]
    fn recompute_alphas(&self, cache: &mut Smoothing<F>, dt: F) {
        cache.dt = dt;
        for (i, (a, lp)) in cache.grating.iter_mut().zip(self.grating_lp.iter()).enumerate() {
            *a = if self.grating_on & (1 << i) != 0 { lp.alpha(dt) } else { F::ZERO };
        }
        for ((a, lp), &on) in cache.ambient.iter_mut().zip(self.ambient_lp.iter()).zip(self.ambient_on.iter()) {
            *a = if on { lp.alpha(dt) } else { F::ZERO };
        }
        if self.observer_on {
            let (lag, smooth) = self.observer.low_passes();
            cache.observer = [lag.alpha(dt), smooth.alpha(dt)];
        }
    }

    /// The grating temperature T_g [°C] the observer follows.
    #[inline(always)]
    fn grating_temperature(&self, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F) -> F {
        let (x, n) = affine_inputs(dl_pm, usize::from(self.gratings), self.ambient, t_amb_c);
        affine(&x, n, &self.observer_row)
    }

    /// Feed one finite sample (shifts Δλ \[pm\], ambient T_amb [°C], time t \[s\]) to the
    /// stream `state` and return the memory vector m (unused terms 0). The caller screens
    /// non-finite samples: they must not reach the operators (the compensator leaves the whole
    /// stream state untouched for them).
    #[inline]
    pub fn update(&self, state: &mut MemoryState<F>, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F, t_s: F) -> [F; MAX_MEMORY] {
        let mut m = [F::ZERO; MAX_MEMORY];
        self.run::<0>(state, dl_pm, t_amb_c, t_s, |k, v| {
            if let Some(o) = m.get_mut(k) {
                *o = v;
            }
        });
        m
    }

    /// [`MemoryOperators::update`] without the terms: moves the stream only (a checkpoint
    /// pass).
    #[inline]
    pub fn advance(&self, state: &mut MemoryState<F>, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F, t_s: F) {
        self.run::<0>(state, dl_pm, t_amb_c, t_s, |_, _| {});
    }

    /// [`MemoryOperators::update`] that adds Γm to `y` instead of returning m (`gamma[k][o]` is
    /// the coefficient of term k on output o, term-major so that one term updates every output
    /// at once; outputs a model does not have carry 0): what the compensator runs per sample,
    /// without the memory vector's round trip through memory.
    // Out of line: one copy per grating count `G` the step is compiled for (the paper's 3, and
    // 0: read from the model).
    #[inline(never)]
    pub fn accumulate<const O: usize, const G: usize>(
        &self,
        state: &mut MemoryState<F>,
        dl_pm: &[F; MAX_GRATINGS],
        t_amb_c: F,
        t_s: F,
        gamma: &[[F; O]; MAX_MEMORY],
        y: &mut [F; O],
    ) {
        // Summed in a local copy: the compiler keeps it in registers across the terms.
        let mut acc = *y;
        self.run::<G>(state, dl_pm, t_amb_c, t_s, |k, v| {
            if let Some(col) = gamma.get(k) {
                for (yo, &g) in acc.iter_mut().zip(col.iter()) {
                    *yo = g.mul_add(v, *yo);
                }
            }
        });
        *y = acc;
    }

    /// Move every operator by one sample and hand each used term to `sink(k, m_k)` in
    /// memory-vector order (unused terms are not handed over).
    #[inline(always)]
    fn run<const G: usize>(
        &self,
        st: &mut MemoryState<F>,
        dl_pm: &[F; MAX_GRATINGS],
        t_amb_c: F,
        t_s: F,
        mut sink: impl FnMut(usize, F),
    ) {
        if !self.any {
            return;
        }
        let t_g = if self.observer_on { self.grating_temperature(dl_pm, t_amb_c) } else { F::ZERO };
        // G > 0: the model's grating count known at compile time (the inner loops unrolled).
        let n = if G == 0 { usize::from(self.gratings) } else { G };
        let dl = head(dl_pm, n);
        // Memory-vector indices: the layout of `Dims` (grating high-passes, ambient, stop, observer).
        let mem_ambient = n * N_GRATING_TAUS;
        let mem_stop = mem_ambient + if self.ambient { N_AMBIENT_TAUS } else { 0 };
        let mem_observer = mem_stop + n * N_PLAYS;
        if !st.primed {
            for row in st.grating.iter_mut().chain(st.play.iter_mut()) {
                *row = *dl_pm;
            }
            st.ambient = [t_amb_c; N_AMBIENT_TAUS];
            DriftObserver::prime(&mut st.observer, t_g, t_amb_c);
            st.t_prev_s = t_s;
            // Only the model's gratings: slots beyond stay as a packed state leaves them.
            st.t_rev_s = [F::ZERO; MAX_GRATINGS];
            for t in st.t_rev_s.iter_mut().take(n) {
                *t = t_s;
            }
            st.dir = [F::ZERO; MAX_GRATINGS];
            st.primed = true;
            if self.observer_on {
                sink(mem_observer, st.observer[1]);
            }
            return;
        }
        let dt = t_s - st.t_prev_s;
        st.t_prev_s = t_s;
        self.refresh_alphas(&mut st.smoothing, dt);
        let alphas = &st.smoothing;
        // The time constants that are on, in order (a model often keeps none or a few).
        let mut on = self.grating_on;
        while on != 0 {
            let i = on.trailing_zeros() as usize;
            on &= on - 1;
            if let (Some(lp), Some(&a), Some(s)) =
                (self.grating_lp.get(i), alphas.grating.get(i), st.grating.get_mut(i))
            {
                for (j, (&x, si)) in dl.iter().zip(s.iter_mut()).enumerate() {
                    sink(i * n + j, x - lp.update(si, x, a));
                }
            }
        }
        for (k, (((lp, &on), &a), si)) in (mem_ambient..).zip(
            self.ambient_lp.iter().zip(self.ambient_on.iter()).zip(alphas.ambient.iter()).zip(st.ambient.iter_mut()),
        ) {
            if on {
                sink(k, t_amb_c - lp.update(si, t_amb_c, a));
            }
        }
        let mut k = mem_stop;
        for (slot, ((op, &on), s)) in self.plays.iter().zip(self.play_on.iter()).zip(st.play.iter_mut()).enumerate() {
            if on {
                let clocked = slot == usize::from(self.narrowest);
                for (j, (&x, si)) in dl.iter().zip(s.iter_mut()).enumerate() {
                    let before = *si;
                    sink(k + j, op.stop(si, x));
                    if clocked && *si != before {
                        quiet_clock(&mut st.t_rev_s, &mut st.dir, j, *si > before, t_s);
                    }
                }
            }
            k += n;
        }
        if self.observer_on {
            let v = self.observer.update(&mut st.observer, t_g, t_amb_c, alphas.observer);
            sink(mem_observer, v);
        }
    }
}

/// A move of grating `j`'s clocked play (`up`: towards larger Δλ) at `t_s`: a move against
/// the last one is a reversal and restarts the grating's quiet time.
#[inline(always)]
fn quiet_clock<F: Real>(t_rev_s: &mut [F; MAX_GRATINGS], dir: &mut [F; MAX_GRATINGS], j: usize, up: bool, t_s: F) {
    let d = if up { F::ONE } else { -F::ONE };
    if let (Some(t), Some(last)) = (t_rev_s.get_mut(j), dir.get_mut(j)) {
        if *last != F::ZERO && *last != d {
            *t = t_s;
        }
        *last = d;
    }
}
