//! The prepared model: every number a step reads, folded at load time, and nothing that a
//! stream moves.

use heapless::Vec;
use nalgebra::{ArrayStorage, SMatrix};

use super::gate::Gate;
use super::rbf::PreparedCentre;
use super::swing::Pace;
use crate::layout::{Dims, MAX_ENVELOPE, MAX_GRATINGS, MAX_MEMORY, MAX_OUTPUTS, MAX_POLY, MAX_STAGE1, MAX_Z};
use crate::memory::MemoryOperators;
use crate::real::Real;

/// A model in per-sample form, immutable while streams run: the folded coefficients, the
/// centres, the band, the envelope, the plausibility bounds and the memory operators'
/// coefficients. The state of a stream (direction latches, memory operators' state, the
/// stream's clock) is a [`super::StreamState`] kept apart, and
/// [`PreparedModel::step`] moves it (`step(&self, &mut state, &sample)`, as idsp's filters
/// `process(&self, &mut state, x)`): one model serves any number of streams, and a stream's
/// state can be checkpointed, resumed or persisted on its own.
///
/// ```
/// use fbg_shared::{FeatureSet, ModelParams, PreparedModel, Sample, StreamState};
/// # let params: ModelParams<f32, 8> =
/// #     fbg_testkit::models::model(8, 1, FeatureSet::HysteresisAware, Default::default());
/// let model = PreparedModel::<f32, 8>::new(&params)?;
/// let (mut a, mut b) = (StreamState::new(), StreamState::new());
/// let s = Sample::new([10.0, -5.0, 2.0], 21.0, 60.0);
/// assert_eq!(model.step(&mut a, &s), model.step(&mut b, &s)); // two streams, one model
/// let checkpoint = a; // `Copy`: a stream can be saved and resumed
/// let next = Sample::new([11.0, -5.0, 2.0], 21.0, 120.0);
/// let e = model.step(&mut a, &next);
/// let mut resumed = checkpoint;
/// assert_eq!(model.step(&mut resumed, &next), e);
/// # Ok::<(), fbg_shared::Error>(())
/// ```
///
/// `K` is the centre capacity; models with fewer centres load too and cost proportionally less.
/// Any [`Dims`] within the capacities of [`crate::layout`] loads; a sample whose grating count
/// differs from the model's is answered as non-finite.
/// `repr(C)`, the fields a step reads per output first and the large arrays last: a Cortex-M
/// float load reaches 1 020 bytes past its base, so the small fields stay one load away.
#[derive(Clone, Debug)]
#[repr(C)]
pub struct PreparedModel<F, const K: usize> {
    /// The model's dims ([`Dims::NONE`] before a model is loaded).
    pub(super) dims: Dims,
    /// Gratings N of the model (the step reads these three as bytes).
    pub(super) gratings: u8,
    /// Whether the model reads T_amb.
    pub(super) ambient: bool,
    /// M, outputs of the model.
    pub(super) outputs: u8,
    /// RBF inputs (used or not).
    pub(super) n_z: u8,
    /// Groups of four RBF inputs that hold them.
    pub(super) z_groups: u8,
    pub(super) uses_time: bool,
    pub(super) uses_latch: bool,
    /// Whether the band grows with time (the time input is then required).
    pub(super) band_grows: bool,
    pub(super) fitted: [bool; MAX_OUTPUTS],
    /// Latch dead band in ticks of 1/1024 pm.
    pub(super) dead_band: i32,
    pub(super) inv_g_tail: F,
    /// End of calibration on the calibration record's clock \[s\].
    pub(super) t_cal_end_s: F,
    /// The band's lead when the stream's clock is unknown \[s\].
    pub(super) lead_max_s: F,
    pub(super) weak_support: F,
    pub(super) flagged_band_factor: F,
    /// k² · s² per output at the end of calibration.
    pub(super) band_var: [F; MAX_OUTPUTS],
    /// k² · ds²/dt per output [unit²/s].
    pub(super) band_var_growth: [F; MAX_OUTPUTS],
    /// The band Model-H fades to: Model-P's k²σ² and its growth per second.
    pub(super) fallback_var: [F; MAX_OUTPUTS],
    pub(super) fallback_var_growth: [F; MAX_OUTPUTS],
    /// Plausible range of each output's estimate (±∞ for outputs unchecked or not fitted).
    pub(super) out_lo: [F; MAX_OUTPUTS],
    pub(super) out_hi: [F; MAX_OUTPUTS],
    /// Each output's band must stay below this before widening (∞: only finite).
    pub(super) band_lim: [F; MAX_OUTPUTS],
    pub(super) env_lo: [F; MAX_ENVELOPE],
    pub(super) env_hi: [F; MAX_ENVELOPE],
    /// Each grating's largest quiet time of the calibration \[s\]; 0 = no fade.
    pub(super) quiet_max_s: [F; MAX_GRATINGS],
    /// Which samples may move the memory state ([`crate::trust`]); off without a stream state
    /// worth keeping (no memory terms, no latches).
    pub(super) gate: Gate<F>,
    /// The calibration's pace ([`crate::trust`]); off without a gate.
    pub(super) pace: Pace<F>,
    /// z_scaled = x · z_gain + z_offset (gain 0 on unused dimensions).
    pub(super) z_gain: [F; MAX_Z],
    pub(super) z_offset: [F; MAX_Z],
    /// Absolute end of calibration (Unix s), when the model knows it.
    pub(super) cal_end_unix_s: Option<f64>,
    /// Stage-1 rows producing *standardised* guesses.
    pub(super) a: [[F; MAX_STAGE1]; MAX_OUTPUTS],
    /// B of paper Eq. 3, one row per output over φ's terms (column-major, as nalgebra keeps it).
    pub(super) b: SMatrix<F, MAX_OUTPUTS, MAX_POLY>,
    /// The memory operators (coefficients; their state is the stream's).
    pub(super) memory: MemoryOperators<F>,
    /// Γ (output units per memory-term unit), term-major: `gamma[k][o]`.
    pub(super) gamma: [[F; MAX_OUTPUTS]; MAX_MEMORY],
    pub(super) centres: Vec<PreparedCentre<F>, K>,
}

impl<F: Real, const K: usize> PreparedModel<F, K> {
    /// A model slot with no model loaded, usable in a `static` that
    /// [`PreparedModel::reload`] then fills in place (so a device never builds a model-sized
    /// value on its stack): all zero bytes. Until a model is loaded it has no output (0
    /// gratings, M = 0) and answers every sample as non-finite.
    pub const fn unloaded() -> Self {
        PreparedModel {
            dims: Dims::NONE,
            gratings: 0,
            ambient: false,
            outputs: 0,
            n_z: 0,
            z_groups: 0,
            a: [[F::ZERO; MAX_STAGE1]; MAX_OUTPUTS],
            b: SMatrix::from_array_storage(ArrayStorage([[F::ZERO; MAX_OUTPUTS]; MAX_POLY])),
            gamma: [[F::ZERO; MAX_OUTPUTS]; MAX_MEMORY],
            memory: MemoryOperators::off(),
            z_gain: [F::ZERO; MAX_Z],
            z_offset: [F::ZERO; MAX_Z],
            centres: Vec::new(),
            inv_g_tail: F::ZERO,
            band_var: [F::ZERO; MAX_OUTPUTS],
            band_var_growth: [F::ZERO; MAX_OUTPUTS],
            t_cal_end_s: F::ZERO,
            cal_end_unix_s: None,
            lead_max_s: F::ZERO,
            band_grows: false,
            env_lo: [F::ZERO; MAX_ENVELOPE],
            env_hi: [F::ZERO; MAX_ENVELOPE],
            // Zero bytes, as the rest (never read before a model is loaded).
            out_lo: [F::ZERO; MAX_OUTPUTS],
            out_hi: [F::ZERO; MAX_OUTPUTS],
            band_lim: [F::ZERO; MAX_OUTPUTS],
            weak_support: F::ZERO,
            // Never read before a model is loaded (no output is fitted); 0 keeps the value all
            // zero bytes, so a `static` of it lands in `.bss` and costs no flash.
            flagged_band_factor: F::ZERO,
            dead_band: 0,
            uses_time: false,
            uses_latch: false,
            fitted: [false; MAX_OUTPUTS],
            gate: Gate::off(),
            quiet_max_s: [F::ZERO; MAX_GRATINGS],
            fallback_var: [F::ZERO; MAX_OUTPUTS],
            fallback_var_growth: [F::ZERO; MAX_OUTPUTS],
            pace: Pace::off(),
        }
    }

    /// The model's dims (N gratings, ambient input, M outputs in output order); `None` when no
    /// model is loaded.
    pub fn dims(&self) -> Option<Dims> {
        (self.gratings > 0).then_some(self.dims)
    }

    /// Number of RBF centres in use.
    pub fn n_centres(&self) -> usize {
        self.centres.len()
    }

    /// Whether the model has memory terms (Γm in the core).
    pub fn has_memory(&self) -> bool {
        self.memory.is_active()
    }

    /// The memory operators (coefficients only).
    pub fn memory(&self) -> &MemoryOperators<F> {
        &self.memory
    }

    /// Whether `other` moves a stream state exactly as this one does on every sample (same
    /// dead band, same memory operators, same rule for which samples are finite, same gate and
    /// pace), so that a state of one can resume the other.
    pub fn same_stream<const K2: usize>(&self, other: &PreparedModel<F, K2>) -> bool {
        self.dead_band == other.dead_band
            && self.gate == other.gate
            && self.pace == other.pace
            && self.gratings == other.gratings
            && self.ambient == other.ambient
            && self.memory.same_spec(&other.memory)
            && self.needs_time() == other.needs_time()
    }

    /// Whether the model reads the time input (feature set, growing band or memory terms).
    #[inline(always)]
    pub(super) fn needs_time(&self) -> bool {
        self.uses_time || self.band_grows || self.memory.is_active()
    }

    /// N: `G` when the step is specialised for it, the model's otherwise (`G` = 0).
    #[inline(always)]
    pub(super) fn g<const G: usize>(&self) -> usize {
        if G == 0 {
            usize::from(self.gratings)
        } else {
            G
        }
    }

    /// M: `M` when the step is specialised for it, the model's otherwise (`M` = 0).
    #[inline(always)]
    pub(super) fn m<const M: usize>(&self) -> usize {
        if M == 0 {
            usize::from(self.outputs)
        } else {
            M
        }
    }
}
