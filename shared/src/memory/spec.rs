//! Which memory operators a model uses: the coefficients a blob carries.

use serde::{Deserialize, Serialize};

use crate::error::Error;
use crate::layout::{Dims, MAX_STAGE1, N_AMBIENT_TAUS, N_GRATING_TAUS, N_PLAYS};
use crate::real::Real;

/// The kinds of memory term, in the order of the memory vector m (see
/// [`Dims::memory_len`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum MemoryGroup {
    /// Δλ_i − EMA_τ(Δλ_i) \[pm\]: thermal lag, slow drift and the slow part of hysteresis.
    GratingHighPass,
    /// T_amb − EMA_τ(T_amb) [°C]: the reference thermometer's own lag.
    AmbientHighPass,
    /// Δλ_i − play_r(Δλ_i) \[pm\]: where the play operator sits after a reversal.
    Stop,
    /// [`crate::memory::DriftObserver`] [°C]: the common drift, temperature outputs only.
    DriftObserver,
}

impl MemoryGroup {
    /// All groups in memory-vector order.
    pub const ALL: [MemoryGroup; 4] =
        [MemoryGroup::GratingHighPass, MemoryGroup::AmbientHighPass, MemoryGroup::Stop, MemoryGroup::DriftObserver];

    /// Short name for reports and the command line.
    pub const fn name(self) -> &'static str {
        match self {
            MemoryGroup::GratingHighPass => "grating-high-pass",
            MemoryGroup::AmbientHighPass => "ambient-high-pass",
            MemoryGroup::Stop => "stop",
            MemoryGroup::DriftObserver => "drift-observer",
        }
    }

    /// Unit of the group's terms.
    pub const fn unit(self) -> &'static str {
        match self {
            MemoryGroup::GratingHighPass | MemoryGroup::Stop => "pm",
            MemoryGroup::AmbientHighPass | MemoryGroup::DriftObserver => "°C",
        }
    }
}

/// The memory operators of a model. A slot whose parameter is 0 is unused: its term is 0 and
/// its coefficients in Γ must be 0.
///
/// Memory vector layout ([`Dims::memory_len`] terms): grating high-passes (τ slot major,
/// grating minor), ambient high-passes (with ambient), stop terms (r slot major, grating minor),
/// the drift observer (with ambient and a temperature output). Slots the dims do not have must
/// be 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MemorySpec<F> {
    /// Time constants τ \[s\] of the grating high-passes Δλ_i − EMA_τ(Δλ_i) (0 = unused).
    pub grating_tau_s: [F; N_GRATING_TAUS],
    /// Time constants τ \[s\] of the ambient high-passes T_amb − EMA_τ(T_amb) (0 = unused).
    pub ambient_tau_s: [F; N_AMBIENT_TAUS],
    /// Half-widths r \[pm\] of the play operators of the stop terms (0 = unused).
    pub play_half_width_pm: [F; N_PLAYS],
    /// Drift observer: the thermometer's lag τl \[s\] (0 = no observer).
    pub observer_lag_s: F,
    /// Drift observer: smoothing τs \[s\] (> 0 when the observer is used).
    pub observer_smooth_s: F,
    /// Drift observer: grating temperature T_g [°C] = row · [Δλ_1..N pm, T_amb °C, 1] (the
    /// first [`Dims::stage1_len`] entries; the rest 0).
    pub observer_row: [F; MAX_STAGE1],
}

/// What one memory term is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TermInfo<F> {
    /// Its group.
    pub group: MemoryGroup,
    /// Grating index (0-based) for grating terms, 0 otherwise.
    pub grating: usize,
    /// τ \[s\] for high-passes, r \[pm\] for stop terms, τs \[s\] for the observer; 0 = unused.
    pub parameter: F,
}

impl<F: Real> MemorySpec<F> {
    /// No memory terms (the `paper` and `latch` variants).
    pub const fn off() -> Self {
        MemorySpec {
            grating_tau_s: [F::ZERO; N_GRATING_TAUS],
            ambient_tau_s: [F::ZERO; N_AMBIENT_TAUS],
            play_half_width_pm: [F::ZERO; N_PLAYS],
            observer_lag_s: F::ZERO,
            observer_smooth_s: F::ZERO,
            observer_row: [F::ZERO; MAX_STAGE1],
        }
    }

    /// What term `k` of the memory vector of a model with `dims` is (`None` beyond
    /// [`Dims::memory_len`]).
    pub fn term(&self, dims: &Dims, k: usize) -> Option<TermInfo<F>> {
        let info = |group, grating, parameter| Some(TermInfo { group, grating, parameter });
        let n = dims.gratings().max(1);
        if k < dims.mem_ambient() {
            info(MemoryGroup::GratingHighPass, k % n, *self.grating_tau_s.get(k / n)?)
        } else if k < dims.mem_stop() {
            info(MemoryGroup::AmbientHighPass, 0, *self.ambient_tau_s.get(k - dims.mem_ambient())?)
        } else if k < dims.mem_observer() {
            let j = k - dims.mem_stop();
            info(MemoryGroup::Stop, j % n, *self.play_half_width_pm.get(j / n)?)
        } else if k == dims.mem_observer() && dims.has_observer() {
            let on = self.observer_lag_s > F::ZERO;
            info(MemoryGroup::DriftObserver, 0, if on { self.observer_smooth_s } else { F::ZERO })
        } else {
            None
        }
    }

    /// Whether term `k` is computed (its slot is used).
    pub fn term_active(&self, dims: &Dims, k: usize) -> bool {
        self.term(dims, k).is_some_and(|t| t.parameter > F::ZERO)
    }

    /// Whether any slot is used.
    pub fn any(&self) -> bool {
        let on = |v: &F| *v > F::ZERO;
        self.grating_tau_s.iter().any(on)
            || self.ambient_tau_s.iter().any(on)
            || self.play_half_width_pm.iter().any(on)
            || self.observer_lag_s > F::ZERO
    }

    /// Every parameter finite and >= 0; an observer with a lag has a smoothing and a finite row;
    /// no ambient slot without the ambient input, no observer without its slot
    /// ([`Dims::has_observer`]).
    pub fn validate(&self, dims: &Dims) -> Result<(), Error> {
        let ok = |v: F| v.is_finite() && v >= F::ZERO;
        if !self.grating_tau_s.iter().all(|&v| ok(v)) {
            return Err(Error::BadParameter { field: "memory.grating_tau_s" });
        }
        if !self.ambient_tau_s.iter().all(|&v| ok(v)) {
            return Err(Error::BadParameter { field: "memory.ambient_tau_s" });
        }
        if !dims.ambient() && self.ambient_tau_s.iter().any(|&v| v != F::ZERO) {
            return Err(Error::BadParameter { field: "memory.ambient_tau_s" });
        }
        if !self.play_half_width_pm.iter().all(|&v| ok(v)) {
            return Err(Error::BadParameter { field: "memory.play_half_width_pm" });
        }
        if !(ok(self.observer_lag_s) && ok(self.observer_smooth_s)) {
            return Err(Error::BadParameter { field: "memory.observer" });
        }
        if self.observer_lag_s > F::ZERO && !dims.has_observer() {
            return Err(Error::BadParameter { field: "memory.observer" });
        }
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if self.observer_lag_s > F::ZERO && !(self.observer_smooth_s > F::ZERO) {
            return Err(Error::BadParameter { field: "memory.observer_smooth_s" });
        }
        if !self.observer_row.iter().all(|v| v.is_finite()) {
            return Err(Error::BadParameter { field: "memory.observer_row" });
        }
        Ok(())
    }

    /// The same spec in another precision.
    pub fn convert<G: Real>(&self) -> MemorySpec<G> {
        use crate::real::cast_array as c;
        MemorySpec {
            grating_tau_s: c(&self.grating_tau_s),
            ambient_tau_s: c(&self.ambient_tau_s),
            play_half_width_pm: c(&self.play_half_width_pm),
            observer_lag_s: G::from_real(self.observer_lag_s),
            observer_smooth_s: G::from_real(self.observer_smooth_s),
            observer_row: c(&self.observer_row),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::paper::{MEM_AMBIENT, MEM_OBSERVER, MEM_STOP, N_MEMORY};

    const D: Dims = Dims::PAPER;

    fn spec() -> MemorySpec<f64> {
        MemorySpec {
            grating_tau_s: [60.0, 0.0, 3600.0, 0.0, 0.0, 604_800.0],
            ambient_tau_s: [0.0, 600.0, 0.0, 0.0],
            play_half_width_pm: [0.0, 0.0, 7.5],
            observer_lag_s: 300.0,
            observer_smooth_s: 1800.0,
            observer_row: [0.125, 0.25, -0.375, 1.0, -20.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        }
    }

    #[test]
    fn terms_follow_the_layout() {
        let s = spec();
        let active: [usize; 15] = [
            0,
            1,
            2,
            6,
            7,
            8,
            15,
            16,
            17,
            MEM_AMBIENT + 1,
            MEM_STOP + 6,
            MEM_STOP + 7,
            MEM_STOP + 8,
            MEM_OBSERVER,
            MEM_OBSERVER,
        ];
        for k in 0..N_MEMORY {
            assert_eq!(s.term_active(&D, k), active.contains(&k), "term {k}");
        }
        assert_eq!(
            s.term(&D, 16),
            Some(TermInfo { group: MemoryGroup::GratingHighPass, grating: 1, parameter: 604_800.0 })
        );
        assert_eq!(
            s.term(&D, MEM_AMBIENT + 1),
            Some(TermInfo { group: MemoryGroup::AmbientHighPass, grating: 0, parameter: 600.0 })
        );
        assert_eq!(s.term(&D, MEM_STOP + 8), Some(TermInfo { group: MemoryGroup::Stop, grating: 2, parameter: 7.5 }));
        assert_eq!(
            s.term(&D, MEM_OBSERVER),
            Some(TermInfo { group: MemoryGroup::DriftObserver, grating: 0, parameter: 1800.0 })
        );
        assert_eq!(s.term(&D, N_MEMORY), None);
        assert!(s.any());
        // The observer is used only with a lag; its smoothing alone does not switch it on.
        let mut t = MemorySpec::<f64>::off();
        t.observer_smooth_s = 100.0;
        assert!(!t.term_active(&D, MEM_OBSERVER));
        assert_eq!(t.term(&D, MEM_OBSERVER).map(|i| i.parameter), Some(0.0));
        assert!(!t.any());
        assert_eq!(t.validate(&D), Ok(()));
    }

    #[test]
    fn validate_names_each_bad_field() {
        assert_eq!(spec().validate(&D), Ok(()));
        assert_eq!(MemorySpec::<f32>::off().validate(&D), Ok(()));
        type Edit = fn(&mut MemorySpec<f64>);
        let cases: [(&str, Edit); 10] = [
            ("memory.grating_tau_s", |s| s.grating_tau_s[1] = -1.0),
            ("memory.grating_tau_s", |s| s.grating_tau_s[5] = f64::INFINITY),
            ("memory.ambient_tau_s", |s| s.ambient_tau_s[3] = f64::NAN),
            ("memory.ambient_tau_s", |s| s.ambient_tau_s[0] = -600.0),
            ("memory.play_half_width_pm", |s| s.play_half_width_pm[0] = -0.5),
            ("memory.observer", |s| s.observer_lag_s = -1.0),
            ("memory.observer", |s| s.observer_smooth_s = f64::NAN),
            ("memory.observer_smooth_s", |s| s.observer_smooth_s = 0.0),
            ("memory.observer_row", |s| s.observer_row[4] = f64::NEG_INFINITY),
            ("memory.observer_row", |s| s.observer_row[0] = f64::NAN),
        ];
        for (field, f) in cases {
            let mut s = spec();
            f(&mut s);
            assert_eq!(s.validate(&D), Err(Error::BadParameter { field }), "{field}");
            assert_eq!(s.convert::<f32>().validate(&D), Err(Error::BadParameter { field }), "{field} (f32)");
        }
    }

    #[test]
    fn convert_round_trips_exact_values() {
        let s = spec();
        assert_eq!(s.convert::<f32>().convert::<f64>(), s);
        assert_eq!(s.convert::<f64>(), s);
    }
}
