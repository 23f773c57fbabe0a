//! What a field reading needs beyond the calibration's arithmetic: the zero of each grating's
//! shifts (λ_ref), the absolute clock of the calibration (the band's lead time), and the
//! calibration's output envelope and largest band (a plausibility check).
//!
//! A model is only right on shifts taken from the wavelengths it was calibrated against: a
//! field record zeroed on its own first reading is off by whatever the measurands were then
//! (a grating at 10 pm/°C zeroed 3.7 °C away reads 3.7 °C wrong, unflagged). So the model
//! carries λ_ref per grating and a tolerance, and a record that states another zero is refused.
//!
//! The output envelope and the largest band make a run-time plausibility check
//! ([`FieldContext::plausible`]): an estimate of a fitted output outside
//! `[lo − δ, hi + δ]`, δ = [`OUTPUT_MARGIN_OF_RANGE`] · (hi − lo) + [`OUTPUT_MARGIN_OF_BAND`] ·
//! band_max, or whose band (before a flagged sample's widening) is non-finite or at least
//! [`BAND_LIMIT_OF_MAX`] · band_max, carries [`crate::Flags::IMPLAUSIBLE`], a fault. A sample
//! whose inputs are inside their envelope gives such an estimate only from a wrong model; one
//! outside is flagged out-of-envelope anyway. An output whose band_max is 0 (a context not
//! known, as in a model built by hand) is checked only for a finite band.

use crate::error::Error;
use crate::layout::{head, Dims, MAX_GRATINGS, MAX_OUTPUTS};

/// Where a grating's reference wavelength λ_ref came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum ZeroSource {
    /// Not known: the record held shifts, not wavelengths (λ_ref is then 0).
    #[default]
    Unknown = 0,
    /// Given by the channel map (`ref_nm`).
    Map = 1,
    /// The record's first reading of the grating.
    FirstReading = 2,
    /// Taken from a model (`import --model`).
    Model = 3,
    /// The simulator's nominal Bragg wavelength.
    Simulated = 4,
}

impl ZeroSource {
    /// The one-byte code in a blob.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The source of a code, `None` for a code this version does not define.
    pub const fn from_code(code: u8) -> Option<ZeroSource> {
        Some(match code {
            0 => ZeroSource::Unknown,
            1 => ZeroSource::Map,
            2 => ZeroSource::FirstReading,
            3 => ZeroSource::Model,
            4 => ZeroSource::Simulated,
            _ => return None,
        })
    }

    /// A short lower-case name (`map`, `first reading`, …).
    pub const fn name(self) -> &'static str {
        match self {
            ZeroSource::Unknown => "unknown",
            ZeroSource::Map => "map",
            ZeroSource::FirstReading => "first reading",
            ZeroSource::Model => "model",
            ZeroSource::Simulated => "simulated",
        }
    }
}

/// The calibration's zero, clock and envelope of outputs, as a blob carries them (f64 where
/// f32 would not hold the number: λ_ref ≈ 1550 nm has a 0.12 pm step in f32, and Unix seconds
/// a 128 s one).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldContext {
    /// Reference wavelength λ_ref per grating \[nm\]: shift Δλ = (λ − λ_ref) · 1000 pm. 0 where
    /// unknown.
    pub lambda_ref_nm: [f64; MAX_GRATINGS],
    /// Where each λ_ref came from.
    pub lambda_ref_source: [ZeroSource; MAX_GRATINGS],
    /// Largest difference \[pm\] between a record's stated λ_ref and the model's that moves no
    /// output by more than a third of its cross-validated error: beyond it a record is refused.
    pub lambda_ref_tol_pm: f32,
    /// Absolute end of calibration, Unix seconds (UTC), when the calibration record had
    /// absolute time.
    pub cal_end_unix_s: Option<f64>,
    /// Largest lead time the cross-validation saw \[s\]: the band's lead when the stream's
    /// clock is unknown.
    pub lead_max_s: f32,
    /// Lowest reference value per output in the calibration batch (output unit).
    pub output_lo: [f32; MAX_OUTPUTS],
    /// Highest reference value per output in the calibration batch (output unit).
    pub output_hi: [f32; MAX_OUTPUTS],
    /// Largest 95 % half-width per output the calibration validated (at `lead_max_s`, unflagged),
    /// output unit.
    pub band_max: [f32; MAX_OUTPUTS],
}

impl FieldContext {
    /// Nothing known: no zero, no clock, no envelope (it does not validate for a fitted output).
    pub const fn unknown() -> FieldContext {
        FieldContext {
            lambda_ref_nm: [0.0; MAX_GRATINGS],
            lambda_ref_source: [ZeroSource::Unknown; MAX_GRATINGS],
            lambda_ref_tol_pm: 0.0,
            cal_end_unix_s: None,
            lead_max_s: 0.0,
            output_lo: [0.0; MAX_OUTPUTS],
            output_hi: [0.0; MAX_OUTPUTS],
            band_max: [0.0; MAX_OUTPUTS],
        }
    }

    /// λ_ref of grating `g` (0-based) \[nm\], `None` when unknown.
    pub fn lambda_ref(&self, g: usize) -> Option<f64> {
        match self.lambda_ref_source.get(g) {
            Some(ZeroSource::Unknown) | None => None,
            Some(_) => self.lambda_ref_nm.get(g).copied(),
        }
    }

    /// The plausible range of output `o`'s estimate and the band it must stay below, (lo, hi,
    /// band limit), in the output's unit ([`crate::field`] states the margins): unbounded
    /// (−∞, ∞, ∞) when the output's band_max is not positive.
    pub fn plausible(&self, o: usize) -> (f32, f32, f32) {
        let (lo, hi, b) = (
            self.output_lo.get(o).copied().unwrap_or(0.0),
            self.output_hi.get(o).copied().unwrap_or(0.0),
            self.band_max.get(o).copied().unwrap_or(0.0),
        );
        // `!(b > 0)`: also a NaN, which `validate` refuses anyway.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(b > 0.0) {
            return (f32::NEG_INFINITY, f32::INFINITY, f32::INFINITY);
        }
        let margin = OUTPUT_MARGIN_OF_RANGE * (hi - lo) + OUTPUT_MARGIN_OF_BAND * b;
        (lo - margin, hi + margin, BAND_LIMIT_OF_MAX * b)
    }

    /// Check the numbers for `dims`: a known λ_ref is a plausible wavelength (100–10 000 nm),
    /// an unknown one 0; the tolerance, lead and bands finite, ≥ 0 and within their
    /// [`crate::bounds`]; the end of calibration finite and within ±`UNIX_MAX_S`; each
    /// fitted output's envelope ordered and within ±`OUTPUT_MAX`.
    pub fn validate(&self, dims: &Dims, fitted: &[bool; MAX_OUTPUTS]) -> Result<(), Error> {
        let n = dims.gratings();
        for (&nm, &src) in head(&self.lambda_ref_nm, n).iter().zip(head(&self.lambda_ref_source, n)) {
            // Compared as bits: on a device without an f64 unit a float comparison would pull in
            // soft-float routines, and for non-negative doubles the bit order is the numeric one
            // (a negative value or NaN has bits above the range's).
            let bits = nm.to_bits();
            let ok = match src {
                ZeroSource::Unknown => bits == 0,
                _ => (LAMBDA_MIN_NM.to_bits()..=LAMBDA_MAX_NM.to_bits()).contains(&bits),
            };
            if !ok {
                return Err(Error::BadParameter { field: "field.lambda_ref_nm" });
            }
        }
        use crate::bounds::within;
        use crate::bounds::{INPUT_MAX, OUTPUT_MAX, TIME_MAX, UNIX_MAX_S};
        if !(within(self.lambda_ref_tol_pm, INPUT_MAX) && self.lambda_ref_tol_pm >= 0.0) {
            return Err(Error::BadParameter { field: "field.lambda_ref_tol_pm" });
        }
        if !(within(self.lead_max_s, TIME_MAX) && self.lead_max_s >= 0.0) {
            return Err(Error::BadParameter { field: "field.lead_max_s" });
        }
        // By bits, as λ_ref: |t| from the bits without the sign, which order as the magnitudes
        // do (NaN and infinities above every finite bound).
        let abs_bits = |t: f64| t.to_bits() & !(1u64 << 63);
        if self.cal_end_unix_s.is_some_and(|t| abs_bits(t) > UNIX_MAX_S.to_bits()) {
            return Err(Error::BadParameter { field: "field.cal_end_unix_s" });
        }
        let m = dims.n_outputs();
        for (((&lo, &hi), &b), &fit) in
            self.output_lo.iter().zip(self.output_hi.iter()).zip(self.band_max.iter()).zip(fitted.iter()).take(m)
        {
            if fit && !(within(lo, OUTPUT_MAX) && within(hi, OUTPUT_MAX) && lo <= hi) {
                return Err(Error::BadParameter { field: "field.output_envelope" });
            }
            if !(within(b, OUTPUT_MAX) && b >= 0.0) {
                return Err(Error::BadParameter { field: "field.band_max" });
            }
        }
        Ok(())
    }
}

/// Margin of the run-time output envelope on each side, as a fraction of the calibration's
/// output range (five times the input envelope's margin the trainer uses: an estimate this far
/// out with its inputs inside their envelope is not an extrapolation).
pub const OUTPUT_MARGIN_OF_RANGE: f32 = 0.5;
/// Margin of the run-time output envelope on each side, in largest bands: an estimate at the
/// edge of the calibration range may be off by its band, and an output held constant in
/// calibration has no range.
pub const OUTPUT_MARGIN_OF_BAND: f32 = 4.0;
/// An estimate's band (before the widening of a flagged sample) is implausible at this many
/// times the largest band the calibration validated: leverage out of distribution and a lead
/// beyond the validated one widen a sound model's band by a few times, not a hundred.
pub const BAND_LIMIT_OF_MAX: f32 = 100.0;

/// Lowest plausible Bragg wavelength \[nm\].
const LAMBDA_MIN_NM: f64 = 100.0;
/// Highest plausible Bragg wavelength \[nm\].
const LAMBDA_MAX_NM: f64 = 10_000.0;

/// Whether `x` is finite, from its exponent bits (no soft-float call on an f32-only device).
pub const fn f64_finite(x: f64) -> bool {
    (x.to_bits() >> 52) & 0x7ff != 0x7ff
}

impl Default for FieldContext {
    fn default() -> Self {
        Self::unknown()
    }
}
