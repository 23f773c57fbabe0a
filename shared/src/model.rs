//! The auditable form of a trained compensator: every coefficient in the units a metrologist
//! checks, exactly what the `.fbgm` blob carries.
//!
//! [`crate::Compensator`] derives its folded, per-sample form from this once at load time.

use heapless::{String, Vec};
use serde::{Deserialize, Serialize};

use crate::error::Error;
use crate::field::FieldContext;
use crate::layout::{
    head, Dims, FeatureSet, MAX_ENVELOPE, MAX_MEMORY, MAX_OUTPUTS, MAX_POLY, MAX_STAGE1, MAX_Z, VAR_RANK,
};
use crate::memory::MemorySpec;
use crate::real::Real;
use crate::trust::TrustSpec;

pub use crate::bounds;
use crate::bounds::within;

/// Whether every entry of `s` is within ±`bound` (inlined, as [`within`]).
#[inline(always)]
fn all_within<F: Real>(s: &[F], bound: f64) -> bool {
    s.iter().all(|&v| within(v, bound))
}

/// Whether `g` may be Γ's entry for memory term `k` of a model of `dims` with the operators
/// `memory`: within [`bounds::COEF_MAX`], and 0 on a term the operators do not compute.
pub(crate) fn gamma_ok<F: Real>(g: F, memory: &MemorySpec<F>, dims: &Dims, k: usize) -> bool {
    within(g, bounds::COEF_MAX) && (g == F::ZERO || memory.term_active(dims, k))
}

/// Hyper-parameters chosen by blocked time-series cross-validation, plus the flag settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Hyper<F> {
    /// Inputs of the RBF residual.
    pub feature_set: FeatureSet,
    /// σ as a multiple of the median nearest-neighbour distance between centres (for audit).
    pub sigma_mult: F,
    /// RBF width σ in standardised units.
    pub sigma: F,
    /// Ridge penalty α of Eq. 7.
    pub alpha: F,
    /// Direction-latch dead band \[pm\].
    pub dead_band_pm: F,
    /// Weak-support threshold on max_j ψ_j (0..1).
    pub weak_support: F,
    /// Envelope margin as a fraction of the calibration range (for audit; the envelope bounds
    /// already include it).
    pub envelope_margin: F,
    /// Factor applied to the 95 % band of a flagged (envelope or support) sample (>= 1).
    pub flagged_band_factor: F,
}

/// One RBF centre with its residual weights and variance eigen-components.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Centre<F> {
    /// Position μ_j in standardised z units (0 on dimensions the feature set does not use and
    /// beyond [`Dims::z_len`]).
    pub mu: [F; MAX_Z],
    /// Residual weights W[:, j] per output, in output units (0 beyond M).
    pub w: [F; MAX_OUTPUTS],
    /// Component j of the `VAR_RANK` eigenvectors of `ΨᵀΨ + αI` with the smallest eigenvalues.
    pub v: [F; VAR_RANK],
}

impl<F: Real> Centre<F> {
    /// Every number within its [`bounds`]: μ ([`bounds::STANDARDISED_MAX`]), the weights
    /// ([`bounds::COEF_MAX`]) and the variance components ([`bounds::EIGVEC_MAX`]). The error
    /// names the part ("centres.mu", "centres.w", "centres.v").
    pub fn check(&self) -> Result<(), Error> {
        let bad = |field| Err(Error::BadParameter { field });
        if !all_within(&self.mu, bounds::STANDARDISED_MAX) {
            return bad("centres.mu");
        }
        if !all_within(&self.w, bounds::COEF_MAX) {
            return bad("centres.w");
        }
        if !all_within(&self.v, bounds::EIGVEC_MAX) {
            return bad("centres.v");
        }
        Ok(())
    }
}

/// Where the model came from (carried in the blob for audit).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Provenance {
    /// Scenario seed (0 for real data).
    pub seed: u64,
    /// Scenario preset or data source name.
    pub scenario: String<24>,
    /// Trainer version that wrote the model.
    pub trainer_version: String<16>,
    /// Training date as YYYYMMDD (UTC).
    pub date_yyyymmdd: u32,
    /// Calibration samples used.
    pub n_cal: u32,
}

/// A trained Model-H (Model-P when it has no centres), generic over the scalar and with a
/// capacity of `K` centres. `Default` is an all-zero placeholder (it does not validate), the
/// starting point of [`crate::blob::decode_into`].
///
/// A model travels as a `.fbgm` blob ([`crate::blob`]), and any precision or capacity converts
/// to any other that holds it:
///
/// ```
/// use fbg_shared::{blob, FeatureSet, ModelParams};
/// # let trained: ModelParams<f32, 8> =
/// #     fbg_testkit::models::model(4, 1, FeatureSet::Paper, Default::default());
/// let mut buf = [0u8; blob::max_len(8)];
/// let n = blob::encode(&trained, &mut buf)?;
/// let back: ModelParams<f32, 4> = blob::decode(&buf[..n])?; // every check passed
/// assert_eq!(back.n_centres(), 4);
/// let host: ModelParams<f64, 4> = back.convert()?;
/// assert_eq!(host.hyper.feature_set, FeatureSet::Paper);
/// buf[20] ^= 1; // one flipped bit
/// assert_eq!(blob::decode::<4>(&buf[..n]), Err(fbg_shared::Error::BadCrc));
/// # Ok::<(), fbg_shared::Error>(())
/// ```
///
/// Every array is sized to the capacity ([`crate::layout`]); only the entries of the model's
/// [`Dims`] are used, the rest are 0 (the blob carries only the used ones).
///
/// `M` is the capacity of Γ's rows: [`MAX_MEMORY`], or 0 for a parameter slot that leaves Γ
/// in the blob it was decoded from (a device's load, [`crate::blob::decode_split`]: Γ is about
/// half of a centre-less slot).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelParams<F, const K: usize, const M: usize = MAX_MEMORY> {
    /// Gratings, ambient input and measurands.
    pub dims: Dims,
    /// Chosen hyper-parameters.
    pub hyper: Hyper<F>,
    /// Stage-1 linear inverse A: first guesses (one per output, in its unit) =
    /// A · [Δλ_1..N pm, T_amb °C (with ambient), 1] (rows M, columns [`Dims::stage1_len`]).
    pub stage1: [[F; MAX_STAGE1]; MAX_OUTPUTS],
    /// Mean of the stage-1 guesses over the calibration batch (T °C, ε µε, p kPa).
    pub guess_mean: [F; MAX_OUTPUTS],
    /// Standard deviation of the stage-1 guesses (same units), > 0.
    pub guess_std: [F; MAX_OUTPUTS],
    /// Polynomial core B (paper Eq. 3) on standardised guesses, one row per output; columns in
    /// [`Dims::poly_term`] order, values in output units.
    pub poly: [[F; MAX_POLY]; MAX_OUTPUTS],
    /// The memory operators (all slots 0 for the `paper` and `latch` variants).
    pub memory: MemorySpec<F>,
    /// Γ: per output, the coefficient of each memory term, in output units per term unit
    /// (e.g. °C per pm for a grating high-pass on the T row); 0 for unused terms. Fitted
    /// jointly with B. Empty when `M` is 0.
    pub gamma: [[F; M]; MAX_OUTPUTS],
    /// Mean of each RBF input over the calibration batch (units of [`Dims::z_name`]; 0 beyond [`Dims::z_len`]).
    pub z_mean: [F; MAX_Z],
    /// Standard deviation of each RBF input (> 0 on used dimensions, ignored elsewhere).
    pub z_std: [F; MAX_Z],
    /// RBF centres with weights (up to `K`).
    pub centres: Vec<Centre<F>, K>,
    /// `1/g_i` for the `VAR_RANK` smallest eigenvalues g_i of `ΨᵀΨ + αI` (0 when unused).
    pub var_inv_g: [F; VAR_RANK],
    /// Optional charge per unit of ‖ψ‖² outside the kept directions (an upper bound when set to
    /// `1/g` of the smallest eigenvalue not kept). The trainer writes 0: the kept directions
    /// are the least determined ones, which carry the leverage out of distribution, and the
    /// others add about dof/N (< 1 % of the band) in distribution.
    pub var_inv_g_tail: F,
    /// Per-output residual variance s² at the end of calibration, from cross-validation
    /// (°C², µε², kPa²).
    pub resid_var: [F; MAX_OUTPUTS],
    /// Growth of the residual variance per second after the end of calibration (°C²/s, µε²/s,
    /// kPa²/s), fitted on the cross-validation residuals against their lead time: drift is a
    /// random walk, so the error variance grows linearly with time since calibration.
    pub resid_var_growth: [F; MAX_OUTPUTS],
    /// End of the calibration batch on the sample clock `t_s` \[s\].
    pub t_cal_end_s: F,
    /// Band multiplier per output: the 95 % quantile of |error| / s(τ) over the
    /// cross-validation residuals (1.96 for Gaussian errors; calibrated because hysteresis makes
    /// the errors far from Gaussian).
    pub band_k: [F; MAX_OUTPUTS],
    /// Lower envelope bound per input Δλ_1..N \[pm\], T_amb [°C] (with ambient), margin
    /// included.
    pub envelope_lo: [F; MAX_ENVELOPE],
    /// Upper envelope bound, margin included.
    pub envelope_hi: [F; MAX_ENVELOPE],
    /// Which outputs were fitted. An output without a reference in the calibration
    /// data is not fitted: the compensator returns NaN for it with an infinite band, whatever
    /// the flags say about the sample.
    pub fitted: [bool; MAX_OUTPUTS],
    /// Training provenance.
    pub provenance: Provenance,
    /// What a field reading needs: each grating's zero, the calibration's absolute clock, the
    /// output envelope and the largest band.
    pub field: FieldContext,
    /// Where the memory may be trusted: the gate's rate limits, the fade's quiet time and the
    /// band it fades to ([`crate::trust`]).
    pub trust: TrustSpec<F>,
}

impl<F: Real, const K: usize, const M: usize> Default for ModelParams<F, K, M> {
    fn default() -> Self {
        Self::empty()
    }
}

impl<F: Real, const K: usize, const M: usize> ModelParams<F, K, M> {
    /// The nested arrays of [`ModelParams::empty`] as constants: a constant of zero bytes is
    /// written in place, where a nested repeat `[[F::ZERO; N]; M]` may be built in a temporary
    /// and copied (at the firmware's opt-level "s" it was, deepening the loader's stack frame
    /// by the size of the three arrays; README-firmware.md has the figures).
    const ZERO_STAGE1: [[F; MAX_STAGE1]; MAX_OUTPUTS] = [[F::ZERO; MAX_STAGE1]; MAX_OUTPUTS];
    const ZERO_POLY: [[F; MAX_POLY]; MAX_OUTPUTS] = [[F::ZERO; MAX_POLY]; MAX_OUTPUTS];
    const ZERO_GAMMA: [[F; M]; MAX_OUTPUTS] = [[F::ZERO; M]; MAX_OUTPUTS];

    /// An all-zero placeholder (it does not validate): a staging slot a blob is decoded into,
    /// usable in a `static` (it lands in `.bss`).
    pub const fn empty() -> Self {
        ModelParams {
            dims: Dims::PAPER,
            hyper: Hyper {
                feature_set: FeatureSet::Paper,
                sigma_mult: F::ZERO,
                sigma: F::ZERO,
                alpha: F::ZERO,
                dead_band_pm: F::ZERO,
                weak_support: F::ZERO,
                envelope_margin: F::ZERO,
                flagged_band_factor: F::ZERO,
            },
            stage1: Self::ZERO_STAGE1,
            guess_mean: [F::ZERO; MAX_OUTPUTS],
            guess_std: [F::ZERO; MAX_OUTPUTS],
            poly: Self::ZERO_POLY,
            memory: MemorySpec::off(),
            gamma: Self::ZERO_GAMMA,
            z_mean: [F::ZERO; MAX_Z],
            z_std: [F::ZERO; MAX_Z],
            centres: Vec::new(),
            var_inv_g: [F::ZERO; VAR_RANK],
            var_inv_g_tail: F::ZERO,
            resid_var: [F::ZERO; MAX_OUTPUTS],
            resid_var_growth: [F::ZERO; MAX_OUTPUTS],
            t_cal_end_s: F::ZERO,
            band_k: [F::ZERO; MAX_OUTPUTS],
            envelope_lo: [F::ZERO; MAX_ENVELOPE],
            envelope_hi: [F::ZERO; MAX_ENVELOPE],
            fitted: [false; MAX_OUTPUTS],
            provenance: Provenance {
                seed: 0,
                scenario: String::new(),
                trainer_version: String::new(),
                date_yyyymmdd: 0,
                n_cal: 0,
            },
            field: FieldContext::unknown(),
            trust: TrustSpec::off(),
        }
    }

    /// Whether the model has memory terms.
    pub fn has_memory(&self) -> bool {
        self.memory.any()
    }

    /// Number of centres in use (0 for a pure Model-P).
    pub fn n_centres(&self) -> usize {
        self.centres.len()
    }

    /// Check every number a device would rely on: finite values within the plausibility
    /// [`bounds`], positive scales, ordered envelope, sane flag settings, output indices within
    /// the capacity. Decoding calls this; so should anyone building params by hand. An error
    /// names the first field that fails.
    pub fn validate(&self) -> Result<(), Error> {
        use bounds::*;
        let d = &self.dims;
        let h = &self.hyper;
        let bad = |field| Err(Error::BadParameter { field });
        let (m, n_s1, n_poly, n_z, n_env) = (d.n_outputs(), d.stage1_len(), d.poly_len(), d.z_len(), d.envelope_len());
        if d.outputs().iter().any(|o| usize::from(o.index) > MAX_OUTPUTS) {
            return bad("dims.outputs");
        }
        if !(within(h.sigma, STANDARDISED_MAX) && h.sigma > F::ZERO) {
            return bad("hyper.sigma");
        }
        if !(within(h.sigma_mult, STANDARDISED_MAX) && h.sigma_mult > F::ZERO) {
            return bad("hyper.sigma_mult");
        }
        if !(within(h.alpha, INV_G_MAX) && h.alpha >= F::ZERO) {
            return bad("hyper.alpha");
        }
        if !(within(h.dead_band_pm, INPUT_MAX) && h.dead_band_pm >= F::ZERO) {
            return bad("hyper.dead_band_pm");
        }
        if !(h.weak_support.is_finite() && h.weak_support >= F::ZERO && h.weak_support <= F::ONE) {
            return bad("hyper.weak_support");
        }
        if !(within(h.envelope_margin, FACTOR_MAX) && h.envelope_margin >= F::ZERO) {
            return bad("hyper.envelope_margin");
        }
        if !(within(h.flagged_band_factor, FACTOR_MAX) && h.flagged_band_factor >= F::ONE) {
            return bad("hyper.flagged_band_factor");
        }
        if !self.stage1.iter().take(m).all(|r| all_within(head(r, n_s1), COEF_MAX)) {
            return bad("stage1");
        }
        if !all_within(head(&self.guess_mean, m), OUTPUT_MAX) {
            return bad("guess_mean");
        }
        if !head(&self.guess_std, m).iter().all(|&s| within(s, OUTPUT_MAX) && s > F::ZERO) {
            return bad("guess_std");
        }
        if !self.poly.iter().take(m).all(|r| all_within(head(r, n_poly), COEF_MAX)) {
            return bad("poly");
        }
        self.memory.validate(d)?;
        self.trust.validate(d)?;
        let mem = &self.memory;
        if !all_within(&mem.grating_tau_s, TIME_MAX) {
            return bad("memory.grating_tau_s");
        }
        if !all_within(&mem.ambient_tau_s, TIME_MAX) {
            return bad("memory.ambient_tau_s");
        }
        if !all_within(&mem.play_half_width_pm, INPUT_MAX) {
            return bad("memory.play_half_width_pm");
        }
        if !(within(mem.observer_lag_s, TIME_MAX) && within(mem.observer_smooth_s, TIME_MAX)) {
            return bad("memory.observer");
        }
        if !all_within(&mem.observer_row, COEF_MAX) {
            return bad("memory.observer_row");
        }
        for row in self.gamma.iter().take(m) {
            for (k, &g) in row.iter().enumerate() {
                if !gamma_ok(g, &self.memory, d, k) {
                    return bad("gamma");
                }
            }
        }
        // Shifts and T_amb come first in z, then time and the latches (±1). Each bound a
        // constant at its call (see `within`).
        let z_ok = |i: usize, v: F| if i < n_env { within(v, INPUT_MAX) } else { within(v, TIME_MAX) };
        if !head(&self.z_mean, n_z).iter().enumerate().all(|(i, &v)| z_ok(i, v)) {
            return bad("z_mean");
        }
        let active = d.z_active(h.feature_set);
        if !self
            .z_std
            .iter()
            .zip(active.iter())
            .take(n_z)
            .enumerate()
            .all(|(i, (&s, &on))| z_ok(i, s) && (!on || s > F::ZERO))
        {
            return bad("z_std");
        }
        self.centres.iter().try_for_each(Centre::check)?;
        if !self.var_inv_g.iter().all(|&v| within(v, INV_G_MAX) && v >= F::ZERO) {
            return bad("var_inv_g");
        }
        if !(within(self.var_inv_g_tail, INV_G_MAX) && self.var_inv_g_tail >= F::ZERO) {
            return bad("var_inv_g_tail");
        }
        if !head(&self.resid_var, m).iter().all(|&v| within(v, VARIANCE_MAX) && v >= F::ZERO) {
            return bad("resid_var");
        }
        if !head(&self.resid_var_growth, m).iter().all(|&v| within(v, VARIANCE_MAX) && v >= F::ZERO) {
            return bad("resid_var_growth");
        }
        if !within(self.t_cal_end_s, TIME_MAX) {
            return bad("t_cal_end_s");
        }
        if !head(&self.band_k, m).iter().all(|&k| within(k, FACTOR_MAX) && k > F::ZERO) {
            return bad("band_k");
        }
        if !self.fitted.iter().take(m).any(|&f| f) {
            return bad("fitted");
        }
        if !self
            .envelope_lo
            .iter()
            .zip(self.envelope_hi.iter())
            .take(n_env)
            .all(|(&lo, &hi)| within(lo, INPUT_MAX) && within(hi, INPUT_MAX) && lo <= hi)
        {
            return bad("envelope");
        }
        self.field.validate(d, &self.fitted)
    }
}

impl<F: Real, const K: usize> ModelParams<F, K> {
    /// The same model in another scalar type (f64 → f32 for export, f32 → f64 to audit a blob)
    /// and capacity. Fails with [`Error::TooManyCentres`] when `K2` cannot hold the centres.
    pub fn convert<G: Real, const K2: usize>(&self) -> Result<ModelParams<G, K2>, Error> {
        fn c<F: Real, G: Real, const N: usize>(a: &[F; N]) -> [G; N] {
            let mut out = [G::ZERO; N];
            for (o, &v) in out.iter_mut().zip(a.iter()) {
                *o = G::from_f64(v.to_f64());
            }
            out
        }
        fn m<F: Real, G: Real, const R: usize, const C: usize>(a: &[[F; C]; R]) -> [[G; C]; R] {
            let mut out = [[G::ZERO; C]; R];
            for (o, r) in out.iter_mut().zip(a.iter()) {
                *o = c(r);
            }
            out
        }
        let g = |v: F| G::from_f64(v.to_f64());
        let mut centres: Vec<Centre<G>, K2> = Vec::new();
        for ce in self.centres.iter() {
            centres
                .push(Centre { mu: c(&ce.mu), w: c(&ce.w), v: c(&ce.v) })
                .map_err(|_| Error::TooManyCentres { found: self.centres.len(), capacity: K2 })?;
        }
        let h = &self.hyper;
        Ok(ModelParams {
            dims: self.dims,
            hyper: Hyper {
                feature_set: h.feature_set,
                sigma_mult: g(h.sigma_mult),
                sigma: g(h.sigma),
                alpha: g(h.alpha),
                dead_band_pm: g(h.dead_band_pm),
                weak_support: g(h.weak_support),
                envelope_margin: g(h.envelope_margin),
                flagged_band_factor: g(h.flagged_band_factor),
            },
            stage1: m(&self.stage1),
            guess_mean: c(&self.guess_mean),
            guess_std: c(&self.guess_std),
            poly: m(&self.poly),
            memory: self.memory.convert(),
            gamma: m(&self.gamma),
            z_mean: c(&self.z_mean),
            z_std: c(&self.z_std),
            centres,
            var_inv_g: c(&self.var_inv_g),
            var_inv_g_tail: g(self.var_inv_g_tail),
            resid_var: c(&self.resid_var),
            resid_var_growth: c(&self.resid_var_growth),
            t_cal_end_s: g(self.t_cal_end_s),
            band_k: c(&self.band_k),
            envelope_lo: c(&self.envelope_lo),
            envelope_hi: c(&self.envelope_hi),
            fitted: self.fitted,
            provenance: self.provenance.clone(),
            field: self.field,
            trust: self.trust.convert(),
        })
    }
}
