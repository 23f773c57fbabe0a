//! Plausible magnitudes of what a dataset holds: wavelengths (absolute or shifts, in nm or pm)
//! and the interrogator's ambient temperature. The importers check every cell against them
//! (`check_units` in the map), and the dataset reader checks a CSV with the same words.

use serde::Deserialize;

use crate::error::ShortNumber;

/// Plausible absolute FBG wavelengths \[nm\].
pub(crate) const NM_RANGE: (f64, f64) = (400.0, 2000.0);
/// Largest plausible shift \[pm\]: 10 nm is beyond any grating's range in a WDM layout.
pub(crate) const MAX_SHIFT_PM: f64 = 10_000.0;
/// Plausible interrogator ambient temperatures [°C].
pub(crate) const AMBIENT_RANGE_C: (f64, f64) = (-80.0, 200.0);

/// The unit of a wavelength column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WlUnit {
    /// Absolute wavelength \[nm\].
    Nm,
    /// Absolute wavelength \[pm\].
    Pm,
    /// Shift from the reference condition \[pm\].
    ShiftPm,
    /// Shift from the reference condition \[nm\].
    ShiftNm,
}

impl WlUnit {
    pub fn name(self) -> &'static str {
        match self {
            WlUnit::Nm => "nm",
            WlUnit::Pm => "pm",
            WlUnit::ShiftPm => "shift_pm",
            WlUnit::ShiftNm => "shift_nm",
        }
    }
    pub(crate) fn is_shift(self) -> bool {
        matches!(self, WlUnit::ShiftPm | WlUnit::ShiftNm)
    }
    /// A cell in this unit → absolute nm (absolute units) or shift pm (shift units).
    pub fn convert(self, v: f64) -> f64 {
        match self {
            WlUnit::Nm | WlUnit::ShiftPm => v,
            WlUnit::Pm => v * 1e-3,
            WlUnit::ShiftNm => v * 1e3,
        }
    }
}

/// Check one wavelength cell (already in the column's unit) for magnitude; the error says what
/// the value looks like and which map key to change.
pub(crate) fn check_wavelength(unit: WlUnit, v: f64, key: &str) -> Result<(), String> {
    // A cell can be 1e308: printed short, not as 309 digits.
    let n = ShortNumber(v);
    let nm = |x: f64| (NM_RANGE.0..=NM_RANGE.1).contains(&x);
    let pm = |x: f64| (NM_RANGE.0 * 1e3..=NM_RANGE.1 * 1e3).contains(&x);
    let set = |u: &str| format!("map key `{key}`: set it to \"{u}\"");
    match unit {
        WlUnit::Nm if nm(v) => Ok(()),
        WlUnit::Nm if pm(v) => Err(format!("{n} is declared nm but is pm-scale (absolute wavelengths are {}–{} nm); {}", NM_RANGE.0, NM_RANGE.1, set("pm"))),
        WlUnit::Nm if v.abs() < NM_RANGE.0 => Err(format!(
            "{n} is declared as an absolute wavelength in nm but looks like a shift (absolute wavelengths are {}–{} nm); {}",
            NM_RANGE.0, NM_RANGE.1, set("shift_pm` or `shift_nm")
        )),
        WlUnit::Nm => Err(format!("{n} is not a wavelength in nm ({}–{} nm); check `{key}`", NM_RANGE.0, NM_RANGE.1)),
        WlUnit::Pm if pm(v) => Ok(()),
        WlUnit::Pm if nm(v) => Err(format!("{n} is declared pm but is nm-scale; {}", set("nm"))),
        WlUnit::Pm if v.abs() < NM_RANGE.0 * 1e3 => Err(format!(
            "{n} is declared as an absolute wavelength in pm but looks like a shift (absolute wavelengths are {}–{} pm); {}",
            NM_RANGE.0 * 1e3, NM_RANGE.1 * 1e3, set("shift_pm")
        )),
        WlUnit::Pm => Err(format!("{n} is not a wavelength in pm; check `{key}`")),
        WlUnit::ShiftPm if v.abs() <= MAX_SHIFT_PM => Ok(()),
        WlUnit::ShiftNm if v.abs() * 1e3 <= MAX_SHIFT_PM => Ok(()),
        WlUnit::ShiftPm | WlUnit::ShiftNm if nm(v) => Err(format!(
            "{n} is declared as a shift ({}) but looks like an absolute wavelength in nm; {}",
            unit.name(),
            set("nm")
        )),
        WlUnit::ShiftPm | WlUnit::ShiftNm if pm(v) => Err(format!(
            "{n} is declared as a shift ({}) but looks like an absolute wavelength in pm; {}",
            unit.name(),
            set("pm")
        )),
        WlUnit::ShiftPm | WlUnit::ShiftNm => Err(format!(
            "{n} ({}) is a shift beyond {} nm, which no grating reaches; check `{key}`",
            unit.name(),
            MAX_SHIFT_PM / 1e3
        )),
    }
}

/// A whole shift column that never leaves the band of absolute wavelengths in nm, with a
/// relative spread under 1 %, holds absolute wavelengths (per cell it cannot be told from a
/// large shift).
pub(crate) fn looks_absolute_nm(values: &[f64]) -> bool {
    let mut a = AbsNmCheck::default();
    values.iter().for_each(|&v| a.push(v));
    a.looks_absolute_nm()
}

/// The message for a shift column that [`looks_absolute_nm`], naming the map key to change.
pub(crate) fn absolute_nm_column_message(values: &[f64], key: &str) -> String {
    let mut a = AbsNmCheck::default();
    values.iter().for_each(|&v| a.push(v));
    a.message(key)
}

/// [`looks_absolute_nm`] one value at a time, in a few numbers (for a column that is read as a
/// stream and never held).
#[derive(Clone, Copy, Debug)]
pub(crate) struct AbsNmCheck {
    /// Finite values seen.
    n: usize,
    /// Whether every one of them lies in the band of absolute wavelengths.
    in_band: bool,
    lo: f64,
    hi: f64,
    sum: f64,
    first: f64,
}

impl Default for AbsNmCheck {
    fn default() -> Self {
        // `-0.0`: the start of `Iterator::sum` for floats, so the mean's bits are the same.
        AbsNmCheck { n: 0, in_band: true, lo: f64::INFINITY, hi: f64::NEG_INFINITY, sum: -0.0, first: f64::NAN }
    }
}

impl AbsNmCheck {
    /// Take one value of the column (a non-finite one is a gap and ignored).
    pub fn push(&mut self, x: f64) {
        if !x.is_finite() {
            return;
        }
        if self.n == 0 {
            self.first = x;
        }
        self.n += 1;
        self.in_band &= (NM_RANGE.0..=NM_RANGE.1).contains(&x);
        self.lo = self.lo.min(x);
        self.hi = self.hi.max(x);
        self.sum += x;
    }

    /// [`looks_absolute_nm`] of the values taken so far.
    pub(crate) fn looks_absolute_nm(&self) -> bool {
        if self.n < 3 || !self.in_band {
            return false;
        }
        self.hi - self.lo < 0.01 * (self.sum / self.n as f64)
    }

    /// [`absolute_nm_column_message`] of the values taken so far.
    pub fn message(&self, key: &str) -> String {
        format!(
            "the column is declared shift_pm but every value lies within 1 % of {:.1}, like absolute wavelengths in nm; map key `{key}`: set it to \"nm\" (or check_units = false if these really are shifts)",
            self.first
        )
    }
}

/// Check an ambient temperature [°C] (after gain and offset).
pub(crate) fn check_ambient(v: f64) -> Result<(), String> {
    let (lo, hi) = AMBIENT_RANGE_C;
    let n = ShortNumber(v);
    if (lo..=hi).contains(&v) {
        Ok(())
    } else if (200.0..=400.0).contains(&v) {
        Err(format!("ambient {n} °C looks like kelvin; map key `ambient.offset`: set it to -273.15"))
    } else {
        Err(format!("ambient {n} °C is outside {lo}–{hi} °C; check the map keys `ambient.column`, `ambient.gain`, `ambient.offset`"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_checks() {
        assert!(check_wavelength(WlUnit::Nm, 1545.1, "k").is_ok());
        assert!(check_wavelength(WlUnit::Nm, 1_545_100.0, "k").unwrap_err().contains("\"pm\""));
        assert!(check_wavelength(WlUnit::Nm, 12.5, "k").unwrap_err().contains("shift_pm"));
        assert!(check_wavelength(WlUnit::ShiftPm, -250.0, "k").is_ok());
        assert!(check_wavelength(WlUnit::ShiftPm, 1_545_100.0, "k").unwrap_err().contains("\"pm\""));
        assert!(check_wavelength(WlUnit::ShiftNm, 1545.1, "k").unwrap_err().contains("\"nm\""));
        assert!(looks_absolute_nm(&[1545.0, 1545.1, 1545.05]));
        assert!(!looks_absolute_nm(&[600.0, 700.0, 650.0]));
        assert!(check_ambient(296.0).unwrap_err().contains("-273.15"));
        // A huge cell is printed short.
        assert!(check_wavelength(WlUnit::ShiftPm, 1e308, "k").unwrap_err().starts_with("1e308 (shift_pm)"));
        assert!(check_ambient(-1e300).unwrap_err().starts_with("ambient -1e300 °C"));
    }
}
