//! Every memory operator of a model over one sample stream: the operators with one state.

use crate::error::Error;
use crate::layout::{Dims, MAX_GRATINGS, MAX_MEMORY};
use crate::memory::{MemoryOperators, MemorySpec, MemoryState};
use crate::real::Real;

/// The memory operators of a [`MemorySpec`] ([`MemoryOperators`]) with the state of one stream
/// ([`MemoryState`]): the convenient pair for a single stream.
///
/// [`MemoryBank::update`] takes one sample and returns the memory vector m (see
/// [`MemoryOperators`] for the start, gaps and cost).
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
    operators: MemoryOperators<F>,
    state: MemoryState<F>,
}

impl<F: Real> MemoryBank<F> {
    /// A bank with no operator in use (every term 0), usable in a `static`: all its bytes are
    /// zero.
    pub const fn off() -> Self {
        MemoryBank { operators: MemoryOperators::off(), state: MemoryState::new() }
    }

    /// A bank for `spec` (any precision; converted here) of a model with `dims` that has seen
    /// no sample. Slots the dims do not have (ambient, observer) stay off.
    pub fn new<G: Real>(spec: &MemorySpec<G>, dims: &Dims) -> Self {
        MemoryBank { operators: MemoryOperators::new(spec, dims), state: MemoryState::new() }
    }

    /// The operators (coefficients only).
    pub fn operators(&self) -> &MemoryOperators<F> {
        &self.operators
    }

    /// Whether the bank computes any term (otherwise [`MemoryBank::update`] returns zeros).
    pub fn is_active(&self) -> bool {
        self.operators.is_active()
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
        self.state.unpack_into(self.operators.gratings(), from)
    }

    /// Forget the stream.
    pub fn reset(&mut self) {
        self.state = MemoryState::new();
    }

    /// Whether `other` computes the same terms from the same coefficients (so that a state of
    /// one resumes the other).
    pub fn same_spec(&self, other: &Self) -> bool {
        self.operators.same_spec(&other.operators)
    }

    /// Feed one finite sample and return the memory vector m ([`MemoryOperators::update`]).
    #[inline]
    pub fn update(&mut self, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F, t_s: F) -> [F; MAX_MEMORY] {
        self.operators.update(&mut self.state, dl_pm, t_amb_c, t_s)
    }

    /// [`MemoryBank::update`] without the terms: moves the stream only (a checkpoint pass).
    #[inline]
    pub fn advance(&mut self, dl_pm: &[F; MAX_GRATINGS], t_amb_c: F, t_s: F) {
        self.operators.advance(&mut self.state, dl_pm, t_amb_c, t_s);
    }
}
