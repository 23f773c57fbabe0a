//! A grating's reflection spectrum tabulated once, then shifted: what every frame reads.

use super::grating::GratingDesign;

/// R(λ_B + x) of one design, tabulated over |x| ≤ `half_span_nm` in steps of `step_nm` and
/// read by linear interpolation (0 outside: a uniform grating's side lobes there are below
/// (κ/σ̂)², far under a detector's noise). A frame of a grating at λ_B(t) reads R(λ − λ_B(t)):
/// the shape is taken as the same at every λ_B, while the exact one scales with λ² — a width
/// change of 2·Δλ_B/λ_B (about 0.1 % for a 1 nm shift), symmetric, so no shift of the centre.
/// Linear interpolation errs by at most step²/8·|R''|, symmetric about λ_B as well.
#[derive(Clone, Debug)]
pub struct ReflectionProfile {
    step_nm: f64,
    half_span_nm: f64,
    values: Vec<f64>,
}

/// The default table step \[nm\] (0.5 pm: interpolation errors of order 10⁻⁶ of the peak on
/// a 0.3 nm FWHM grating).
pub const PROFILE_STEP_NM: f64 = 0.0005;

/// The default half-span of the table \[nm\].
pub const PROFILE_HALF_SPAN_NM: f64 = 5.0;

impl ReflectionProfile {
    /// Tabulate `design` about `bragg_nm`.
    pub fn tabulate(design: &GratingDesign, bragg_nm: f64, half_span_nm: f64, step_nm: f64) -> Self {
        let n = (half_span_nm / step_nm).ceil() as usize;
        let r = design.spectrum(bragg_nm);
        let values = (0..=2 * n).map(|k| r(bragg_nm + (k as f64 - n as f64) * step_nm)).collect();
        ReflectionProfile { step_nm, half_span_nm: n as f64 * step_nm, values }
    }

    /// R at offset `x_nm` from the Bragg wavelength (0 beyond the table, and for NaN).
    pub fn at(&self, x_nm: f64) -> f64 {
        if x_nm.is_nan() || x_nm.abs() >= self.half_span_nm {
            return 0.0;
        }
        let u = (x_nm + self.half_span_nm) / self.step_nm;
        let k = u.floor();
        let f = u - k;
        let k = k as usize;
        match (self.values.get(k), self.values.get(k + 1)) {
            (Some(a), Some(b)) => a + f * (b - a),
            (Some(a), None) => *a,
            _ => 0.0,
        }
    }

    /// The half-span of the table \[nm\].
    pub fn half_span_nm(&self) -> f64 {
        self.half_span_nm
    }
}
