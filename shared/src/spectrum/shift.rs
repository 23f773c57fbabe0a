//! A grating's reference wavelength, for the shift Δλ of a peak in f32.

use crate::real::Real;

/// λ_ref \[nm\] as the sum of two reals, `hi + lo` (hi the nearest value, lo the rest), so that
/// Δλ = (λ − λ_ref)·1000 pm is computed in f32 without losing λ_ref's digits: at 1550 nm an
/// f32 steps by 0.12 pm, and λ_ref rounded to it would shift every reading by up to 0.06 pm.
/// λ − hi is exact (both near 1550 nm), so the only rounding is that of the peak itself.
///
/// The host splits the model's λ_ref ([`crate::FieldContext::lambda_ref`], f64) with
/// [`ShiftRef::from_nm`] and sends both halves; the device never touches an f64.
///
/// ```
/// use fbg_shared::spectrum::ShiftRef;
/// let r = ShiftRef::<f32>::from_nm(1550.123_456_7);
/// let dl = r.shift_pm(1550.2f32);
/// assert!((f64::from(dl) - (f64::from(1550.2f32) - 1550.123_456_7) * 1000.0).abs() < 1e-3);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShiftRef<R> {
    /// λ_ref rounded to `R` \[nm\].
    pub hi_nm: R,
    /// λ_ref − `hi_nm` \[nm\].
    pub lo_nm: R,
}

impl<R: Real> ShiftRef<R> {
    /// Split λ_ref \[nm\].
    pub fn from_nm(lambda_ref_nm: f64) -> Self {
        let hi_nm = R::from_f64(lambda_ref_nm);
        ShiftRef { hi_nm, lo_nm: R::from_f64(lambda_ref_nm - hi_nm.to_f64()) }
    }

    /// Δλ = (λ − λ_ref)·1000 \[pm\] of a peak at `wavelength_nm` (NaN stays NaN).
    pub fn shift_pm(&self, wavelength_nm: R) -> R {
        ((wavelength_nm - self.hi_nm) - self.lo_nm) * R::from_f64(1000.0)
    }
}
