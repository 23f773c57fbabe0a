//! Dimensions of the compensator and the layout of its feature vectors.
//!
//! A model maps `N` gratings (1 ≤ N ≤ [`MAX_GRATINGS`]) plus an optional ambient thermometer to
//! `M` measurands (1 ≤ M ≤ [`MAX_OUTPUTS`]): [`Dims`], carried by the model and its blob. The
//! device types hold fixed-size arrays sized to these compile-time capacities, of which only
//! the first N (gratings) or M (outputs) entries are used; unused entries are zero. The number
//! of RBF centres `K` is a const generic of the device types.
//!
//! Every vector's layout follows the dims (DESIGN §4):
//!
//! - stage 1 regressors: [Δλ_1..N, T_amb (with ambient), 1];
//! - polynomial terms on the standardised first guesses g_1..M: [1, g_1..g_M, g_1²..g_M², then
//!   g_i·g_j for i < j in lexicographic order] (for M = 3 the paper's
//!   [1, T, ε, p, T², ε², p², Tε, Tp, εp]);
//! - envelope inputs: [Δλ_1..N, T_amb (with ambient)];
//! - RBF inputs z: [Δλ_1..N, T_amb (with ambient), t, latch_1..N];
//! - memory vector m: grating high-passes (τ slot major, grating minor), ambient high-passes
//!   (with ambient), stop terms (r slot major, grating minor), the drift observer (with ambient
//!   and a temperature output).
//!
//! [`paper`] keeps the paper's fixed layout (3 gratings, ambient, T/ε/p) as constants for code
//! that handles only that set-up (the paper-preset benchmarks, the test kit's synthetic
//! installation).

use serde::{Deserialize, Serialize};

use crate::error::Error;

/// Capacity: gratings (wavelength inputs) a model may have.
pub const MAX_GRATINGS: usize = 8;
/// Capacity: measurands (outputs) a model may have.
pub const MAX_OUTPUTS: usize = 4;
/// Capacity: stage-1 regressors [Δλ_1..N, T_amb, 1].
pub const MAX_STAGE1: usize = MAX_GRATINGS + 2;
/// Capacity: polynomial terms (degree 2 in `MAX_OUTPUTS` guesses).
pub const MAX_POLY: usize = poly_len(MAX_OUTPUTS);
/// Capacity: inputs checked against the calibration envelope [Δλ_1..N, T_amb] (time always
/// extrapolates, so it is never checked).
pub const MAX_ENVELOPE: usize = MAX_GRATINGS + 1;
/// Capacity: RBF inputs [Δλ_1..N, T_amb, t, latch_1..N].
pub const MAX_Z: usize = 2 * MAX_GRATINGS + 2;
/// Time-constant slots of the grating high-passes Δλ_i − EMA_τ(Δλ_i).
pub const N_GRATING_TAUS: usize = 6;
/// Time-constant slots of the ambient high-passes T_amb − EMA_τ(T_amb).
pub const N_AMBIENT_TAUS: usize = 4;
/// Half-width slots of the stop terms Δλ_i − play_r(Δλ_i).
pub const N_PLAYS: usize = 3;
/// Capacity: memory terms m (see [`Dims::memory_len`]).
pub const MAX_MEMORY: usize = MAX_GRATINGS * (N_GRATING_TAUS + N_PLAYS) + N_AMBIENT_TAUS + 1;
/// Number of eigen-directions of `(ΨᵀΨ + αI)⁻¹` kept for the predictive variance: those with
/// the smallest eigenvalues g of `ΨᵀΨ + αI`, which carry the leverage out of distribution
/// (exact when `K <= VAR_RANK`; see `ModelParams::var_inv_g_tail` for the rest).
pub const VAR_RANK: usize = 4;
/// Two-sided 95 % normal quantile used for the band.
pub const Z95: f64 = 1.959_963_984_540_054;

/// Polynomial terms of degree ≤ 2 in `m` variables: 1 + m + m(m+1)/2.
pub const fn poly_len(m: usize) -> usize {
    1 + m + m * (m + 1) / 2
}

/// What a measurand is: its physical quantity, which fixes its unit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum Quantity {
    /// Temperature [°C].
    #[default]
    Temperature = 0,
    /// Strain \[µε\].
    Strain = 1,
    /// Pressure \[kPa\].
    Pressure = 2,
}

impl Quantity {
    /// Stable code stored in the model blob.
    pub const fn code(self) -> u8 {
        self as u8
    }
    /// The quantity for a blob code, `None` when unknown.
    pub const fn from_code(code: u8) -> Option<Self> {
        match code {
            0 => Some(Quantity::Temperature),
            1 => Some(Quantity::Strain),
            2 => Some(Quantity::Pressure),
            _ => None,
        }
    }
    /// Short channel stem ("T", "strain", "p").
    pub const fn stem(self) -> &'static str {
        match self {
            Quantity::Temperature => "T",
            Quantity::Strain => "strain",
            Quantity::Pressure => "p",
        }
    }
    /// Unit for display ("°C", "µε", "kPa").
    pub const fn unit(self) -> &'static str {
        match self {
            Quantity::Temperature => "°C",
            Quantity::Strain => "µε",
            Quantity::Pressure => "kPa",
        }
    }
    /// Unit as it appears in a column name ("C", "ue", "kPa").
    pub const fn column_unit(self) -> &'static str {
        match self {
            Quantity::Temperature => "C",
            Quantity::Strain => "ue",
            Quantity::Pressure => "kPa",
        }
    }
}

/// One measurand of a model: its quantity and which one of that quantity it is (1-based: the
/// second strain channel is `Output { quantity: Strain, index: 2 }`, named `strain2_ue`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Output {
    /// Physical quantity (fixes the unit).
    pub quantity: Quantity,
    /// 1 for the first of its quantity, 2 for the second, …
    pub index: u8,
}

impl Default for Output {
    fn default() -> Self {
        Output::first(Quantity::Temperature)
    }
}

impl Output {
    /// The first output of `quantity`.
    pub const fn first(quantity: Quantity) -> Self {
        Output { quantity, index: 1 }
    }

    /// Short channel name: `T`, `strain`, `p`, `strain2`, … (table columns, JSON keys).
    pub fn channel(&self) -> heapless::String<16> {
        let mut s = heapless::String::new();
        let _ = s.push_str(self.quantity.stem());
        if self.index != 1 {
            push_u8(&mut s, self.index);
        }
        s
    }

    /// Dataset column name: `T_C`, `strain_ue`, `strain2_ue`, `p_kPa`, …
    pub fn column(&self) -> heapless::String<16> {
        let mut s = self.channel();
        let _ = s.push('_');
        let _ = s.push_str(self.quantity.column_unit());
        s
    }

    /// Unit for display.
    pub const fn unit(&self) -> &'static str {
        self.quantity.unit()
    }
}

fn push_u8<const N: usize>(s: &mut heapless::String<N>, v: u8) {
    if v >= 100 {
        let _ = s.push(char::from(b'0' + v / 100));
    }
    if v >= 10 {
        let _ = s.push(char::from(b'0' + (v / 10) % 10));
    }
    let _ = s.push(char::from(b'0' + v % 10));
}

/// The dimensions of a model: N gratings, whether an ambient thermometer is an input, and its
/// M measurands in output order. Only the first `n_outputs` entries of `outputs` are used
/// (the rest are the default and ignored).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Dims {
    gratings: u8,
    ambient: bool,
    n_outputs: u8,
    outputs: [Output; MAX_OUTPUTS],
}

impl Default for Dims {
    fn default() -> Self {
        Dims::PAPER
    }
}

impl Dims {
    /// The paper's set-up: 3 gratings, ambient, outputs T [°C], ε \[µε\], p \[kPa\].
    pub const PAPER: Dims = Dims {
        gratings: 3,
        ambient: true,
        n_outputs: 3,
        outputs: [
            Output::first(Quantity::Temperature),
            Output::first(Quantity::Strain),
            Output::first(Quantity::Pressure),
            Output::first(Quantity::Temperature),
        ],
    };

    /// No model: 0 gratings and outputs, all zero bytes (what an unloaded compensator holds,
    /// so that a `static` of it stays in `.bss`). Not a valid model's dims.
    pub(crate) const NONE: Dims = Dims {
        gratings: 0,
        ambient: false,
        n_outputs: 0,
        outputs: [Output { quantity: Quantity::Temperature, index: 0 }; MAX_OUTPUTS],
    };

    /// Dims for `gratings` gratings, with or without ambient, and `outputs` in output order.
    /// A count beyond the capacity is [`Error::OverCapacity`] naming both; zero gratings or
    /// outputs, an output index of 0 or the same output twice is [`Error::BadParameter`].
    pub fn new(gratings: usize, ambient: bool, outputs: &[Output]) -> Result<Self, Error> {
        if gratings > MAX_GRATINGS {
            return Err(Error::OverCapacity {
                field: "gratings",
                found: sat_u16(gratings),
                capacity: MAX_GRATINGS as u16,
            });
        }
        if outputs.len() > MAX_OUTPUTS {
            return Err(Error::OverCapacity {
                field: "measurands",
                found: sat_u16(outputs.len()),
                capacity: MAX_OUTPUTS as u16,
            });
        }
        if gratings == 0 {
            return Err(Error::BadParameter { field: "dims.gratings" });
        }
        if outputs.is_empty() {
            return Err(Error::BadParameter { field: "dims.measurands" });
        }
        let mut out = [Output::default(); MAX_OUTPUTS];
        for (i, (o, &src)) in out.iter_mut().zip(outputs.iter()).enumerate() {
            if src.index == 0 || outputs.iter().take(i).any(|&p| p == src) {
                return Err(Error::BadParameter { field: "dims.outputs" });
            }
            *o = src;
        }
        Ok(Dims { gratings: gratings as u8, ambient, n_outputs: outputs.len() as u8, outputs: out })
    }

    /// N, the number of gratings.
    #[inline(always)]
    pub const fn gratings(&self) -> usize {
        self.gratings as usize
    }
    /// Whether the ambient temperature is an input.
    #[inline(always)]
    pub const fn ambient(&self) -> bool {
        self.ambient
    }
    /// M, the number of measurands.
    #[inline(always)]
    pub const fn n_outputs(&self) -> usize {
        self.n_outputs as usize
    }
    /// The measurands, in output order.
    pub fn outputs(&self) -> &[Output] {
        head(&self.outputs, self.n_outputs())
    }
    /// Index of the first output of `quantity`, if any.
    pub fn position(&self, quantity: Quantity) -> Option<usize> {
        self.outputs().iter().position(|o| o.quantity == quantity)
    }
    /// Whether the model has the drift observer slot: it compares the gratings' temperature
    /// with the thermometer, so it needs the ambient input and a temperature output.
    pub fn has_observer(&self) -> bool {
        self.ambient && self.position(Quantity::Temperature).is_some()
    }
    /// Stage-1 regressors: N + ambient + 1 (the last is the constant).
    #[inline(always)]
    pub const fn stage1_len(&self) -> usize {
        self.gratings() + self.ambient as usize + 1
    }
    /// Polynomial terms: 1 + M + M(M+1)/2.
    #[inline(always)]
    pub const fn poly_len(&self) -> usize {
        poly_len(self.n_outputs())
    }
    /// Envelope inputs: N + ambient.
    #[inline(always)]
    pub const fn envelope_len(&self) -> usize {
        self.gratings() + self.ambient as usize
    }
    /// RBF inputs: N + ambient + 1 (time) + N (latches).
    #[inline(always)]
    pub const fn z_len(&self) -> usize {
        2 * self.gratings() + self.ambient as usize + 1
    }
    /// Index of the time input in z.
    #[inline(always)]
    pub const fn z_time(&self) -> usize {
        self.gratings() + self.ambient as usize
    }
    /// Index of the first direction latch in z.
    #[inline(always)]
    pub const fn z_latch(&self) -> usize {
        self.z_time() + 1
    }
    /// Index of the first ambient high-pass in m (= the grating high-passes' count).
    pub const fn mem_ambient(&self) -> usize {
        self.gratings() * N_GRATING_TAUS
    }
    /// Index of the first stop term in m.
    pub const fn mem_stop(&self) -> usize {
        self.mem_ambient() + if self.ambient { N_AMBIENT_TAUS } else { 0 }
    }
    /// Index of the drift observer in m (when [`Dims::has_observer`]).
    pub const fn mem_observer(&self) -> usize {
        self.mem_stop() + self.gratings() * N_PLAYS
    }
    /// Memory terms m: N·(grating τ slots + play slots), the ambient slots with ambient, and
    /// the observer when the model has one.
    pub fn memory_len(&self) -> usize {
        self.mem_observer() + usize::from(self.has_observer())
    }
    /// Which RBF inputs (of `MAX_Z`, only the first [`Dims::z_len`] exist) `fs` uses.
    pub fn z_active(&self, fs: FeatureSet) -> [bool; MAX_Z] {
        let mut on = [false; MAX_Z];
        for (i, o) in on.iter_mut().enumerate().take(self.z_len()) {
            *o = if i == self.z_time() {
                fs.uses_time()
            } else if i >= self.z_latch() {
                fs.uses_latch()
            } else {
                true
            };
        }
        on
    }
    /// Names of the RBF inputs with units, e.g. `dl2 [pm]`, `T_amb [°C]`, `t [s]`, `latch2`.
    pub fn z_name(&self, i: usize) -> heapless::String<16> {
        let mut s = heapless::String::new();
        if i < self.gratings() {
            let _ = s.push_str("dl");
            push_u8(&mut s, (i + 1) as u8);
            let _ = s.push_str(" [pm]");
        } else if self.ambient && i == self.gratings() {
            let _ = s.push_str("T_amb [°C]");
        } else if i == self.z_time() {
            let _ = s.push_str("t [s]");
        } else if i < self.z_len() {
            let _ = s.push_str("latch");
            push_u8(&mut s, (i - self.z_latch() + 1) as u8);
        }
        s
    }
    /// The variables (i, j) of polynomial term `k` (`None` for the constant and beyond the
    /// terms): a linear term is (i, None), a square (i, Some(i)), a cross product (i, Some(j)).
    pub fn poly_term(&self, k: usize) -> Option<(usize, Option<usize>)> {
        let m = self.n_outputs();
        if k == 0 || k >= self.poly_len() {
            return None;
        }
        if k <= m {
            return Some((k - 1, None));
        }
        if k <= 2 * m {
            return Some((k - m - 1, Some(k - m - 1)));
        }
        let mut c = 2 * m + 1;
        for i in 0..m {
            for j in i + 1..m {
                if c == k {
                    return Some((i, Some(j)));
                }
                c += 1;
            }
        }
        None
    }
}

/// Which inputs feed the RBF residual.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[repr(u8)]
pub enum FeatureSet {
    /// Paper Eq. 5: z = [Δλ_1..N, T_amb, t].
    Paper = 0,
    /// z = [Δλ_1..N, T_amb, latch_1..N] (the default).
    #[default]
    HysteresisAware = 1,
    /// z = [Δλ_1..N, T_amb, t, latch_1..N], when cross-validation keeps time.
    HysteresisAwareTime = 2,
}

impl FeatureSet {
    /// All feature sets, in code order.
    pub const ALL: [FeatureSet; 3] = [FeatureSet::Paper, FeatureSet::HysteresisAware, FeatureSet::HysteresisAwareTime];

    /// Whether each input of the paper layout ([`paper::Z_DIMS`]) is used.
    pub const fn active(self) -> [bool; paper::Z_DIMS] {
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

/// `a` padded with zeros (or cut) to `C` entries: a fixed-layout vector into a capacity-sized
/// one, or back.
pub fn pad<T: Copy + Default, const N: usize, const C: usize>(a: &[T; N]) -> [T; C] {
    let mut out = [T::default(); C];
    for (o, &v) in out.iter_mut().zip(a.iter()) {
        *o = v;
    }
    out
}

/// [`pad`] for a matrix (rows and columns).
pub fn pad2<T: Copy + Default, const R: usize, const N: usize, const R2: usize, const C: usize>(
    a: &[[T; N]; R],
) -> [[T; C]; R2] {
    let mut out = [[T::default(); C]; R2];
    for (o, r) in out.iter_mut().zip(a.iter()) {
        *o = pad(r);
    }
    out
}

/// The first `n` entries of `a` (all of it when `n` exceeds its length).
#[inline(always)]
pub fn head<T>(a: &[T], n: usize) -> &[T] {
    a.get(..n).unwrap_or(a)
}

/// [`head`], mutable.
#[inline(always)]
pub fn head_mut<T>(a: &mut [T], n: usize) -> &mut [T] {
    let len = a.len();
    match a.get_mut(..n.min(len)) {
        Some(h) => h,
        None => &mut [],
    }
}

fn sat_u16(v: usize) -> u16 {
    u16::try_from(v).unwrap_or(u16::MAX)
}

/// The paper's fixed layout (3 gratings, ambient, outputs T, ε, p: [`Dims::PAPER`]) as
/// constants, for code that handles only that set-up (the paper-preset benchmarks, the test
/// kit's synthetic installation).
pub mod paper {
    use super::{poly_len, Dims, N_AMBIENT_TAUS, N_GRATING_TAUS, N_PLAYS};

    /// Gratings.
    pub const N_GRATINGS: usize = 3;
    /// Outputs: temperature [°C], strain \[µε\], pressure \[kPa\], in that order.
    pub const N_OUTPUTS: usize = 3;
    /// Stage-1 regressors: Δλ1..3 \[pm\], T_amb [°C], 1.
    pub const N_STAGE1: usize = 5;
    /// Polynomial terms of paper Eq. 3: [1, T, ε, p, T², ε², p², Tε, Tp, εp].
    pub const N_POLY: usize = poly_len(N_OUTPUTS);
    /// Envelope inputs: Δλ1..3 \[pm\], T_amb [°C].
    pub const N_ENVELOPE: usize = 4;
    /// RBF inputs: [Δλ1, Δλ2, Δλ3, T_amb, t, latch1, latch2, latch3].
    pub const Z_DIMS: usize = 8;
    /// Index of the time input in z.
    pub const Z_TIME: usize = 4;
    /// Index of the first direction latch in z.
    pub const Z_LATCH: usize = 5;
    /// Index of the first grating high-pass in m.
    pub const MEM_GRATING: usize = 0;
    /// Index of the first ambient high-pass in m.
    pub const MEM_AMBIENT: usize = N_GRATINGS * N_GRATING_TAUS;
    /// Index of the first stop term in m.
    pub const MEM_STOP: usize = MEM_AMBIENT + N_AMBIENT_TAUS;
    /// Index of the drift observer in m.
    pub const MEM_OBSERVER: usize = MEM_STOP + N_GRATINGS * N_PLAYS;
    /// Memory terms m.
    pub const N_MEMORY: usize = MEM_OBSERVER + 1;
    /// Short names of the outputs, in output order.
    pub const CHANNELS: [&str; N_OUTPUTS] = ["T", "strain", "p"];
    /// Units of the outputs, in output order.
    pub const UNITS: [&str; N_OUTPUTS] = ["°C", "µε", "kPa"];
    /// Names of the RBF inputs with units, in `Z_DIMS` order.
    pub const Z_NAMES: [&str; Z_DIMS] =
        ["dl1 [pm]", "dl2 [pm]", "dl3 [pm]", "T_amb [°C]", "t [s]", "latch1", "latch2", "latch3"];
    /// Names of the polynomial terms in `N_POLY` order.
    pub const POLY_NAMES: [&str; N_POLY] = ["1", "T", "ε", "p", "T²", "ε²", "p²", "Tε", "Tp", "εp"];

    const _: () = assert!(Dims::PAPER.gratings() == N_GRATINGS);
    const _: () = assert!(Dims::PAPER.n_outputs() == N_OUTPUTS);
    const _: () = assert!(Dims::PAPER.stage1_len() == N_STAGE1);
    const _: () = assert!(Dims::PAPER.poly_len() == N_POLY);
    const _: () = assert!(Dims::PAPER.envelope_len() == N_ENVELOPE);
    const _: () = assert!(Dims::PAPER.z_len() == Z_DIMS);
    const _: () = assert!(Dims::PAPER.z_time() == Z_TIME);
    const _: () = assert!(Dims::PAPER.z_latch() == Z_LATCH);
    const _: () = assert!(Dims::PAPER.mem_stop() == MEM_STOP);
    const _: () = assert!(Dims::PAPER.mem_observer() == MEM_OBSERVER);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_dims_and_names() {
        let d = Dims::PAPER;
        assert_eq!(d.memory_len(), paper::N_MEMORY);
        assert_eq!(paper::N_MEMORY, 32);
        for (i, n) in paper::Z_NAMES.iter().enumerate() {
            assert_eq!(d.z_name(i).as_str(), *n);
        }
        let names: std::vec::Vec<_> = d.outputs().iter().map(|o| o.column()).collect();
        assert_eq!(names, ["T_C", "strain_ue", "p_kPa"]);
        assert_eq!(Output { quantity: Quantity::Strain, index: 2 }.column().as_str(), "strain2_ue");
        // Paper Eq. 3 order.
        let terms: std::vec::Vec<_> = (0..d.poly_len()).map(|k| d.poly_term(k)).collect();
        assert_eq!(
            terms,
            [
                None,
                Some((0, None)),
                Some((1, None)),
                Some((2, None)),
                Some((0, Some(0))),
                Some((1, Some(1))),
                Some((2, Some(2))),
                Some((0, Some(1))),
                Some((0, Some(2))),
                Some((1, Some(2))),
            ]
        );
        for fs in FeatureSet::ALL {
            assert_eq!(pad::<bool, 8, MAX_Z>(&fs.active()), d.z_active(fs));
        }
    }

    #[test]
    fn dims_follow_n_and_m() {
        let s = Output::first(Quantity::Strain);
        let d = Dims::new(2, false, &[Output::first(Quantity::Temperature), s]).unwrap();
        assert_eq!((d.stage1_len(), d.poly_len(), d.envelope_len(), d.z_len()), (3, 6, 2, 5));
        assert!(!d.has_observer());
        assert_eq!(d.memory_len(), 2 * 6 + 2 * 3);
        let four = [
            Output::first(Quantity::Temperature),
            s,
            Output { quantity: Quantity::Strain, index: 2 },
            Output::first(Quantity::Pressure),
        ];
        let d = Dims::new(8, true, &four).unwrap();
        assert_eq!((d.stage1_len(), d.poly_len(), d.z_len(), d.memory_len()), (10, 15, 18, MAX_MEMORY));
        assert_eq!(d.poly_term(14), Some((2, Some(3))));
        assert_eq!(Dims::new(9, true, &four), Err(Error::OverCapacity { field: "gratings", found: 9, capacity: 8 }));
        assert_eq!(Dims::new(1, true, &[]), Err(Error::BadParameter { field: "dims.measurands" }));
        assert_eq!(Dims::new(1, true, &[s, s]), Err(Error::BadParameter { field: "dims.outputs" }));
        // Without a temperature output there is no observer even with ambient.
        assert!(!Dims::new(1, true, &[s]).unwrap().has_observer());
    }
}
