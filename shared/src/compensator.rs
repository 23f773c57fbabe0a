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
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::clock::StreamClock;
use crate::direction_latch::LatchBank;
use crate::error::Error;
use crate::flags::Flags;
use crate::layout::{head, MAX_ENVELOPE, MAX_GRATINGS, MAX_MEMORY, MAX_OUTPUTS, MAX_POLY, MAX_STAGE1, MAX_Z, VAR_RANK};
use crate::memory::bank::{affine, affine_inputs};
use crate::memory::{MemoryBank, MemoryState};
use crate::model::{Centre, ModelParams};
use crate::real::Real;

/// One measured sample: the shifts of its gratings, the ambient temperature and the time.
///
/// `dl_pm` holds up to [`MAX_GRATINGS`] shifts of which the first `gratings` are the sample's
/// (the rest are 0); a model answers a sample with another grating count as non-finite. A model
/// without an ambient input ignores `t_amb_c` (send NaN); a model with one needs it finite.
///
/// On the link (postcard, [`crate::protocol`]) a sample is its `gratings` shifts (a length and
/// the values), then T_amb and t: the model's N values, not the capacity.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sample<F> {
    /// Measured wavelength shifts Δλ_1..N \[pm\] (the rest 0).
    pub dl_pm: [F; MAX_GRATINGS],
    /// N, the number of shifts in `dl_pm`.
    pub gratings: u8,
    /// Ambient reference temperature T_amb [°C] (NaN, and ignored, without an ambient input).
    pub t_amb_c: F,
    /// Time on the calibration clock \[s\] (used by feature sets with time, by a band that
    /// grows after calibration and by the memory terms).
    pub t_s: F,
}

impl<F: Real> Sample<F> {
    /// A sample of `N` gratings (at most [`MAX_GRATINGS`], checked at compile time).
    ///
    /// ```
    /// use fbg_shared::Sample;
    /// let s = Sample::new([0.1f64, 2.0, -3.0], 20.0, 60.0);
    /// assert_eq!((s.gratings, s.dl(), s.dl_pm[3]), (3, &[0.1, 2.0, -3.0][..], 0.0));
    /// ```
    pub fn new<const N: usize>(dl_pm: [F; N], t_amb_c: F, t_s: F) -> Self {
        const { assert!(N <= MAX_GRATINGS, "more gratings than MAX_GRATINGS") };
        Sample { dl_pm: crate::layout::pad(&dl_pm), gratings: N as u8, t_amb_c, t_s }
    }

    /// A sample from a slice of shifts; more than [`MAX_GRATINGS`] is
    /// [`Error::OverCapacity`].
    pub fn from_slice(dl_pm: &[F], t_amb_c: F, t_s: F) -> Result<Self, Error> {
        if dl_pm.len() > MAX_GRATINGS {
            return Err(Error::OverCapacity {
                field: "gratings",
                found: u16::try_from(dl_pm.len()).unwrap_or(u16::MAX),
                capacity: MAX_GRATINGS as u16,
            });
        }
        let mut d = [F::ZERO; MAX_GRATINGS];
        for (o, &v) in d.iter_mut().zip(dl_pm.iter()) {
            *o = v;
        }
        Ok(Sample { dl_pm: d, gratings: dl_pm.len() as u8, t_amb_c, t_s })
    }

    /// Whether the shifts and the ambient temperature are finite: what a model with an ambient
    /// input reads (one that reads time also needs a finite `t_s`; one without ambient ignores
    /// `t_amb_c`).
    #[inline(always)]
    pub fn inputs_finite(&self) -> bool {
        self.dl().iter().all(|v| v.is_finite()) && self.t_amb_c.is_finite()
    }

    /// The sample's shifts (the first `gratings` of `dl_pm`).
    pub fn dl(&self) -> &[F] {
        head(&self.dl_pm, usize::from(self.gratings))
    }

    /// The sample in another precision: exact from f32 to f64 (how a host replays what a
    /// device received), rounded to nearest from f64 to f32 (what a device receives).
    ///
    /// ```
    /// use fbg_shared::Sample;
    /// let host = Sample::new([0.1f64, 2.0, -3.0], 20.0, 60.0);
    /// let device: Sample<f32> = host.cast();
    /// assert_eq!(device.dl_pm[0], 0.1f32);
    /// assert_eq!(device.cast::<f64>().dl_pm[0], f64::from(0.1f32));
    /// ```
    pub fn cast<G: Real>(&self) -> Sample<G> {
        Sample {
            dl_pm: self.dl_pm.map(G::from_real),
            gratings: self.gratings,
            t_amb_c: G::from_real(self.t_amb_c),
            t_s: G::from_real(self.t_s),
        }
    }
}

impl<F: Real + Serialize> Serialize for Sample<F> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.dl(), self.t_amb_c, self.t_s).serialize(s)
    }
}

impl<'de, F: Real + Deserialize<'de>> Deserialize<'de> for Sample<F> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (dl, t_amb_c, t_s): (Vec<F, MAX_GRATINGS>, F, F) = Deserialize::deserialize(d)?;
        let mut dl_pm = [F::ZERO; MAX_GRATINGS];
        for (o, &v) in dl_pm.iter_mut().zip(dl.iter()) {
            *o = v;
        }
        Ok(Sample { dl_pm, gratings: dl.len() as u8, t_amb_c, t_s })
    }
}

/// One compensated estimate: the model's M values and bands (in its output order and units)
/// and the flags. Entries beyond M are 0 (use [`Estimate::values`] and [`Estimate::band`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Estimate<F> {
    /// One value per output (unit of the output).
    pub values: [F; MAX_OUTPUTS],
    /// Half-width of the 95 % band, same units (infinite for non-finite input).
    pub band95: [F; MAX_OUTPUTS],
    /// M, the number of outputs.
    pub outputs: u8,
    /// Fault flags.
    pub flags: Flags,
}

impl<F: Real> Estimate<F> {
    /// The M values.
    pub fn values(&self) -> &[F] {
        head(&self.values, usize::from(self.outputs))
    }
    /// The M band half-widths.
    pub fn band(&self) -> &[F] {
        head(&self.band95, usize::from(self.outputs))
    }
    /// The answer to a sample the model cannot read: NaN values, infinite band, `flags`.
    fn refused(outputs: u8, flags: Flags) -> Self {
        let mut e = Estimate { values: [F::ZERO; MAX_OUTPUTS], band95: [F::ZERO; MAX_OUTPUTS], outputs, flags };
        let m = usize::from(outputs);
        for (v, b) in e.values.iter_mut().zip(e.band95.iter_mut()).take(m) {
            *v = F::NAN;
            *b = F::INFINITY;
        }
        e
    }
}

impl<F: Real + Serialize> Serialize for Estimate<F> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.values(), self.band(), self.flags).serialize(s)
    }
}

impl<'de, F: Real + Deserialize<'de>> Deserialize<'de> for Estimate<F> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (v, b, flags): (Vec<F, MAX_OUTPUTS>, Vec<F, MAX_OUTPUTS>, Flags) = Deserialize::deserialize(d)?;
        let mut e = Estimate::refused(v.len() as u8, flags);
        for (o, &x) in e.values.iter_mut().zip(v.iter()) {
            *o = x;
        }
        for (o, &x) in e.band95.iter_mut().zip(b.iter()) {
            *o = x;
        }
        Ok(e)
    }
}

/// RBF inputs in per-sample form: [`MAX_Z`] rounded up to whole groups of four, so that the
/// distance runs four inputs at a time (the padding is zero in both z and μ: exact).
const ZP: usize = MAX_Z.div_ceil(4) * 4;

/// A centre in per-sample form.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct PreparedCentre<F> {
    /// −2μ_j/(σ√2) (0 on unused inputs): ‖z − μ‖² = ‖z‖² + ‖μ‖² + z·(−2μ) in scaled units.
    m2: [F; ZP],
    /// ‖μ_j/(σ√2)‖².
    mu_sq: F,
    w: [F; MAX_OUTPUTS],
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

impl<F: Real> StreamState<F> {
    /// The direction latches.
    pub fn latches(&self) -> LatchBank {
        self.latches
    }

    /// The memory operators' state (see [`MemoryState::pack`] for a compact copy).
    pub fn memory(&self) -> &MemoryState<F> {
        &self.memory
    }
}

/// A loaded model with its stream state, ready to compensate samples.
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
/// `K` is the centre capacity; models with fewer centres load too and cost proportionally less.
/// Any [`crate::layout::Dims`] within the capacities of [`crate::layout`] loads; a sample whose grating count
/// differs from the model's is answered as non-finite.
#[derive(Clone, Debug)]
pub struct Compensator<F, const K: usize> {
    /// Gratings N of the model.
    gratings: u8,
    /// Whether the model reads T_amb.
    ambient: bool,
    /// M, outputs of the model.
    outputs: u8,
    /// Polynomial terms.
    n_poly: u8,
    /// RBF inputs (used or not).
    n_z: u8,
    /// Groups of four RBF inputs that hold them.
    z_groups: u8,
    /// Stage-1 rows producing *standardised* guesses.
    a: [[F; MAX_STAGE1]; MAX_OUTPUTS],
    b: [[F; MAX_POLY]; MAX_OUTPUTS],
    /// Γ (output units per memory-term unit), term-major: `gamma[k][o]`.
    gamma: [[F; MAX_OUTPUTS]; MAX_MEMORY],
    /// The memory operators and their state.
    memory: MemoryBank<F>,
    /// z_scaled = x · z_gain + z_offset (gain 0 on unused dimensions).
    z_gain: [F; MAX_Z],
    z_offset: [F; MAX_Z],
    centres: Vec<PreparedCentre<F>, K>,
    inv_g_tail: F,
    /// k² · s² per output at the end of calibration.
    band_var: [F; MAX_OUTPUTS],
    /// k² · ds²/dt per output [unit²/s].
    band_var_growth: [F; MAX_OUTPUTS],
    t_cal_end_s: F,
    /// Absolute end of calibration (Unix s), when the model knows it.
    cal_end_unix_s: Option<f64>,
    /// The band's lead when the stream's clock is unknown \[s\].
    lead_max_s: F,
    /// The stream's clock, as set ([`Compensator::set_clock`]).
    clock: StreamClock,
    /// lead = `t_s` + this offset; `None`: the lead is unknown.
    lead_offset_s: Option<F>,
    /// Whether the band grows with time (the time input is then required).
    band_grows: bool,
    env_lo: [F; MAX_ENVELOPE],
    env_hi: [F; MAX_ENVELOPE],
    /// Plausible range of each output's estimate (±∞ for outputs unchecked or not fitted).
    out_lo: [F; MAX_OUTPUTS],
    out_hi: [F; MAX_OUTPUTS],
    /// Each output's band must stay below this before widening (∞: only finite).
    band_lim: [F; MAX_OUTPUTS],
    weak_support: F,
    flagged_band_factor: F,
    /// Latch dead band in ticks of 1/1024 pm.
    dead_band: i32,
    uses_time: bool,
    uses_latch: bool,
    fitted: [bool; MAX_OUTPUTS],
    latches: LatchBank,
}

/// The folded form of everything but the centres, computed in the compensator's precision.
struct Folded<F> {
    a: [[F; MAX_STAGE1]; MAX_OUTPUTS],
    b: [[F; MAX_POLY]; MAX_OUTPUTS],
    z_gain: [F; MAX_Z],
    z_offset: [F; MAX_Z],
    /// 1/(σ√2).
    k_sigma: F,
    v_scale: [F; VAR_RANK],
    band_var: [F; MAX_OUTPUTS],
    band_var_growth: [F; MAX_OUTPUTS],
}

fn all_finite<F: Real>(xs: &[F]) -> bool {
    xs.iter().all(|v| v.is_finite())
}

impl<F: Real> Folded<F> {
    fn of<G: Real, const K2: usize>(p: &ModelParams<G, K2>) -> Self {
        let f = |v: G| F::from_real(v);
        let d = &p.dims;
        let (m_out, n_s1, n_poly) = (d.n_outputs(), d.stage1_len(), d.poly_len());
        let mut a = [[F::ZERO; MAX_STAGE1]; MAX_OUTPUTS];
        for (((row, src), &m), &s) in
            a.iter_mut().zip(p.stage1.iter()).zip(p.guess_mean.iter()).zip(p.guess_std.iter()).take(m_out)
        {
            let inv = F::ONE / f(s);
            for (k, (o, &v)) in row.iter_mut().zip(src.iter()).enumerate().take(n_s1) {
                let v = if k == n_s1 - 1 { f(v) - f(m) } else { f(v) };
                *o = v * inv;
            }
        }
        let mut b = [[F::ZERO; MAX_POLY]; MAX_OUTPUTS];
        for (row, src) in b.iter_mut().zip(p.poly.iter()).take(m_out) {
            for (o, &v) in row.iter_mut().zip(src.iter()).take(n_poly) {
                *o = f(v);
            }
        }
        let k_sigma = F::ONE / (f(p.hyper.sigma) * F::SQRT_2);
        let active = d.z_active(p.hyper.feature_set);
        let mut z_gain = [F::ZERO; MAX_Z];
        let mut z_offset = [F::ZERO; MAX_Z];
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
        let mut band_var = [F::ZERO; MAX_OUTPUTS];
        let mut band_var_growth = [F::ZERO; MAX_OUTPUTS];
        for (((o, og), (&s2, &q)), &k) in band_var
            .iter_mut()
            .zip(band_var_growth.iter_mut())
            .zip(p.resid_var.iter().zip(p.resid_var_growth.iter()))
            .zip(p.band_k.iter())
            .take(m_out)
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

    fn centre<G: Real>(&self, c: &Centre<G>, active: &[bool; MAX_Z], outputs: usize) -> PreparedCentre<F> {
        let mut pc = PreparedCentre::<F>::default();
        let two = F::ONE + F::ONE;
        for ((o, &mu), &on) in pc.m2.iter_mut().zip(c.mu.iter()).zip(active.iter()) {
            if on {
                let m = F::from_real(mu) * self.k_sigma;
                *o = -two * m;
                pc.mu_sq = m.mul_add(m, pc.mu_sq);
            }
        }
        for (o, &w) in pc.w.iter_mut().zip(c.w.iter()).take(outputs) {
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
    /// Until a model is loaded it has no output (0 gratings, M = 0) and answers every sample as
    /// non-finite.
    pub const fn unloaded() -> Self {
        Compensator {
            gratings: 0,
            ambient: false,
            outputs: 0,
            n_poly: 0,
            n_z: 0,
            z_groups: 0,
            a: [[F::ZERO; MAX_STAGE1]; MAX_OUTPUTS],
            b: [[F::ZERO; MAX_POLY]; MAX_OUTPUTS],
            gamma: [[F::ZERO; MAX_OUTPUTS]; MAX_MEMORY],
            memory: MemoryBank::off(),
            z_gain: [F::ZERO; MAX_Z],
            z_offset: [F::ZERO; MAX_Z],
            centres: Vec::new(),
            inv_g_tail: F::ZERO,
            band_var: [F::ZERO; MAX_OUTPUTS],
            band_var_growth: [F::ZERO; MAX_OUTPUTS],
            t_cal_end_s: F::ZERO,
            cal_end_unix_s: None,
            lead_max_s: F::ZERO,
            clock: StreamClock::Unknown,
            lead_offset_s: None,
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
            latches: LatchBank::new(),
        }
    }

    /// Replace the model in place, atomically: `params` is validated and every folded number
    /// checked first; on error the compensator keeps its old model and stream state. On
    /// success the stream state (direction latches) is reset.
    pub fn reload<G: Real, const K2: usize>(&mut self, params: &ModelParams<G, K2>) -> Result<(), Error> {
        params.validate()?;
        self.reload_parts(params, params.centres.len(), || params.centres.iter().copied())
    }

    /// [`Compensator::reload`] from a model whose centres are read from elsewhere: `head`
    /// (validated, e.g. by [`crate::blob::decode_split`], and holding no centres itself) and
    /// its `centres`, read twice (once to check every folded number, once to write them), one
    /// at a time. The same folding, the same checks and the same atomicity as `reload`.
    pub fn reload_split<G: Real, const K2: usize, I: ExactSizeIterator<Item = Centre<G>> + Clone>(
        &mut self,
        head: &ModelParams<G, K2>,
        centres: I,
    ) -> Result<(), Error> {
        self.reload_parts(head, centres.len(), || centres.clone())
    }

    /// Decode a blob ([`crate::blob::decode_split`]: everything but the centres into a
    /// centre-less parameter slot on this frame, the centres read from `bytes` one at a time)
    /// and [`Compensator::reload_split`] it: what a device does to load a model, with about
    /// a third of a whole [`ModelParams`] on its stack. Atomic like [`Compensator::reload`].
    pub fn reload_blob(&mut self, bytes: &[u8]) -> Result<(), Error> {
        let mut head = ModelParams::<f32, 0>::empty();
        let centres = crate::blob::decode_split::<K>(bytes, &mut head)?;
        self.reload_split(&head, centres)
    }

    /// The shared part of the reloads: `n` centres, `centres()` yields them (each time anew).
    fn reload_parts<G: Real, const K2: usize, I: Iterator<Item = Centre<G>>>(
        &mut self,
        params: &ModelParams<G, K2>,
        n: usize,
        centres: impl Fn() -> I,
    ) -> Result<(), Error> {
        if n > K {
            return Err(Error::TooManyCentres { found: n, capacity: K });
        }
        // Folding can overflow even when every stored number is finite (e.g. a tiny guess_std
        // scales stage 1 to infinity in f32): refuse such a model before touching anything.
        let folded = Folded::<F>::of(params);
        let dims = params.dims;
        let m_out = dims.n_outputs();
        let active = dims.z_active(params.hyper.feature_set);
        let f = |v: G| F::from_real(v);
        let env_ok = params.envelope_lo.iter().chain(params.envelope_hi.iter()).all(|&v| f(v).is_finite());
        let gamma_ok = params.gamma.iter().all(|r| r.iter().all(|&v| f(v).is_finite()));
        // A τ or r that overflows this precision would switch its slot off here but not in the
        // trainer's precision.
        let memory_ok = params.memory.convert::<F>().validate(&dims).is_ok();
        if !folded.is_finite()
            || !env_ok
            || !gamma_ok
            || !memory_ok
            || !centres().all(|c| folded.centre(&c, &active, m_out).is_finite())
            || !f(params.t_cal_end_s).is_finite()
            || !F::from_real(params.field.lead_max_s).is_finite()
        {
            return Err(Error::BadParameter { field: "folded coefficients (overflow in this precision)" });
        }
        // From here nothing can fail.
        self.centres.clear();
        for c in centres() {
            // Capacity was checked above; a failed push cannot happen.
            let _ = self.centres.push(folded.centre(&c, &active, m_out));
        }
        let h = &params.hyper;
        self.gratings = dims.gratings() as u8;
        self.ambient = dims.ambient();
        self.outputs = m_out as u8;
        self.n_poly = dims.poly_len() as u8;
        self.n_z = dims.z_len() as u8;
        self.z_groups = dims.z_len().div_ceil(4) as u8;
        self.a = folded.a;
        self.b = folded.b;
        let n_mem = dims.memory_len();
        for (k, col) in self.gamma.iter_mut().enumerate() {
            for (i, (o, row)) in col.iter_mut().zip(params.gamma.iter()).enumerate() {
                *o = match row.get(k) {
                    Some(&v) if i < m_out && k < n_mem => f(v),
                    _ => F::ZERO,
                };
            }
        }
        self.memory = MemoryBank::new(&params.memory, &dims);
        self.z_gain = folded.z_gain;
        self.z_offset = folded.z_offset;
        self.inv_g_tail = f(params.var_inv_g_tail);
        self.band_var = folded.band_var;
        self.band_var_growth = folded.band_var_growth;
        self.t_cal_end_s = f(params.t_cal_end_s);
        self.band_grows = params.resid_var_growth.iter().any(|&q| q > G::ZERO);
        self.cal_end_unix_s = params.field.cal_end_unix_s;
        self.lead_max_s = F::from_real(params.field.lead_max_s);
        self.set_clock(self.clock);
        let n_env = dims.envelope_len();
        for (k, (o, &v)) in self.env_lo.iter_mut().zip(params.envelope_lo.iter()).enumerate() {
            *o = if k < n_env { f(v) } else { F::ZERO };
        }
        for (k, (o, &v)) in self.env_hi.iter_mut().zip(params.envelope_hi.iter()).enumerate() {
            *o = if k < n_env { f(v) } else { F::ZERO };
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
        self.weak_support = f(h.weak_support);
        self.flagged_band_factor = f(h.flagged_band_factor);
        self.dead_band = crate::direction_latch::ticks(h.dead_band_pm);
        self.uses_time = h.feature_set.uses_time();
        self.uses_latch = h.feature_set.uses_latch();
        for (k, (o, &v)) in self.fitted.iter_mut().zip(params.fitted.iter()).enumerate() {
            *o = k < m_out && v;
        }
        self.latches.reset();
        self.memory.reset();
        Ok(())
    }

    /// Whether max_j ψ_j < weak_support, decided from ‖ψ‖² when it can be: ψ_j ≥ 0, so
    /// max ψ ≤ ‖ψ‖ (weak when ‖ψ‖² < w²) and max ψ ≥ ‖ψ‖/√n (not weak when ‖ψ‖² ≥ n·w², with
    /// a margin for the rounding of the sum); otherwise ψ is computed again, identically, for
    /// its maximum (rare: samples near the weak-support boundary).
    #[inline(always)]
    fn weak(&self, z: &[F; ZP], z_sq: F, psi_sq: F) -> bool {
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
        psi_max_pass::<F, K>(&self.centres, z, z_sq, usize::from(self.z_groups)) < w
    }

    /// N: `G` when the step is specialised for it, the model's otherwise (`G` = 0).
    #[inline(always)]
    fn g<const G: usize>(&self) -> usize {
        if G == 0 {
            usize::from(self.gratings)
        } else {
            G
        }
    }

    /// M: `M` when the step is specialised for it, the model's otherwise (`M` = 0).
    #[inline(always)]
    fn m<const M: usize>(&self) -> usize {
        if M == 0 {
            usize::from(self.outputs)
        } else {
            M
        }
    }

    /// The model's grating count N, ambient input and output count M (0 gratings: no model
    /// loaded).
    pub fn dims(&self) -> (usize, bool, usize) {
        (usize::from(self.gratings), self.ambient, usize::from(self.outputs))
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

    /// Say how this stream's `t_s` relates to the end of calibration (kept across
    /// [`Compensator::reset`] and model reloads; a new compensator's clock is
    /// [`StreamClock::Unknown`]). With an unknown lead (no clock, or an absolute start and a
    /// model without an absolute end of calibration) the band takes the largest lead the
    /// calibration validated and every estimate of a model whose band grows carries
    /// [`Flags::LEAD_UNKNOWN`].
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
        self.clock = clock;
        self.lead_offset_s = match clock {
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

    /// The stream's clock as last set.
    pub fn clock(&self) -> StreamClock {
        self.clock
    }

    /// The lead time \[s\] since the end of calibration of a sample at `t_s` on this stream's
    /// clock (at least 0), `None` when the clock does not give it.
    pub fn lead_s(&self, t_s: F) -> Option<F> {
        self.lead_offset_s.map(|o| (t_s + o).max(F::ZERO))
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

    /// [`Compensator::set_stream_state`] from the parts of a compact checkpoint: the latches
    /// and the memory operators packed by [`MemoryState::pack`] at the model's grating count
    /// (empty for a model without memory terms). Nothing changes when `memory` is refused.
    pub fn set_stream_packed(&mut self, latches: LatchBank, memory: &[F]) -> Result<(), Error> {
        if self.memory.is_active() || !memory.is_empty() {
            self.memory.set_packed_state(memory)?;
        }
        self.latches = latches;
        Ok(())
    }

    /// Whether `other` moves its stream state exactly as this one does on every sample (same
    /// dead band, same memory operators, same rule for which samples are finite), so that a
    /// state taken from one can resume the other.
    pub fn same_stream<const K2: usize>(&self, other: &Compensator<F, K2>) -> bool {
        self.dead_band == other.dead_band
            && self.gratings == other.gratings
            && self.ambient == other.ambient
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

    /// Current direction-latch values (−1, 0, +1 per grating; 0 beyond N).
    pub fn latch_values(&self) -> [F; MAX_GRATINGS] {
        self.latches.values()
    }

    /// Advance the stream state by one accepted sample and add the memory terms Γm to `y`;
    /// returns the latch values.
    #[inline(always)]
    fn advance_state<const G: usize>(&mut self, s: &Sample<F>, y: &mut [F; MAX_OUTPUTS]) -> [F; MAX_GRATINGS] {
        let latch: [F; MAX_GRATINGS] = self.latches.update(&s.dl_pm, self.g::<G>(), self.dead_band);
        if self.memory.is_active() {
            self.memory.accumulate(&s.dl_pm, s.t_amb_c, s.t_s, &self.gamma, y);
        }
        latch
    }

    /// Advance the stream state and compute the core's estimate Bφ + Γm.
    #[inline(always)]
    fn advance_with_core<const G: usize, const M: usize>(
        &mut self,
        s: &Sample<F>,
    ) -> ([F; MAX_GRATINGS], [F; MAX_OUTPUTS]) {
        let mut y = self.core::<G, M>(s);
        let latch = self.advance_state::<G>(s, &mut y);
        (latch, y)
    }

    /// Advance the stream state (direction latches, memory operators) by one sample without
    /// compensating it: what `step` does to the state, for samples whose estimate is not
    /// needed. Non-finite samples leave the state as `step` would.
    #[inline]
    pub fn advance(&mut self, s: &Sample<F>) {
        if self.accepts(s) {
            let _: [F; MAX_GRATINGS] = self.latches.update(&s.dl_pm, usize::from(self.gratings), self.dead_band);
            self.memory.advance(&s.dl_pm, s.t_amb_c, s.t_s);
        }
    }

    /// Whether a sample has the model's grating count and is finite where this model reads it
    /// (Δλ, T_amb with an ambient input, and t when the feature set, the band or the memory
    /// terms use time); other samples are answered as non-finite and leave the stream state
    /// untouched.
    #[inline(always)]
    fn accepts(&self, s: &Sample<F>) -> bool {
        self.accepts_shaped::<0>(s)
    }

    /// [`Compensator::accepts`] for a model of `G` gratings (0: any).
    #[inline(always)]
    fn accepts_shaped<const G: usize>(&self, s: &Sample<F>) -> bool {
        s.gratings == self.gratings
            && head(&s.dl_pm, self.g::<G>()).iter().all(|v| v.is_finite())
            && (!self.ambient || s.t_amb_c.is_finite())
            && (!self.needs_time() || s.t_s.is_finite())
    }

    /// The polynomial core Bφ (Model-P's answer when the model has no memory terms):
    /// stage-1 standardised first guesses, then paper Eq. 3 generalised to M guesses.
    #[inline(always)]
    fn core<const G: usize, const M: usize>(&self, s: &Sample<F>) -> [F; MAX_OUTPUTS] {
        let m = self.m::<M>();
        let (x, n_in) = affine_inputs(&s.dl_pm, self.g::<G>(), self.ambient, s.t_amb_c);
        let mut g = [F::ZERO; MAX_OUTPUTS];
        for (gi, row) in g.iter_mut().zip(self.a.iter()).take(m) {
            *gi = affine(&x, n_in, row);
        }
        let phi = poly_features(&g, m);
        let mut y = [F::ZERO; MAX_OUTPUTS];
        let n_poly = if M == 0 { usize::from(self.n_poly) } else { crate::layout::poly_len(M) };
        for (yi, row) in y.iter_mut().zip(self.b.iter()).take(m) {
            let mut acc = F::ZERO;
            for (&c, &ph) in head(row, n_poly).iter().zip(phi.iter()) {
                acc = c.mul_add(ph, acc);
            }
            *yi = acc;
        }
        y
    }

    /// The scaled RBF inputs z (unused inputs 0) and ‖z‖².
    #[inline(always)]
    fn rbf_inputs<const G: usize>(&self, s: &Sample<F>, latch: [F; MAX_GRATINGS]) -> ([F; ZP], F) {
        let n = self.g::<G>();
        let mut x_z = [F::ZERO; MAX_Z];
        let mut i = 0;
        for (o, &d) in x_z.iter_mut().zip(head(&s.dl_pm, n).iter()) {
            *o = d;
            i += 1;
        }
        if self.ambient {
            if let Some(o) = x_z.get_mut(i) {
                *o = s.t_amb_c;
            }
            i += 1;
        }
        if self.uses_time {
            if let Some(o) = x_z.get_mut(i) {
                *o = s.t_s;
            }
        }
        i += 1;
        if self.uses_latch {
            for (o, &l) in x_z.iter_mut().skip(i).zip(head(&latch, n).iter()) {
                *o = l;
            }
        }
        let mut z = [F::ZERO; ZP];
        let mut z_sq = F::ZERO;
        let n_z = usize::from(self.n_z);
        for (((zi, &x), &gn), &of) in
            z.iter_mut().zip(x_z.iter()).zip(self.z_gain.iter()).zip(self.z_offset.iter()).take(n_z)
        {
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
    pub fn core_and_activations(&mut self, s: &Sample<F>, psi: &mut [F]) -> Option<[F; MAX_OUTPUTS]> {
        // The paper's shape with compile-time loop bounds, as in `step_with`.
        if self.gratings == 3 && self.outputs == 3 {
            self.core_and_activations_shaped::<3, 3>(s, psi)
        } else {
            self.core_and_activations_shaped::<0, 0>(s, psi)
        }
    }

    /// [`Compensator::core_and_activations`] for a model of `G` gratings and `M` outputs (0:
    /// read from the model).
    #[inline(always)]
    fn core_and_activations_shaped<const G: usize, const M: usize>(
        &mut self,
        s: &Sample<F>,
        psi: &mut [F],
    ) -> Option<[F; MAX_OUTPUTS]> {
        if !self.accepts_shaped::<G>(s) {
            return None;
        }
        let (latch, y) = self.advance_with_core::<G, M>(s);
        let (z, z_sq) = self.rbf_inputs::<G>(s, latch);
        let groups = usize::from(self.z_groups);
        for (o, c) in psi.iter_mut().zip(self.centres.iter()) {
            *o = psi_of::<F>(c, &z, z_sq, groups);
        }
        Some(y)
    }

    /// The RBF activations ψ_j of sample `s` (into `psi`, one per centre) given the direction
    /// latches after it (as [`Compensator::latch_values`] reads them once the sample is
    /// compensated), without moving the stream state: the ψ of
    /// [`Compensator::core_and_activations`], by the same code, for a trainer that has the
    /// stream's latches already and tries several RBF layers on one stream. `false` (and `psi`
    /// untouched) for a sample `step` would answer as non-finite.
    pub fn activations(&self, s: &Sample<F>, latch: &[F; MAX_GRATINGS], psi: &mut [F]) -> bool {
        if !self.accepts(s) {
            return false;
        }
        let (z, z_sq) = self.rbf_inputs::<0>(s, *latch);
        let groups = usize::from(self.z_groups);
        for (o, c) in psi.iter_mut().zip(self.centres.iter()) {
            *o = psi_of::<F>(c, &z, z_sq, groups);
        }
        true
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
    pub fn step_with(&mut self, s: &Sample<F>, sink: impl FnMut(usize, F)) -> Estimate<F> {
        // The paper's shape (3 gratings, 3 outputs) with the loop bounds known at compile
        // time, every other shape with them read from the model: the same operations in the
        // same order either way.
        if self.gratings == 3 && self.outputs == 3 {
            self.step_shaped::<3, 3>(s, sink)
        } else {
            self.step_shaped::<0, 0>(s, sink)
        }
    }

    /// [`Compensator::step_with`] for a model of `G` gratings and `M` outputs (0: read from
    /// the model).
    #[inline(always)]
    fn step_shaped<const G: usize, const M: usize>(
        &mut self,
        s: &Sample<F>,
        mut sink: impl FnMut(usize, F),
    ) -> Estimate<F> {
        if !self.accepts_shaped::<G>(s) {
            return Estimate::refused(self.outputs, Flags::NON_FINITE);
        }
        let (latch, y) = self.advance_with_core::<G, M>(s);
        let (x_env, n_env) = affine_inputs(&s.dl_pm, self.g::<G>(), self.ambient, s.t_amb_c);

        let mut flags = Flags::OK;
        for ((&x, &lo), &hi) in head(&x_env, n_env).iter().zip(self.env_lo.iter()).zip(self.env_hi.iter()) {
            if x < lo || x > hi {
                flags.insert(Flags::OUT_OF_ENVELOPE);
            }
        }

        // RBF residual (paper Eq. 5-6) with the variance projections in the same pass.
        let (z, z_sq) = self.rbf_inputs::<G>(s, latch);
        let groups = usize::from(self.z_groups);
        // Unused inputs have zero weight in every centre and zero value: each adds an exact 0.
        let acc = centre_pass::<F, K>(&self.centres, &z, z_sq, groups, y, &mut sink);
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
            return Estimate::refused(self.outputs, flags.union(Flags::NON_FINITE));
        }
        let m = self.m::<M>();
        let lead = if !self.band_grows {
            F::ZERO
        } else if let Some(o) = self.lead_offset_s {
            (s.t_s + o).max(F::ZERO)
        } else {
            flags.insert(Flags::LEAD_UNKNOWN);
            self.lead_max_s
        };
        // The band, and the plausibility of the value and the band (crate::field): three
        // compares per output. An output unchecked or not fitted has ±∞ bounds and an infinite
        // limit: only a band that overflows flags it (then the leverage did, for every output).
        let mut band95 = [F::ZERO; MAX_OUTPUTS];
        let mut implausible = false;
        for (((bi, (&bv, &bg)), (&v, &lim)), (&lo, &hi)) in band95
            .iter_mut()
            .zip(self.band_var.iter().zip(self.band_var_growth.iter()))
            .zip(y.iter().zip(self.band_lim.iter()))
            .zip(self.out_lo.iter().zip(self.out_hi.iter()))
            .take(m)
        {
            *bi = (bg.mul_add(lead, bv) * (F::ONE + lev)).sqrt();
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

// Out of line: one copy per variant serves every shape of the step (it does not depend on
// the dims), with the per-centre work inlined in it.
#[inline(never)]
#[allow(clippy::type_complexity)]
fn centre_pass<F: Real, const K: usize>(
    centres: &Vec<PreparedCentre<F>, K>,
    z: &[F; ZP],
    z_sq: F,
    groups: usize,
    mut y: [F; MAX_OUTPUTS],
    sink: &mut impl FnMut(usize, F),
) -> ([F; MAX_OUTPUTS], [F; VAR_RANK], F) {
    let mut proj = [F::ZERO; VAR_RANK];
    let mut psi_sq = F::ZERO;
    // Inlined into the loop below (as a closure the compiler kept it out of line: a call per
    // centre).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn one<F: Real>(
        j: usize,
        c: &PreparedCentre<F>,
        z: &[F; ZP],
        z_sq: F,
        groups: usize,
        sink: &mut impl FnMut(usize, F),
        y: &mut [F; MAX_OUTPUTS],
        proj: &mut [F; VAR_RANK],
        psi_sq: &mut F,
    ) {
        let psi = psi_of::<F>(c, z, z_sq, groups);
        sink(j, psi);
        for (yi, &w) in y.iter_mut().zip(c.w.iter()) {
            *yi = w.mul_add(psi, *yi);
        }
        for (pi, &v) in proj.iter_mut().zip(c.v.iter()) {
            *pi = v.mul_add(psi, *pi);
        }
        *psi_sq = psi.mul_add(psi, *psi_sq);
    }
    for (j, c) in centres.iter().enumerate() {
        one(j, c, z, z_sq, groups, sink, &mut y, &mut proj, &mut psi_sq);
    }
    (y, proj, psi_sq)
}

/// ψ_j = exp(−‖z − μ_j‖²/(2σ²)) over the first `groups` groups of four inputs, in input order
/// (an unused or padding input adds an exact 0).
#[inline(always)]
fn psi_of<F: Real>(c: &PreparedCentre<F>, z: &[F; ZP], z_sq: F, groups: usize) -> F {
    let mut d2 = z_sq + c.mu_sq;
    for (zc, mc) in z.chunks_exact(4).zip(c.m2.chunks_exact(4)).take(groups) {
        if let ([z0, z1, z2, z3], [m0, m1, m2, m3]) = (zc, mc) {
            d2 = z0.mul_add(*m0, d2);
            d2 = z1.mul_add(*m1, d2);
            d2 = z2.mul_add(*m2, d2);
            d2 = z3.mul_add(*m3, d2);
        }
    }
    d2.exp_neg()
}

#[inline(never)]
fn psi_max_pass<F: Real, const K: usize>(
    centres: &Vec<PreparedCentre<F>, K>,
    z: &[F; ZP],
    z_sq: F,
    groups: usize,
) -> F {
    let mut m = F::ZERO;
    for c in centres.iter() {
        m = m.max(psi_of::<F>(c, z, z_sq, groups));
    }
    m
}
