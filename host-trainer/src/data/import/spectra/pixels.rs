//! `--format pixels`: a spectrometer's frames, `t_s,channel,` and then one column per pixel
//! (`p0,p1,…` or `0,1,…`, in order), one row per frame and channel, raw counts (linear; dB with
//! `--scale db`). The pixel-to-wavelength polynomial is the map's `[spectra] pixel_to_nm`
//! (c₀ first, λ in nm at pixel p = 0, 1, …); the table itself is [`super::wide_csv`]'s.

use fbg_shared::spectrum::{Grid, POLY_COEFFS};

use crate::data::units::NM_RANGE;
use crate::error::ShortNumber;

/// The grid of the pixel columns under the calibration `coefficients`, or (index of the
/// offending column, message): the columns must be the pixels 0, 1, … in order, and λ must be
/// monotonic over them.
pub(crate) fn grid_of(columns: &[&str], coefficients: &[f64]) -> Result<Grid<f64>, (usize, String)> {
    for (k, c) in columns.iter().enumerate() {
        let digits = c.strip_prefix(['p', 'P']).unwrap_or(c);
        if digits.parse::<usize>().ok() != Some(k) {
            return Err((k, format!("`{}` where pixel {k} is expected: a pixels header is `t_s,channel,p0,p1,…` (or `0,1,…`), every pixel in order", crate::error::quote_cell(c))));
        }
    }
    let mut c = [0.0; POLY_COEFFS];
    for (dst, src) in c.iter_mut().zip(coefficients) {
        *dst = *src;
    }
    let grid = Grid::polynomial(c);
    // Every pixel's wavelength must be one an FBG can have: a sign or an exponent wrong in
    // the calibration would otherwise give negative or astronomical wavelengths.
    let (lo, hi) = NM_RANGE;
    if let Some((k, l)) =
        (0..columns.len()).map(|k| (k, grid.wavelength(k as f64))).find(|(_, l)| !(lo..=hi).contains(l))
    {
        return Err((
            k,
            format!(
                "the map's [spectra] pixel_to_nm gives pixel {k} the wavelength {} nm, outside {lo}–{hi} nm: check the coefficients, their unit (nm) and their order (c₀ first)",
                ShortNumber(l)
            ),
        ));
    }
    monotonic(&grid, columns.len()).map_err(|(k, s)| {
        (
            k,
            format!(
                "the map's [spectra] pixel_to_nm is not monotonic at pixel {k} (dλ/dp = {s:e} nm, {:e} nm at pixel 0): check the coefficients and their order (c₀ first)",
                grid.step_at(0.0)
            ),
        )
    })?;
    Ok(grid)
}

/// `Ok` when λ(p) keeps its direction over the `pixels` read (the detector inverts it), else
/// the first pixel where it does not and dλ/dp there \[nm\].
pub(crate) fn monotonic(grid: &Grid<f64>, pixels: usize) -> Result<(), (usize, f64)> {
    let sign = grid.step_at(0.0).signum();
    for k in 0..pixels {
        let s = grid.step_at(k as f64);
        if !(s.is_finite() && s != 0.0 && s.signum() == sign) {
            return Err((k, s));
        }
    }
    Ok(())
}
