//! `--format spectra-csv`: a plain spectra table, `t_s,channel,` and then one column per
//! wavelength of the grid named by the wavelength in nm (`1530.000,1530.008,…`), one row per
//! frame and channel, intensities linear or in dB (`--scale`). The table itself is
//! [`super::wide_csv`]'s.
//!
//! The wavelengths must increase and lie on a uniform grid (an OSA trace, a swept laser, a
//! resampled spectrometer frame): each within a tenth of the step, or within half a unit of
//! the header's last written decimal, of start + k·step. A spectrometer's own non-uniform
//! pixels are `--format pixels` with its calibration polynomial.

use fbg_shared::spectrum::Grid;

use super::super::number;
use crate::data::units::NM_RANGE;
use crate::error::ShortNumber;

/// Largest distance of a header wavelength from the uniform grid, in steps.
const GRID_TOLERANCE_STEPS: f64 = 0.1;

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
    let tolerance = (GRID_TOLERANCE_STEPS * step).max(0.5 * 10f64.powi(-(decimals.min(15) as i32)));
    for (k, &v) in nm.iter().enumerate() {
        let off = v - (first + k as f64 * step);
        if off.abs() > tolerance {
            return Err((
                k,
                format!(
                    "{v} nm is {:.3} pm off the uniform grid {first} nm + {:.6} nm·k; the wavelengths must be evenly spaced (a non-uniform spectrometer grid is --format pixels with its calibration polynomial)",
                    1e3 * off,
                    step
                ),
            ));
        }
    }
    Ok(Grid::uniform(first, step))
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
}
