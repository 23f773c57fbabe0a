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

/// Where the unit of a checked cell is set, so that a unit message says what to change: an
/// import map's key, or a column handed over in memory (a Python frame's), whose values the
/// caller converts.
#[derive(Clone, Copy, Debug)]
pub enum UnitSource<'a> {
    /// The map key that sets the unit (`grating[1].unit`, `enlight.unit`).
    MapKey(&'a str),
    /// A column given as values (`dl1_pm`, `T_amb_C`): shifts in pm, ambient in °C.
    Column(&'a str),
}

impl UnitSource<'_> {
    /// The advice for a cell that looks like unit `u` (a map's unit name).
    fn set(self, u: &str) -> String {
        match self {
            UnitSource::MapKey(key) => format!("map key `{key}`: set it to \"{u}\""),
            UnitSource::Column(c) => format!("column `{c}` holds shifts in pm from λ_ref: convert it"),
        }
    }
    /// What the cell was said to be.
    fn declared(self, unit: WlUnit) -> String {
        match self {
            UnitSource::MapKey(_) => format!("is declared as a shift ({})", unit.name()),
            UnitSource::Column(_) => "should be a shift in pm".to_string(),
        }
    }
    /// The advice for a cell that fits no unit.
    fn check(self) -> String {
        match self {
            UnitSource::MapKey(key) => format!("check `{key}`"),
            UnitSource::Column(c) => format!("check column `{c}`"),
        }
    }
}

/// Check one wavelength cell (already in the column's unit) for magnitude; the error says what
/// the value looks like and what to change (`source`).
pub(crate) fn check_wavelength(unit: WlUnit, v: f64, source: UnitSource<'_>) -> Result<(), String> {
    // A cell can be 1e308: printed short, not as 309 digits.
    let n = ShortNumber(v);
    let nm = |x: f64| (NM_RANGE.0..=NM_RANGE.1).contains(&x);
    let pm = |x: f64| (NM_RANGE.0 * 1e3..=NM_RANGE.1 * 1e3).contains(&x);
    let set = |u: &str| source.set(u);
    match unit {
        WlUnit::Nm if nm(v) => Ok(()),
        WlUnit::Nm if pm(v) => Err(format!("{n} is declared nm but is pm-scale (absolute wavelengths are {}–{} nm); {}", NM_RANGE.0, NM_RANGE.1, set("pm"))),
        WlUnit::Nm if v.abs() < NM_RANGE.0 => Err(format!(
            "{n} is declared as an absolute wavelength in nm but looks like a shift (absolute wavelengths are {}–{} nm); {}",
            NM_RANGE.0, NM_RANGE.1, set("shift_pm` or `shift_nm")
        )),
        WlUnit::Nm => {
            Err(format!("{n} is not a wavelength in nm ({}–{} nm); {}", NM_RANGE.0, NM_RANGE.1, source.check()))
        }
        WlUnit::Pm if pm(v) => Ok(()),
        WlUnit::Pm if nm(v) => Err(format!("{n} is declared pm but is nm-scale; {}", set("nm"))),
        WlUnit::Pm if v.abs() < NM_RANGE.0 * 1e3 => Err(format!(
            "{n} is declared as an absolute wavelength in pm but looks like a shift (absolute wavelengths are {}–{} pm); {}",
            NM_RANGE.0 * 1e3, NM_RANGE.1 * 1e3, set("shift_pm")
        )),
        WlUnit::Pm => Err(format!("{n} is not a wavelength in pm; {}", source.check())),
        WlUnit::ShiftPm if v.abs() <= MAX_SHIFT_PM => Ok(()),
        WlUnit::ShiftNm if v.abs() * 1e3 <= MAX_SHIFT_PM => Ok(()),
        WlUnit::ShiftPm | WlUnit::ShiftNm if nm(v) => {
            Err(format!("{n} {} but looks like an absolute wavelength in nm; {}", source.declared(unit), set("nm")))
        }
        WlUnit::ShiftPm | WlUnit::ShiftNm if pm(v) => {
            Err(format!("{n} {} but looks like an absolute wavelength in pm; {}", source.declared(unit), set("pm")))
        }
        WlUnit::ShiftPm | WlUnit::ShiftNm => Err(format!(
            "{n} ({}) is a shift beyond {} nm, which no grating reaches; {}",
            unit.name(),
            MAX_SHIFT_PM / 1e3,
            source.check()
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
    a.message(UnitSource::MapKey(key))
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
    pub fn message(&self, source: UnitSource<'_>) -> String {
        let fix = match source {
            UnitSource::MapKey(key) => {
                format!("map key `{key}`: set it to \"nm\" (or check_units = false if these really are shifts)")
            }
            UnitSource::Column(c) => format!("column `{c}` holds shifts in pm from λ_ref: convert it"),
        };
        let kind = match source {
            UnitSource::MapKey(_) => "is declared shift_pm",
            UnitSource::Column(_) => "should hold shifts in pm",
        };
        format!(
            "the column {kind} but every value lies within 1 % of {:.1}, like absolute wavelengths in nm; {fix}",
            self.first
        )
    }
}

/// Check an ambient temperature [°C] (after gain and offset); `source` is the map's
/// `ambient` table or the column.
pub(crate) fn check_ambient(v: f64, source: UnitSource<'_>) -> Result<(), String> {
    let (lo, hi) = AMBIENT_RANGE_C;
    let n = ShortNumber(v);
    if (lo..=hi).contains(&v) {
        Ok(())
    } else if (200.0..=400.0).contains(&v) {
        Err(match source {
            UnitSource::MapKey(key) => {
                format!("ambient {n} °C looks like kelvin; map key `{key}.offset`: set it to -273.15")
            }
            UnitSource::Column(c) => format!("ambient {n} °C looks like kelvin; subtract 273.15 from column `{c}`"),
        })
    } else {
        Err(match source {
            UnitSource::MapKey(key) => format!(
                "ambient {n} °C is outside {lo}–{hi} °C; check the map keys `{key}.column`, `{key}.gain`, `{key}.offset`"
            ),
            UnitSource::Column(c) => format!("ambient {n} °C is outside {lo}–{hi} °C; check column `{c}`"),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_checks() {
        let k = UnitSource::MapKey("k");
        assert!(check_wavelength(WlUnit::Nm, 1545.1, k).is_ok());
        assert!(check_wavelength(WlUnit::Nm, 1_545_100.0, k).unwrap_err().contains("\"pm\""));
        assert!(check_wavelength(WlUnit::Nm, 12.5, k).unwrap_err().contains("shift_pm"));
        assert!(check_wavelength(WlUnit::ShiftPm, -250.0, k).is_ok());
        assert!(check_wavelength(WlUnit::ShiftPm, 1_545_100.0, k).unwrap_err().contains("\"pm\""));
        assert!(check_wavelength(WlUnit::ShiftNm, 1545.1, k).unwrap_err().contains("\"nm\""));
        assert!(looks_absolute_nm(&[1545.0, 1545.1, 1545.05]));
        assert!(!looks_absolute_nm(&[600.0, 700.0, 650.0]));
        assert!(check_ambient(296.0, UnitSource::MapKey("ambient")).unwrap_err().contains("-273.15"));
        // A huge cell is printed short.
        assert!(check_wavelength(WlUnit::ShiftPm, 1e308, k).unwrap_err().starts_with("1e308 (shift_pm)"));
        assert!(check_ambient(-1e300, UnitSource::MapKey("ambient")).unwrap_err().starts_with("ambient -1e300 °C"));
    }
}
