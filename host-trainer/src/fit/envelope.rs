//! The calibration envelope: the range of the inputs a model was calibrated over, with a margin,
//! beyond which the device flags its estimates (DESIGN §4).

use rayon::prelude::*;

use fbg_shared::layout::MAX_ENVELOPE;

use crate::data::Dataset;

/// Envelope margin: fraction of the calibration range added on each side.
pub(crate) const ENVELOPE_MARGIN: f64 = 0.10;

/// Calibration envelope of [Δλ_1..N, T_amb (with ambient)] over `idx` with
/// [`ENVELOPE_MARGIN`], rounded outwards to f32 so that host and device compare against the
/// same bounds (0 beyond [`fbg_shared::layout::Dims::envelope_len`]).
pub(crate) fn envelope(d: &Dataset, idx: &[usize]) -> ([f64; MAX_ENVELOPE], [f64; MAX_ENVELOPE]) {
    let mut cols: Vec<&[f64]> = d.dl_pm.iter().map(|c| c.as_slice()).collect();
    if let Some(a) = &d.t_amb_c {
        cols.push(a);
    }
    let (mn, mx) = idx
        .par_chunks(16_384)
        .map(|ch| {
            let mut mn = [f64::INFINITY; MAX_ENVELOPE];
            let mut mx = [f64::NEG_INFINITY; MAX_ENVELOPE];
            for &i in ch {
                for (c, col) in cols.iter().enumerate() {
                    mn[c] = mn[c].min(col[i]);
                    mx[c] = mx[c].max(col[i]);
                }
            }
            (mn, mx)
        })
        .reduce(
            || ([f64::INFINITY; MAX_ENVELOPE], [f64::NEG_INFINITY; MAX_ENVELOPE]),
            |a, b| (std::array::from_fn(|c| a.0[c].min(b.0[c])), std::array::from_fn(|c| a.1[c].max(b.1[c]))),
        );
    let mut lo = [0.0; MAX_ENVELOPE];
    let mut hi = [0.0; MAX_ENVELOPE];
    for c in 0..cols.len() {
        let m = ENVELOPE_MARGIN * (mx[c] - mn[c]);
        lo[c] = f32_down(mn[c] - m);
        hi[c] = f32_up(mx[c] + m);
    }
    (lo, hi)
}

/// The largest f32 at or below `v`.
fn f32_down(v: f64) -> f64 {
    let f = v as f32;
    if (f as f64) > v {
        f.next_down() as f64
    } else {
        f as f64
    }
}

/// The smallest f32 at or above `v`.
fn f32_up(v: f64) -> f64 {
    let f = v as f32;
    if (f as f64) < v {
        f.next_up() as f64
    } else {
        f as f64
    }
}
