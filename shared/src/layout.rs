//! Fixed dimensions of the compensator and the layout of its feature vectors.
//!
//! The gratings, outputs and polynomial terms are fixed by the physics; only the
//! number of RBF centres `K` varies between models and is a const generic of the device types.

/// Gratings (wavelength inputs) per sensor group.
pub const N_GRATINGS: usize = 3;
/// Outputs: temperature [°C], strain \[µε\], pressure \[kPa\], in that order.
pub const N_OUTPUTS: usize = 3;
/// Raw inputs per sample: Δλ1..3 \[pm\], T_amb [°C], t \[s\].
pub const N_INPUTS: usize = 5;
/// Stage-1 regressors: Δλ1..3 \[pm\], T_amb [°C], 1.
pub const N_STAGE1: usize = 5;
/// Polynomial terms of paper Eq. 3: [1, T, ε, p, T², ε², p², Tε, Tp, εp].
pub const N_POLY: usize = 10;
/// Inputs checked against the calibration envelope: Δλ1..3 \[pm\], T_amb [°C] (time always
/// extrapolates, so it is never checked).
pub const N_ENVELOPE: usize = 4;
/// RBF input layout: [Δλ1, Δλ2, Δλ3, T_amb, t, latch1, latch2, latch3]. Dimensions the
/// feature set does not use carry zero scale and contribute nothing.
pub const Z_DIMS: usize = 8;
/// Index of the time input in the RBF layout.
pub const Z_TIME: usize = 4;
/// Index of the first direction latch in the RBF layout.
pub const Z_LATCH: usize = 5;
/// Time-constant slots of the grating high-passes Δλ_i − EMA_τ(Δλ_i).
pub const N_GRATING_TAUS: usize = 6;
/// Time-constant slots of the ambient high-passes T_amb − EMA_τ(T_amb).
pub const N_AMBIENT_TAUS: usize = 4;
/// Half-width slots of the stop terms Δλ_i − play_r(Δλ_i).
pub const N_PLAYS: usize = 3;
/// Index of the first grating high-pass in the memory vector m (τ slot major, grating minor).
pub const MEM_GRATING: usize = 0;
/// Index of the first ambient high-pass in m.
pub const MEM_AMBIENT: usize = MEM_GRATING + N_GRATINGS * N_GRATING_TAUS;
/// Index of the first stop term in m (r slot major, grating minor).
pub const MEM_STOP: usize = MEM_AMBIENT + N_AMBIENT_TAUS;
/// Index of the drift observer in m.
pub const MEM_OBSERVER: usize = MEM_STOP + N_GRATINGS * N_PLAYS;
/// Memory terms m of Model-H (see [`crate::memory`]); unused slots are 0.
pub const N_MEMORY: usize = MEM_OBSERVER + 1;
/// Number of eigen-directions of `(ΨᵀΨ + αI)⁻¹` kept for the predictive variance: those with
/// the smallest eigenvalues g of `ΨᵀΨ + αI`, which carry the leverage out of distribution
/// (exact when `K <= VAR_RANK`; see `ModelParams::var_inv_g_tail` for the rest).
pub const VAR_RANK: usize = 4;
/// Two-sided 95 % normal quantile used for the band.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Short names of the outputs, in output order: table columns, JSON keys, messages.
pub const CHANNELS: [&str; N_OUTPUTS] = ["T", "strain", "p"];
/// Units of the outputs, in output order.
pub const UNITS: [&str; N_OUTPUTS] = ["°C", "µε", "kPa"];
/// Names of the RBF inputs with units, in `Z_DIMS` order.
pub const Z_NAMES: [&str; Z_DIMS] =
    ["dl1 [pm]", "dl2 [pm]", "dl3 [pm]", "T_amb [°C]", "t [s]", "latch1", "latch2", "latch3"];
/// Names of the polynomial terms (on standardised first guesses) in `N_POLY` order.
pub const POLY_NAMES: [&str; N_POLY] = ["1", "T", "ε", "p", "T²", "ε²", "p²", "Tε", "Tp", "εp"];

/// Which inputs feed the RBF residual.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[repr(u8)]
pub enum FeatureSet {
    /// Paper Eq. 5: z = [Δλ1..3, T_amb, t].
    Paper = 0,
    /// z = [Δλ1..3, T_amb, latch1..3] (the default).
    #[default]
    HysteresisAware = 1,
    /// z = [Δλ1..3, T_amb, t, latch1..3], when cross-validation keeps time.
    HysteresisAwareTime = 2,
}

impl FeatureSet {
    /// All feature sets, in code order.
    pub const ALL: [FeatureSet; 3] = [FeatureSet::Paper, FeatureSet::HysteresisAware, FeatureSet::HysteresisAwareTime];

    /// Whether each `Z_DIMS` input is used.
    pub const fn active(self) -> [bool; Z_DIMS] {
        let time = self.uses_time();
        let latch = self.uses_latch();
        [true, true, true, true, time, latch, latch, latch]
    }
    /// True when the time input is part of z.
    pub const fn uses_time(self) -> bool {
        matches!(self, FeatureSet::Paper | FeatureSet::HysteresisAwareTime)
    }
    /// True when the direction latches are part of z.
    pub const fn uses_latch(self) -> bool {
        matches!(self, FeatureSet::HysteresisAware | FeatureSet::HysteresisAwareTime)
    }
    /// Stable code stored in the model blob.
    pub const fn code(self) -> u8 {
        self as u8
    }
    /// The feature set for a blob code, `None` when unknown.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(FeatureSet::Paper),
            1 => Some(FeatureSet::HysteresisAware),
            2 => Some(FeatureSet::HysteresisAwareTime),
            _ => None,
        }
    }
    /// Command-line / report name.
    pub const fn name(self) -> &'static str {
        match self {
            FeatureSet::Paper => "paper",
            FeatureSet::HysteresisAware => "hysteresis-aware",
            FeatureSet::HysteresisAwareTime => "hysteresis-aware+time",
        }
    }
}
