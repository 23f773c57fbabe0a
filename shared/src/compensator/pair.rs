//! The convenient pair: one model with the state of one stream.

use super::estimate::Estimate;
use super::prepared::PreparedModel;
use super::sample::Sample;
use super::state::StreamState;
use crate::clock::StreamClock;
use crate::error::Error;
use crate::layout::Dims;
use crate::model::ModelParams;
use crate::real::Real;

/// A loaded model with the state of one stream, ready to compensate samples: a
/// [`PreparedModel`] and its [`StreamState`] (what a device or a command-line run holds).
///
/// ```
/// use fbg_shared::{Compensator, FeatureSet, ModelParams, Sample};
/// # let params: ModelParams<f32, 8> =
/// #     fbg_testkit::models::model(8, 1, FeatureSet::HysteresisAware, Default::default());
/// // `params`: a trained model, e.g. `fbg_shared::blob::decode(&bytes)?`.
/// let mut comp = Compensator::<f32, 8>::new(&params)?;
/// let e = comp.step(&Sample::new([10.0, -5.0, 2.0], 21.0, 60.0));
/// assert_eq!(e.values().len(), 3); // the model's M outputs
/// assert!(e.values().iter().chain(e.band().iter()).all(|v| v.is_finite()));
/// // A non-finite input is flagged, never a panic.
/// let bad = comp.step(&Sample::new([f32::NAN, 0.0, 0.0], 21.0, 120.0));
/// assert!(bad.flags.contains(fbg_shared::Flags::NON_FINITE));
/// comp.reset(); // a new acquisition
/// # Ok::<(), fbg_shared::Error>(())
/// ```
///
/// `K` is the centre capacity (see [`PreparedModel`]).
#[derive(Clone, Debug)]
// The state first: the step reaches it, the latches and the memory operators' state, with
// short offsets from the compensator's address (the model behind it is several KiB).
#[repr(C)]
pub struct Compensator<F, const K: usize> {
    state: StreamState<F>,
    model: PreparedModel<F, K>,
}

impl<F: Real, const K: usize> Compensator<F, K> {
    /// A compensator for `params` (any scalar type and capacity), validated and folded
    /// ([`PreparedModel::new`]), on a stream that has seen no sample.
    pub fn new<G: Real, const K2: usize>(params: &ModelParams<G, K2>) -> Result<Self, Error> {
        Ok(Compensator { state: StreamState::new(), model: PreparedModel::new(params)? })
    }

    /// A compensator with no model loaded, usable in a `static` that [`Compensator::reload`]
    /// then fills in place (so a device never builds a compensator-sized value on its stack):
    /// all zero bytes. Until a model is loaded it has no output (0 gratings, M = 0) and answers
    /// every sample as non-finite.
    pub const fn unloaded() -> Self {
        Compensator { state: StreamState::new(), model: PreparedModel::unloaded() }
    }

    /// Replace the model in place, atomically: `params` is validated and every folded number
    /// checked first; on error the compensator keeps its old model and stream state. On
    /// success the stream state (direction latches, memory operators) is reset; the clock
    /// stays, its lead now from the new model.
    pub fn reload<G: Real, const K2: usize>(&mut self, params: &ModelParams<G, K2>) -> Result<(), Error> {
        self.model.reload(params)?;
        self.restart();
        Ok(())
    }

    /// [`Compensator::reload`] from a blob ([`PreparedModel::reload_blob`]): what a device does
    /// to load a model.
    pub fn reload_blob(&mut self, bytes: &[u8]) -> Result<(), Error> {
        self.model.reload_blob(bytes)?;
        self.restart();
        Ok(())
    }

    /// After a new model: a stream that has seen no sample, on the same clock.
    fn restart(&mut self) {
        self.state.reset();
        let clock = self.state.clock();
        self.model.set_clock(&mut self.state, clock);
    }

    /// The model.
    pub fn model(&self) -> &PreparedModel<F, K> {
        &self.model
    }

    /// The stream state (copy it to checkpoint the stream).
    pub fn state(&self) -> &StreamState<F> {
        &self.state
    }

    /// The model and the stream state apart, for a caller that moves the state by some samples
    /// ([`PreparedModel::begin_batch`]) while it ends others ([`PreparedModel::end_batch`],
    /// which reads the model only).
    pub fn parts_mut(&mut self) -> (&PreparedModel<F, K>, &mut StreamState<F>) {
        (&self.model, &mut self.state)
    }

    /// The model's dims; `None` when no model is loaded.
    pub fn dims(&self) -> Option<Dims> {
        self.model.dims()
    }

    /// Number of RBF centres in use.
    pub fn n_centres(&self) -> usize {
        self.model.n_centres()
    }

    /// Whether the model has memory terms (Γm in the core).
    pub fn has_memory(&self) -> bool {
        self.model.has_memory()
    }

    /// Forget the stream state (direction latches, memory operators) before a new acquisition.
    pub fn reset(&mut self) {
        self.state.reset();
    }

    /// Say how this stream's `t_s` relates to the end of calibration
    /// ([`PreparedModel::set_clock`]; kept across [`Compensator::reset`] and model reloads; a
    /// new compensator's clock is [`StreamClock::Unknown`]).
    ///
    /// ```
    /// use fbg_shared::{Compensator, FeatureSet, Flags, ModelParams, Sample, StreamClock};
    /// # let mut params: ModelParams<f32, 8> =
    /// #     fbg_testkit::models::model(8, 1, FeatureSet::HysteresisAware, Default::default());
    /// # params.resid_var_growth[0] = 1e-6;
    /// params.field.cal_end_unix_s = Some(1.7e9);
    /// let mut comp = Compensator::<f64, 8>::new(&params)?;
    /// let s = Sample::new([10.0, -5.0, 2.0], 21.0, 60.0);
    /// assert!(comp.step(&s).flags.contains(Flags::LEAD_UNKNOWN));
    /// comp.set_clock(StreamClock::StartUnix(1.7e9 + 86_400.0)); // a day after calibration
    /// assert_eq!(comp.lead_s(60.0), Some(86_460.0));
    /// assert!(!comp.step(&s).flags.contains(Flags::LEAD_UNKNOWN));
    /// # Ok::<(), fbg_shared::Error>(())
    /// ```
    pub fn set_clock(&mut self, clock: StreamClock) {
        self.model.set_clock(&mut self.state, clock);
    }

    /// The stream's clock as last set.
    pub fn clock(&self) -> StreamClock {
        self.state.clock()
    }

    /// The lead time \[s\] since the end of calibration of a sample at `t_s` on this stream's
    /// clock (at least 0), `None` when the clock does not give it.
    pub fn lead_s(&self, t_s: F) -> Option<F> {
        self.state.lead_s(t_s)
    }

    /// Compensate one sample ([`PreparedModel::step`]). Never panics: non-finite inputs give
    /// NaN values, an infinite band and [`crate::Flags::NON_FINITE`], leaving the stream state
    /// untouched.
    #[inline]
    pub fn step(&mut self, s: &Sample<F>) -> Estimate<F> {
        self.model.step(&mut self.state, s)
    }

    /// Compensate `samples` in order into `out` ([`PreparedModel::step_batch`]): bit for bit
    /// what [`Compensator::step`] gives sample after sample, the RBF pass run over several
    /// samples at once. Returns how many were compensated (the shorter slice's length).
    #[inline(always)]
    pub fn step_batch(&mut self, samples: &[Sample<F>], out: &mut [Estimate<F>]) -> usize {
        self.model.step_batch(&mut self.state, samples, out)
    }

    /// [`PreparedModel::begin_batch`] on this compensator's stream.
    #[inline(always)]
    pub fn begin_batch(&mut self, samples: &[Sample<F>], pending: &mut [super::Pending<F>]) -> usize {
        self.model.begin_batch(&mut self.state, samples, pending)
    }

    /// [`PreparedModel::end_batch`]: the estimates of samples begun by
    /// [`Compensator::begin_batch`]; moves no state (callable from several threads at once).
    #[inline(always)]
    pub fn end_batch(&self, samples: &[Sample<F>], pending: &[super::Pending<F>], out: &mut [Estimate<F>]) -> usize {
        self.model.end_batch(samples, pending, out)
    }

    /// [`Compensator::step`] that also hands each RBF activation ψ_j to `sink(j, ψ_j)`
    /// ([`PreparedModel::step_with`]).
    #[inline(always)]
    pub fn step_with(&mut self, s: &Sample<F>, sink: impl FnMut(usize, F)) -> Estimate<F> {
        self.model.step_with(&mut self.state, s, sink)
    }
}
