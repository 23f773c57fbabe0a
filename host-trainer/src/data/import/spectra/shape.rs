//! A grating's measured reflection shape (`[[grating]] shape = "scan.csv"`): the template the
//! detector's estimate is refined by ([`fbg_shared::spectrum::template_fit`]), which removes the
//! peak-locking of a coarse pixel grid that every method built on a Gaussian keeps.
//!
//! The file is a CSV with a header naming `wavelength_nm` and `reflectance` (other columns are
//! ignored): a swept-laser scan of the one grating, wavelengths increasing, reflectance linear
//! (not dB) on any scale. It must be the grating's own shape from outside the record, enclose
//! its peak (first and last samples below half the peak above the scan's floor), hold no second
//! peak above that half, and resolve it: at least [`MIN_SAMPLES_ABOVE_HALF`] samples above half.
//! The template's centre (the wavelength the fit reports) is the centroid of the peak's samples
//! above half; a constant offset from the grating's true centre cancels in its shifts.

use std::path::Path;

use super::shape_table::ShapeTable;
use crate::data::units::NM_RANGE;
use crate::error::{quote_cell, quote_number, TrainerError};

/// Samples above half the scan's peak below which the scan does not resolve the peak.
pub const MIN_SAMPLES_ABOVE_HALF: usize = 5;

/// The shape in `path` tabulated as a template; errors name the file, line and column.
pub(crate) fn load(path: &Path) -> Result<ShapeTable, TrainerError> {
    let name = path.display().to_string();
    let bad = |line: u64, column: &str, message: String| TrainerError::data(&name, line, column, message);
    let text = std::fs::read(path).map_err(|e| TrainerError::io(path, e))?;
    // The line a record starts on, blank lines counted (the reader's own count skips them, and
    // a record's offset is that of the blank lines before it).
    let newlines: Vec<usize> = text.iter().enumerate().filter(|(_, &b)| b == b'\n').map(|(i, _)| i).collect();
    let line_at = |byte: u64| {
        let start = byte as usize + text.iter().skip(byte as usize).take_while(|&&b| b == b'\n' || b == b'\r').count();
        1 + newlines.partition_point(|&i| i < start) as u64
    };
    let mut rd = csv::ReaderBuilder::new().has_headers(true).flexible(true).from_reader(text.as_slice());
    let headers = rd.headers().map_err(|e| bad(1, "", e.to_string()))?.clone();
    let col = |want: &str| {
        headers.iter().position(|h| h.trim() == want).ok_or_else(|| {
            bad(1, want, format!("no `{want}` column (the header names `wavelength_nm` and `reflectance`)"))
        })
    };
    let (cw, cr) = (col("wavelength_nm")?, col("reflectance")?);
    // (wavelength, reflectance, line) of every row.
    let mut rows: Vec<(f64, f64, u64)> = Vec::new();
    for rec in rd.records() {
        let rec = rec.map_err(|e| bad(e.position().map_or(0, |p| line_at(p.byte())), "", e.to_string()))?;
        let line = rec.position().map_or(0, |p| line_at(p.byte()));
        let num = |c: usize, name: &str| -> Result<f64, TrainerError> {
            let cell = rec.get(c).unwrap_or("").trim();
            cell.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad(line, name, format!("`{}` is not a finite number", quote_cell(cell))))
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
        if let Some(&(prev, _, _)) = rows.last() {
            if w <= prev {
                let (w, prev) = (quote_number(w), quote_number(prev));
                return Err(bad(
                    line,
                    "wavelength_nm",
                    format!("{w} nm does not increase (the row before: {prev} nm)"),
                ));
            }
        }
        rows.push((w, v, line));
    }
    let centre = peak_centre(&rows).map_err(|(line, m)| bad(line, "reflectance", m))?;
    let (wl, r): (Vec<f64>, Vec<f64>) = rows.iter().map(|&(w, v, _)| (w, v)).unzip();
    ShapeTable::from_scan(&wl, &r, centre)
        .ok_or_else(|| bad(1, "wavelength_nm", "the scan spans less than two template steps about its peak".into()))
}

/// The centre of the scan's one peak: the centroid of the samples of its run above half the
/// peak (half way from the scan's floor to its maximum); an error (line, message) where the
/// scan is in dB, does not enclose or resolve the peak, or holds a second one.
fn peak_centre(rows: &[(f64, f64, u64)]) -> Result<f64, (u64, String)> {
    let Some((top, &(w_max, max, line_max))) = rows.iter().enumerate().max_by(|a, b| a.1 .1.total_cmp(&b.1 .1)) else {
        return Err((1, "the scan has no rows".into()));
    };
    if max <= 0.0 {
        let m = quote_number(max);
        return Err((
            line_max,
            format!("the largest reflectance is {m}: the scan must be linear (not dB), its peak above 0"),
        ));
    }
    let floor = rows.iter().map(|r| r.1).fold(f64::INFINITY, f64::min);
    let half = 0.5 * (max + floor);
    let above = |i: usize| rows.get(i).is_some_and(|r| r.1 >= half);
    let (mut first, mut last) = (top, top);
    while first > 0 && above(first - 1) {
        first -= 1;
    }
    while above(last + 1) {
        last += 1;
    }
    if first == 0 || last + 1 == rows.len() {
        let edge = if first == 0 { rows[0].2 } else { rows[rows.len() - 1].2 };
        return Err((
            edge,
            format!("the scan does not enclose the peak at {} nm: this edge sample is above half of it (scan past both flanks)", quote_number(w_max)),
        ));
    }
    if let Some(&(w, _, line)) =
        rows.iter().enumerate().find(|(i, _)| (*i < first || *i > last) && above(*i)).map(|(_, r)| r)
    {
        return Err((
            line,
            format!(
                "a second peak at {} nm rises above half the one at {} nm: a shape is the scan of one grating",
                quote_number(w),
                quote_number(w_max)
            ),
        ));
    }
    let n = last - first + 1;
    if n < MIN_SAMPLES_ABOVE_HALF {
        return Err((
            line_max,
            format!("the scan does not resolve the peak: {n} samples above half of it, at least {MIN_SAMPLES_ABOVE_HALF} needed (a step well under the grating's width)"),
        ));
    }
    let run = &rows[first..=last];
    let (sum_wr, sum_r) = run.iter().fold((0.0, 0.0), |(a, b), &(w, v, _)| (a + w * (v - floor), b + (v - floor)));
    Ok(sum_wr / sum_r)
}
