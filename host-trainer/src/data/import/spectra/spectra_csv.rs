//! `--format spectra-csv`: a plain spectra table, `t_s,channel,` and then one column per
//! wavelength of the grid named by the wavelength in nm (`1530.000,1530.008,…`), one row per
//! frame and channel, intensities linear or in dB (`--scale`). The table itself is
//! [`super::wide_csv`]'s.
//!
//! The wavelengths must increase. On a uniform grid (an OSA trace, a swept laser, a resampled
//! spectrometer frame) each lies within a tenth of the step, or within half a unit of the
//! header's last written decimal, of start + k·step. Otherwise the header is a tabulated grid,
//! each pixel's own wavelength as a spectrometer exports it: the grid is then the pixel
//! polynomial of lowest degree (≤ 5, as spectrometer calibrations are) that passes within one
//! unit of the last written decimal of every header wavelength; a header no such polynomial
//! fits is refused at its worst column.

use fbg_shared::spectrum::{Grid, POLY_COEFFS};
use nalgebra::{DMatrix, DVector};

use super::super::number;
use crate::data::units::NM_RANGE;
use crate::error::ShortNumber;

/// Largest distance of a header wavelength from the uniform grid, in steps.
const GRID_TOLERANCE_STEPS: f64 = 0.1;

/// Smallest distance \[nm\] a tabulated header's polynomial is held to (a femtometre), for a
/// header written to more decimals than a double carries; otherwise its last decimal.
const MIN_TABLE_TOLERANCE_NM: f64 = 1e-6;

/// The uniform grid of the header's wavelengths, or (index of the offending column, message).
pub(crate) fn grid_of(columns: &[&str]) -> Result<Grid<f64>, (usize, String)> {
    let mut nm = Vec::with_capacity(columns.len());
    let mut decimals = 0usize;
    for (k, c) in columns.iter().enumerate() {
        let v = number(c)
            .map_err(|m| (k, format!("{m}: a spectra-csv header names each column by its wavelength in nm")))?
            .ok_or_else(|| (k, "empty header cell: each sample column is named by its wavelength in nm".to_string()))?;
        if !(NM_RANGE.0..=NM_RANGE.1).contains(&v) {
            return Err((
                k,
                format!("{} is not a wavelength in nm ({}–{} nm)", ShortNumber(v), NM_RANGE.0, NM_RANGE.1),
            ));
        }
        if let Some(&prev) = nm.last() {
            if v <= prev {
                return Err((k, format!("the wavelengths must increase: {v} nm follows {prev} nm")));
            }
        }
        decimals = decimals.max(c.split_once('.').map_or(0, |(_, f)| f.len()));
        nm.push(v);
    }
    let (Some(&first), Some(&last)) = (nm.first(), nm.last()) else {
        return Err((0, "no wavelength columns".into()));
    };
    let step = (last - first) / (nm.len() - 1) as f64;
    let unit = 10f64.powi(-(decimals.min(15) as i32));
    let tolerance = (GRID_TOLERANCE_STEPS * step).max(0.5 * unit);
    let uniform = Grid::uniform(first, step);
    if nm.iter().enumerate().all(|(k, &v)| (v - uniform.wavelength(k as f64)).abs() <= tolerance) {
        return Ok(uniform);
    }
    let table_tolerance = unit.max(MIN_TABLE_TOLERANCE_NM);
    let (grid, worst, off) = tabulated(&nm, table_tolerance);
    if off > table_tolerance {
        let v = nm.get(worst).copied().unwrap_or(f64::NAN);
        return Err((
            worst,
            format!(
                "{v} nm is {:.3} pm off the smoothest pixel polynomial (degree ≤ {}) through the header's wavelengths, more than the header's last decimal: the wavelengths must be evenly spaced or follow a spectrometer's pixel calibration",
                1e3 * off,
                POLY_COEFFS - 1
            ),
        ));
    }
    super::pixels::monotonic(&grid, nm.len()).map_err(|(k, s)| {
        (
            k,
            format!(
                "the pixel polynomial through the header's wavelengths turns back at column {k} (dλ/dp = {s:e} nm)"
            ),
        )
    })?;
    Ok(grid)
}

/// The pixel polynomial of lowest degree (2 to 5) through the wavelengths `nm` of pixels 0, 1,
/// … by least squares, with the pixel of its largest distance from them and that distance
/// \[nm\]: the first degree within `tolerance` \[nm\] of every one, else degree 5.
fn tabulated(nm: &[f64], tolerance: f64) -> (Grid<f64>, usize, f64) {
    let n = nm.len();
    let first = nm.first().copied().unwrap_or(f64::NAN);
    // In x = p / (n − 1) ∈ [0, 1] and relative to the first wavelength, for conditioning.
    let scale = (n.max(2) - 1) as f64;
    let mut best = (Grid::uniform(first, f64::NAN), 0, f64::INFINITY);
    for degree in 2..POLY_COEFFS.min(n) {
        let a = DMatrix::from_fn(n, degree + 1, |k, j| (k as f64 / scale).powi(j as i32));
        let y = DVector::from_iterator(n, nm.iter().map(|&v| v - first));
        let Some(svd) = a.try_svd(true, true, f64::EPSILON, 10_000) else { continue };
        let Ok(sol) = svd.solve(&y, 1e-14) else { continue };
        let mut c = [0.0; POLY_COEFFS];
        for (j, (o, &aj)) in c.iter_mut().zip(sol.iter()).enumerate() {
            *o = aj / scale.powi(j as i32);
        }
        if let Some(c0) = c.first_mut() {
            *c0 += first;
        }
        let grid = Grid::polynomial(c);
        let (worst, off) = nm
            .iter()
            .enumerate()
            .map(|(k, &v)| (k, (grid.wavelength(k as f64) - v).abs()))
            .fold((0, 0.0), |acc, x| if x.1 > acc.1 || x.1.is_nan() { x } else { acc });
        best = (grid, worst, off);
        if off <= tolerance {
            break;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_8_pm_grid_written_to_the_pm_is_uniform_and_an_uneven_one_is_not() {
        let names: Vec<String> = (0..500).map(|k| format!("{:.3}", 1530.0 + 0.008 * k as f64)).collect();
        let cells: Vec<&str> = names.iter().map(String::as_str).collect();
        let Ok(Grid::Uniform { start_nm, step_nm }) = grid_of(&cells) else { panic!("not uniform") };
        assert!((start_nm - 1530.0).abs() < 1e-12 && (step_nm - 0.008).abs() < 1e-12);
        let mut uneven = cells.clone();
        uneven[250] = "1532.003";
        assert_eq!(grid_of(&uneven).map_err(|e| e.0), Err(250));
        uneven[250] = "1531.000";
        assert!(grid_of(&uneven).unwrap_err().1.contains("must increase"));
    }

    /// A spectrometer's own pixels, each wavelength written to the pm (as `simulate --spectra`
    /// writes its 512-pixel grid): the tabulated grid's polynomial gives every pixel, and the
    /// fractional pixels between them, within the header's rounding.
    #[test]
    fn a_tabulated_spectrometer_grid_becomes_its_pixel_polynomial() {
        let truth = Grid::polynomial([1510.0, 0.1765, -2e-5, 3e-9, 0.0, 0.0]);
        let names: Vec<String> = (0..512).map(|k| format!("{:.3}", truth.wavelength(k as f64))).collect();
        let cells: Vec<&str> = names.iter().map(String::as_str).collect();
        let g = grid_of(&cells).unwrap();
        assert!(matches!(g, Grid::Polynomial { .. }));
        let worst = (0..5110)
            .map(|q| q as f64 / 10.0)
            .map(|p| (g.wavelength(p) - truth.wavelength(p)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.5e-3, "{worst} nm");
        // One wavelength 5 pm off its pixel fits no calibration: refused at that column.
        let mut bad = names.clone();
        bad[300] = format!("{:.3}", truth.wavelength(300.0) + 0.005);
        let cells: Vec<&str> = bad.iter().map(String::as_str).collect();
        let (k, m) = grid_of(&cells).unwrap_err();
        assert_eq!(k, 300, "{m}");
        assert!(m.contains("pm off the smoothest pixel polynomial"), "{m}");
    }
}
