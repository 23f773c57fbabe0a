//! A grating's measured reflection shape (`[[grating]] shape = "scan.csv"`): the template the
//! detector's estimate is refined by ([`fbg_shared::spectrum::template_fit`]), which removes the
//! peak-locking of a coarse pixel grid that every method built on a Gaussian keeps.
//!
//! The file is a CSV with a header naming `wavelength_nm` and `reflectance` (other columns are
//! ignored): a swept-laser scan of the grating, wavelengths increasing, reflectance on any
//! scale (linear, not dB). It must be the grating's own shape from outside the record, and
//! resolve its peak: at least [`MIN_SAMPLES_ABOVE_HALF`] samples above half the maximum.

use std::path::Path;

use super::shape_table::ShapeTable;
use crate::data::units::NM_RANGE;
use crate::error::{quote_number, TrainerError};

/// Samples above half the scan's maximum below which the scan does not resolve the peak.
pub const MIN_SAMPLES_ABOVE_HALF: usize = 5;

/// The shape in `path` tabulated as a template; errors name the file, line and column.
pub(crate) fn load(path: &Path) -> Result<ShapeTable, TrainerError> {
    let name = path.display().to_string();
    let bad = |line: u64, column: &str, message: String| TrainerError::data(&name, line, column, message);
    let mut rd = csv::ReaderBuilder::new().has_headers(true).from_path(path).map_err(|e| match e.into_kind() {
        csv::ErrorKind::Io(io) => TrainerError::io(path, io),
        other => bad(1, "", format!("{other:?}")),
    })?;
    let headers = rd.headers().map_err(|e| bad(1, "", e.to_string()))?.clone();
    let col = |want: &str| {
        headers.iter().position(|h| h.trim() == want).ok_or_else(|| {
            bad(1, want, format!("no `{want}` column (the header names `wavelength_nm` and `reflectance`)"))
        })
    };
    let (cw, cr) = (col("wavelength_nm")?, col("reflectance")?);
    let (mut wl, mut r) = (Vec::new(), Vec::new());
    for (k, rec) in rd.records().enumerate() {
        let line = k as u64 + 2;
        let rec = rec.map_err(|e| bad(line, "", e.to_string()))?;
        let num = |c: usize, name: &str| -> Result<f64, TrainerError> {
            let cell = rec.get(c).unwrap_or("").trim();
            cell.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(line, name, format!("`{}` is not a finite number", crate::error::quote_cell(cell))))
        };
        let (w, v) = (num(cw, "wavelength_nm")?, num(cr, "reflectance")?);
        if !(NM_RANGE.0..=NM_RANGE.1).contains(&w) {
            let (lo, hi) = NM_RANGE;
            return Err(bad(
                line,
                "wavelength_nm",
                format!("{} is not a wavelength in nm ({lo}–{hi} nm)", quote_number(w)),
            ));
        }
        if let Some(&prev) = wl.last() {
            if w <= prev {
                let (w, prev) = (quote_number(w), quote_number(prev));
                return Err(bad(
                    line,
                    "wavelength_nm",
                    format!("{w} nm does not increase (the row before: {prev} nm)"),
                ));
            }
        }
        wl.push(w);
        r.push(v);
    }
    let max = r.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let above = r.iter().filter(|&&v| v >= 0.5 * max).count();
    if max <= 0.0 || above < MIN_SAMPLES_ABOVE_HALF {
        return Err(bad(
            1,
            "reflectance",
            format!(
                "the scan does not resolve the grating's peak: {above} samples above half its maximum, at least {MIN_SAMPLES_ABOVE_HALF} needed (a swept-laser scan at a step well under the grating's width)"
            ),
        ));
    }
    ShapeTable::from_scan(&wl, &r).ok_or_else(|| bad(1, "reflectance", "the scan cannot be tabulated".into()))
}
