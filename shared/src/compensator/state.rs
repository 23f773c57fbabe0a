//! The state of one sample stream: what a step moves, and the stream's clock.

use super::gate::GateState;
use super::prepared::PreparedModel;
use crate::clock::StreamClock;
use crate::direction_latch::LatchBank;
use crate::error::Error;
use crate::layout::MAX_GRATINGS;
use crate::memory::MemoryState;
use crate::real::Real;

/// The state of one stream of samples through a [`PreparedModel`]. `Copy`, so a stream can be
/// checkpointed, resumed (by any model for which [`PreparedModel::same_stream`] holds) or
/// persisted.
///
/// Two parts:
/// - what the samples moved: the direction latches and the memory operators' state (with the
///   cache of their smoothing factors, which changes no value);
///   [`StreamState::reset`] forgets it;
/// - the stream's clock ([`StreamClock`], set by [`PreparedModel::set_clock`]) with the lead
///   offset it gives for the model that set it: it belongs to the stream, not to the model
///   (one model serves streams on different clocks), and is kept by `reset` (a new acquisition
///   on the same clock). After the model changes, set the clock again
///   ([`crate::Compensator`] does).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StreamState<F> {
    latches: LatchBank,
    memory: MemoryState<F>,
    /// The last sample the gate let into the memory state ([`crate::trust`]).
    gate: GateState<F>,
    /// The stream's clock, as set.
    clock: StreamClock,
    /// lead = `t_s` + this offset; `None`: the lead is unknown.
    lead_offset_s: Option<F>,
}

impl<F: Real> StreamState<F> {
    /// A stream that has seen no sample, on an unknown clock: all zero bytes.
    pub const fn new() -> Self {
        StreamState {
            latches: LatchBank::new(),
            memory: MemoryState::new(),
            gate: GateState::new(),
            clock: StreamClock::Unknown,
            lead_offset_s: None,
        }
    }

    /// Forget the samples (direction latches, memory operators) before a new acquisition; the
    /// clock stays.
    pub fn reset(&mut self) {
        self.latches.reset();
        self.memory = MemoryState::new();
        self.gate = GateState::new();
    }

    /// The direction latches.
    pub fn latches(&self) -> LatchBank {
        self.latches
    }

    /// Current direction-latch values (−1, 0, +1 per grating; 0 beyond N).
    pub fn latch_values(&self) -> [F; MAX_GRATINGS] {
        self.latches.values()
    }

    /// The memory operators' state (see [`MemoryState::pack`] for a compact copy).
    pub fn memory(&self) -> &MemoryState<F> {
        &self.memory
    }

    /// The stream's clock as last set.
    pub fn clock(&self) -> StreamClock {
        self.clock
    }

    /// The lead time \[s\] since the end of calibration of a sample at `t_s` on this stream's
    /// clock (at least 0), `None` when the clock does not give it.
    #[inline(always)]
    pub fn lead_s(&self, t_s: F) -> Option<F> {
        self.lead_offset_s.map(|o| (t_s + o).max(F::ZERO))
    }

    /// The lead offset (lead = `t_s` + offset), `None` when unknown.
    #[inline(always)]
    pub(super) fn lead_offset_s(&self) -> Option<F> {
        self.lead_offset_s
    }

    /// The latches and the memory operators' state, for the step to move.
    #[inline(always)]
    pub(super) fn moving(&mut self) -> (&mut LatchBank, &mut MemoryState<F>) {
        (&mut self.latches, &mut self.memory)
    }

    /// What the gate remembers (the last sample let in, the pace), for a checkpoint: a state
    /// resumed from packed memory ([`PreparedModel::resume_packed`]) starts its gate over,
    /// [`StreamState::resume_gate`] puts this back.
    pub fn gate_state(&self) -> GateState<F> {
        self.gate
    }

    /// Put back what the gate remembered ([`StreamState::gate_state`]) of the same stream,
    /// through a model with the same gate ([`PreparedModel::same_stream`]).
    pub fn resume_gate(&mut self, gate: GateState<F>) {
        self.gate = gate;
    }

    /// The gate's memory of the last sample let in.
    #[inline(always)]
    pub(super) fn gate(&self) -> &GateState<F> {
        &self.gate
    }

    /// The same, to move.
    #[inline(always)]
    pub(super) fn gate_mut(&mut self) -> &mut GateState<F> {
        &mut self.gate
    }
}

impl<F: Real, const K: usize> PreparedModel<F, K> {
    /// Say how `state`'s stream's `t_s` relates to this model's end of calibration (kept
    /// across [`StreamState::reset`]; a new state's clock is [`StreamClock::Unknown`]). With
    /// an unknown lead (no clock, or an absolute start and a model without an absolute end of
    /// calibration) the band takes the largest lead the calibration validated and every
    /// estimate of a model whose band grows carries [`crate::Flags::LEAD_UNKNOWN`].
    pub fn set_clock(&self, state: &mut StreamState<F>, clock: StreamClock) {
        state.clock = clock;
        state.lead_offset_s = match clock {
            StreamClock::Calibration => Some(-self.t_cal_end_s),
            // In this precision: f64 arithmetic would cost an f32 device soft-float routines,
            // and the rounding of Unix seconds in f32 (< 128 s) is nothing against a band that
            // grows over days.
            StreamClock::StartUnix(start) => {
                self.cal_end_unix_s.map(|end| F::from_f64(start) - F::from_f64(end)).filter(|o| o.is_finite())
            }
            StreamClock::Unknown => None,
        };
    }

    /// Put `state` where a compact checkpoint says its stream was: the latches and the memory
    /// operators packed by [`MemoryState::pack`] at this model's grating count (empty for a
    /// model without memory terms); the clock stays. Nothing changes when `memory` is refused.
    pub fn resume_packed(&self, state: &mut StreamState<F>, latches: LatchBank, memory: &[F]) -> Result<(), Error> {
        if self.memory.is_active() || !memory.is_empty() {
            state.memory.unpack_into(self.memory.gratings(), memory)?;
        }
        state.latches = latches;
        // The gate starts over: its range test holds at once, its rate test from the next
        // sample let in.
        state.gate = GateState::new();
        Ok(())
    }
}
