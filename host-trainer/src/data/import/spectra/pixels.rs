//! `--format pixels`: a spectrometer's frames, `t_s,channel,` and then one column per pixel
//! (`p0,p1,…` or `0,1,…`, in order), one row per frame and channel, raw counts (linear; dB with
//! `--scale db`). The pixel-to-wavelength polynomial is the map's `[spectra] pixel_to_nm`
//! (c₀ first, λ in nm at pixel p = 0, 1, …); the table itself is [`super::wide_csv`]'s.

use fbg_shared::spectrum::{Grid, POLY_COEFFS};

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
    // The detector inverts λ(p): it must not turn back over the pixels read.
    let sign = grid.step_at(0.0).signum();
    for k in 0..columns.len() {
        let s = grid.step_at(k as f64);
        if !(s.is_finite() && s != 0.0 && s.signum() == sign) {
            return Err((
                k,
                format!(
                    "the map's [spectra] pixel_to_nm is not monotonic at pixel {k} (dλ/dp = {s:e} nm, {:e} nm at pixel 0): check the coefficients and their order (c₀ first)",
                    grid.step_at(0.0)
                ),
            ));
        }
    }
    Ok(grid)
}
