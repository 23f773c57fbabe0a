//! The stream state of the memory operators: what a checkpoint of a stream keeps.

use crate::error::Error;
use crate::layout::{head, MAX_GRATINGS, N_AMBIENT_TAUS, N_GRATING_TAUS, N_PLAYS};
use crate::real::Real;

/// The stream state of the memory operators ([`MemoryOperators`]): every low-pass and play
/// position, the observer and the last sample time (sized to the capacity of [`MAX_GRATINGS`]
/// gratings); `Copy`, so a stream can be checkpointed and resumed.
///
/// It also carries the smoothing factors of the last Δt, a cache that the
/// operators fill and that changes no value: it is neither packed nor compared.
///
/// [`MemoryOperators`]: crate::memory::MemoryOperators
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MemoryState<F> {
    pub(super) grating: [[F; MAX_GRATINGS]; N_GRATING_TAUS],
    pub(super) ambient: [F; N_AMBIENT_TAUS],
    pub(super) play: [[F; MAX_GRATINGS]; N_PLAYS],
    pub(super) observer: [F; 2],
    pub(super) t_prev_s: F,
    /// Per grating, when its narrowest play operator last reversed \[s\] (the start of its
    /// quiet time, [`crate::trust`]), and the direction of that play's last move (−1, 0, +1).
    pub(super) t_rev_s: [F; MAX_GRATINGS],
    pub(super) dir: [F; MAX_GRATINGS],
    pub(super) primed: bool,
    pub(super) smoothing: Smoothing<F>,
}

/// The smoothing factors α of every low-pass for the last Δt, so that a regularly sampled
/// stream costs no exponential per step: recomputed only when Δt changes.
///
/// A cache, not state: the factors are a function of the operators' τ and of Δt, so any two
/// compare equal. It starts at Δt = 0 with every factor 0, which is what
/// [`crate::memory::smoothing_factor`] gives for Δt = 0 whatever τ (and keeps a fresh state all
/// zero bytes). It is valid for the operators that filled it, and for any with the same
/// coefficients ([`crate::memory::MemoryOperators::same_spec`]): a state resumes only those.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Smoothing<F> {
    /// Δt of the cached factors \[s\].
    pub(super) dt: F,
    pub(super) grating: [F; N_GRATING_TAUS],
    pub(super) ambient: [F; N_AMBIENT_TAUS],
    pub(super) observer: [F; 2],
}

impl<F: Real> Smoothing<F> {
    const fn new() -> Self {
        Smoothing {
            dt: F::ZERO,
            grating: [F::ZERO; N_GRATING_TAUS],
            ambient: [F::ZERO; N_AMBIENT_TAUS],
            observer: [F::ZERO; 2],
        }
    }
}

impl<F> PartialEq for Smoothing<F> {
    /// Always: a cache is no part of the stream (see [`Smoothing`]).
    fn eq(&self, _: &Self) -> bool {
        true
    }
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
            t_rev_s: [F::ZERO; MAX_GRATINGS],
            dir: [F::ZERO; MAX_GRATINGS],
            primed: false,
            smoothing: Smoothing::new(),
        }
    }
}

impl<F: Real> MemoryState<F> {
    /// The quiet time of grating `g` at `t_s` \[s\]: how long its narrowest play operator has
    /// not reversed ([`crate::trust`]); 0 before the first sample and beyond the capacity.
    #[inline(always)]
    pub fn quiet_s(&self, g: usize, t_s: F) -> F {
        match self.t_rev_s.get(g) {
            Some(&t) if self.primed => (t_s - t).max(F::ZERO),
            _ => F::ZERO,
        }
    }

    /// Numbers in the packed form of the state of a bank over `gratings` gratings
    /// ([`MemoryState::pack`]): every low-pass and play position of those gratings, the ambient
    /// low-passes, the observer's two stages, the last sample time and whether the bank is primed, then
    /// per grating when its narrowest play last reversed and the direction of its last move.
    pub const fn packed_len(gratings: usize) -> usize {
        gratings * (N_GRATING_TAUS + N_PLAYS + 2) + N_AMBIENT_TAUS + 4
    }

    /// Write the state of the first `gratings` gratings into `out` (exactly
    /// [`MemoryState::packed_len`] numbers, exact in any precision): a checkpoint of a long
    /// stream at the model's own size instead of the capacity's. Slots beyond `gratings` are not
    /// kept (a bank over `gratings` never reads them).
    pub fn pack(&self, gratings: usize, out: &mut [F]) -> Result<(), Error> {
        let n = Self::check_packed(gratings, out.len())?;
        let rows = self.grating.iter().chain(self.play.iter()).chain([&self.t_rev_s, &self.dir]);
        let (mut cells, rest) = out.split_at_mut(n * (N_GRATING_TAUS + N_PLAYS + 2));
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
    /// over `gratings` never reads them), and so is the smoothing cache. Nothing is written
    /// when `from` is refused.
    pub fn unpack_into(&mut self, gratings: usize, from: &[F]) -> Result<(), Error> {
        let n = Self::check_packed(gratings, from.len())?;
        let s = self;
        let (mut cells, rest) = from.split_at(n * (N_GRATING_TAUS + N_PLAYS + 2));
        for row in s.grating.iter_mut().chain(s.play.iter_mut()).chain([&mut s.t_rev_s, &mut s.dir]) {
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
