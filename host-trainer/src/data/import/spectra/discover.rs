//! Without a map: the gratings of a channel are the peaks of its first spectrum, each given a
//! search window that reaches halfway to its neighbours.
//!
//! A peak is a run of samples above floor + max(10 % of the spectrum's highest peak, the
//! detector's no-peak SNR × σ) (floor and σ of the whole spectrum, `NoiseEstimate`); runs less
//! than three samples apart are one peak (noise on a flank that dips under the level). The 10 %
//! stays above a uniform grating's side lobes (4.7 %) and leaves out a grating weaker than a
//! tenth of the strongest on the channel: map such an installation. The windows are fixed for
//! the whole record, so a grating must not move past the midpoint to its neighbour.

use fbg_shared::spectrum::{DetectorConfig, NoiseEstimate, Spectrum, Window};

/// A peak's samples rise above this fraction of the highest peak (above the floor).
const LEVEL_FRACTION: f64 = 0.1;

/// Runs of samples above the level closer than this many samples are one peak.
const MERGE_GAP: usize = 3;

/// The search windows of the peaks of `s`, in wavelength order (empty when nothing rises above
/// the noise).
pub(crate) fn windows(s: &Spectrum<'_, f64>, config: &DetectorConfig<f64>) -> Vec<Window<f64>> {
    let v = s.samples();
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let noise = NoiseEstimate::of(&finite);
    let vmax = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let height = vmax - noise.floor;
    if height.is_nan() || height <= 0.0 || (noise.sigma > 0.0 && height / noise.sigma < config.no_peak_snr) {
        return Vec::new();
    }
    let level = noise.floor + (LEVEL_FRACTION * height).max(config.no_peak_snr * noise.sigma);
    // Runs above the level: (first, last, pixel of the maximum).
    let mut runs: Vec<(usize, usize, usize)> = Vec::new();
    for (i, &x) in v.iter().enumerate() {
        // NaN samples (missing) are never above the level.
        if x.is_nan() || x <= level {
            continue;
        }
        match runs.last_mut() {
            Some((_, last, imax)) if i <= *last + MERGE_GAP => {
                *last = i;
                if x > v.get(*imax).copied().unwrap_or(f64::NEG_INFINITY) {
                    *imax = i;
                }
            }
            _ => runs.push((i, i, i)),
        }
    }
    let grid = s.grid();
    let mut centres: Vec<f64> = runs.iter().map(|r| grid.wavelength(r.2 as f64)).collect();
    centres.sort_by(f64::total_cmp);
    let (a, b) = (grid.wavelength(0.0), grid.wavelength(v.len().saturating_sub(1) as f64));
    let (lo_end, hi_end) = (a.min(b), a.max(b));
    let n = centres.len();
    (0..n)
        .map(|k| {
            let c = centres[k];
            let left = if k > 0 { Some(0.5 * (c - centres[k - 1])) } else { None };
            let right = if k + 1 < n { Some(0.5 * (centres[k + 1] - c)) } else { None };
            // The outermost windows as wide on their open side as on their inner one.
            let (l, r) = match (left, right) {
                (Some(l), Some(r)) => (l, r),
                (Some(l), None) => (l, l),
                (None, Some(r)) => (r, r),
                (None, None) => (c - lo_end, hi_end - c),
            };
            Window::new((c - l).max(lo_end), (c + r).min(hi_end))
        })
        .collect()
}
