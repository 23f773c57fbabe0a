//! The map's `[spectra]` table checked and turned into the detector's settings and the
//! import's gap rule.

use fbg_shared::spectrum::{from_db, DetectorConfig, Method, PeakFlags, Threshold};

use super::super::mapping::SpectraMap;
use super::super::scale::Scale;

/// Flags that make a frame's wavelength a gap unless the map's `gap_on` says otherwise: the
/// detector's faults (a clipped top, a neighbour in the window, a maximum at the window's edge;
/// `no-peak` has no wavelength anyway).
pub(crate) const DEFAULT_GAP_ON: PeakFlags = PeakFlags::FAULTS;

/// The name of each single flag, in bit order (`PeakFlags`' own Display names).
pub(crate) fn flag_names() -> impl Iterator<Item = (PeakFlags, String)> {
    (0..8).map(|b| {
        let f = PeakFlags(1 << b);
        (f, f.to_string())
    })
}

/// The flags of a `gap_on` list, or the name that is not a flag.
fn flags_named(names: &[String]) -> Result<PeakFlags, String> {
    let mut out = PeakFlags::OK;
    for n in names {
        let Some((f, _)) = flag_names().find(|(_, name)| name.eq_ignore_ascii_case(n.trim())) else {
            let known: Vec<String> = flag_names().map(|(_, n)| n).collect();
            return Err(format!("`{n}` is not a peak flag; known: {}", known.join(", ")));
        };
        out.insert(f);
    }
    Ok(out)
}

/// The method named `s`.
fn method_named(s: &str) -> Result<Method, String> {
    Method::ALL.iter().copied().find(|m| m.name().eq_ignore_ascii_case(s.trim())).ok_or_else(|| {
        let known: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
        format!("`{}` is not a method; known: {}", crate::error::quote_cell(s), known.join(", "))
    })
}

impl SpectraMap {
    /// Check the table; errors are (key within `[spectra]`, message).
    pub(crate) fn validate(&self) -> Result<(), (&'static str, String)> {
        if let Some(c) = &self.pixel_to_nm {
            if !(2..=fbg_shared::spectrum::POLY_COEFFS).contains(&c.len()) || c.iter().any(|v| !v.is_finite()) {
                return Err((
                    "pixel_to_nm",
                    format!(
                        "{} coefficients; give 2 to {} finite ones, c₀ first (λ = c₀ + c₁·p + …, nm)",
                        c.len(),
                        fbg_shared::spectrum::POLY_COEFFS
                    ),
                ));
            }
        }
        if let Some(m) = &self.method {
            method_named(m).map_err(|e| ("method", e))?;
        }
        if let Some(f) = self.threshold {
            if !(f > 0.0 && f < 1.0) {
                return Err(("threshold", format!("{f} is not a fraction of the peak's height in (0, 1)")));
            }
        }
        for (key, v) in [
            ("reference_fwhm_nm", self.reference_fwhm_nm),
            ("min_fwhm_nm", self.min_fwhm_nm),
            ("max_fwhm_nm", self.max_fwhm_nm),
            ("max_asymmetry", self.max_asymmetry),
            ("second_peak_fraction", self.second_peak_fraction),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0) {
                    return Err((key, format!("{v} is not a positive number")));
                }
            }
        }
        for (key, v) in
            [("full_scale", self.full_scale), ("min_snr_db", self.min_snr_db), ("no_peak_snr_db", self.no_peak_snr_db)]
        {
            if let Some(v) = v {
                if !v.is_finite() {
                    return Err((key, format!("{v} is not finite")));
                }
            }
        }
        if let Some(g) = &self.gap_on {
            flags_named(g).map_err(|e| ("gap_on", e))?;
        }
        Ok(())
    }
}

/// What detection and the import take from the map (defaults where it says nothing).
#[derive(Clone, Debug)]
pub(crate) struct Settings {
    /// The detector's settings (linear intensities).
    pub config: DetectorConfig<f64>,
    /// Flags whose frames become gaps.
    pub gap_on: PeakFlags,
}

impl Settings {
    /// From a validated `[spectra]` table for a file in `scale`.
    pub(crate) fn of(m: &SpectraMap, scale: Scale) -> Settings {
        let d = DetectorConfig::<f64>::default();
        let snr = |db: Option<f64>, default: f64| db.map_or(default, |db| 10f64.powf(db / 10.0));
        let config = DetectorConfig {
            method: m.method.as_deref().and_then(|s| method_named(s).ok()).unwrap_or(d.method),
            threshold: m.threshold.map_or(d.threshold, Threshold::Fraction),
            reference_fwhm_nm: m.reference_fwhm_nm.unwrap_or(d.reference_fwhm_nm),
            // The detector compares linear samples: a dB full scale is converted like them.
            full_scale: m.full_scale.map_or(d.full_scale, |f| if scale == Scale::Db { from_db(f) } else { f }),
            min_snr: snr(m.min_snr_db, d.min_snr),
            no_peak_snr: snr(m.no_peak_snr_db, d.no_peak_snr),
            min_fwhm_nm: m.min_fwhm_nm.unwrap_or(d.min_fwhm_nm),
            max_fwhm_nm: m.max_fwhm_nm.unwrap_or(d.max_fwhm_nm),
            max_asymmetry: m.max_asymmetry.unwrap_or(d.max_asymmetry),
            second_peak_fraction: m.second_peak_fraction.unwrap_or(d.second_peak_fraction),
        };
        let gap_on = m.gap_on.as_deref().and_then(|g| flags_named(g).ok()).unwrap_or(DEFAULT_GAP_ON);
        Settings { config, gap_on: gap_on.union(PeakFlags::NO_PEAK) }
    }

    /// The gap rule's flags by name.
    pub(crate) fn gap_on_names(&self) -> Vec<String> {
        flag_names().filter(|(f, _)| self.gap_on.contains(*f)).map(|(_, n)| n).collect()
    }
}
