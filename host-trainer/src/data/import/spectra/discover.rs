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
    (0..centres.len())
        .filter_map(|k| {
            let c = *centres.get(k)?;
            let left = k.checked_sub(1).and_then(|i| centres.get(i)).map(|p| 0.5 * (c - p));
            let right = centres.get(k + 1).map(|q| 0.5 * (q - c));
            // The outermost windows as wide on their open side as on their inner one.
            let (l, r) = match (left, right) {
                (Some(l), Some(r)) => (l, r),
                (Some(l), None) => (l, l),
                (None, Some(r)) => (r, r),
                (None, None) => (c - lo_end, hi_end - c),
            };
            Some(Window::new((c - l).max(lo_end), (c + r).min(hi_end)))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use fbg_shared::spectrum::Grid;

    /// Three Gaussians (0.3 nm FWHM) on a floor, the middle one at a fifth of the others'
    /// height, on a 10 pm grid: three windows, in wavelength order, meeting halfway.
    #[test]
    fn three_peaks_give_three_windows_meeting_halfway() {
        let grid = Grid::uniform(1530.0, 0.01);
        let s: Vec<f64> = (0..2000)
            .map(|k| {
                let l = grid.wavelength(k as f64);
                let g = |c: f64, h: f64| h * (-0.5 * ((l - c) / (0.3 / 2.3548)).powi(2)).exp();
                0.01 + g(1535.0, 1.0) + g(1541.0, 0.2) + g(1545.0, 1.0)
            })
            .collect();
        let w = windows(&Spectrum::new(&s, grid), &DetectorConfig::default());
        let bounds: Vec<(f64, f64)> = w.iter().map(|w| (w.lo_nm, w.hi_nm)).collect();
        let want = [(1532.0, 1538.0), (1538.0, 1543.0), (1543.0, 1547.0)];
        assert_eq!(bounds.len(), 3, "{bounds:?}");
        for (got, want) in bounds.iter().zip(want) {
            assert!((got.0 - want.0).abs() < 1e-9 && (got.1 - want.1).abs() < 1e-9, "{bounds:?}");
        }
        // A flat channel has no grating.
        assert!(windows(&Spectrum::new(&[0.01; 100], grid), &DetectorConfig::default()).is_empty());
    }
}
