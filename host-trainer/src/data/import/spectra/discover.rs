//! Without a map: the gratings of a channel are the peaks of its first spectrum, each given a
//! search window that reaches halfway to its neighbours.
//!
//! A candidate is a run of samples above floor + max(10 % of the spectrum's highest peak,
//! [`NOISE_SIGMAS`] × σ, the detector's no-peak SNR × σ), floor and σ measured on the whole
//! spectrum (`NoiseEstimate`): a peak must stand out of the measured noise, so a noise sample is
//! not one (on a fine grid of ten thousand samples, a level of a few σ is crossed by noise
//! alone). Candidates are then taken strongest first, and one closer to a stronger peak than
//! [`MIN_SEPARATION_FWHM`] times that peak's FWHM (measured at its half height) is part of it:
//! a side lobe (a uniform grating of high reflectivity has side lobes far above 10 %), or a
//! flank that noise cut under the level. The 10 % leaves out a grating weaker than a tenth of
//! the strongest on the channel, and gratings closer than the separation are taken as one:
//! map such an installation. The windows are fixed for the whole record, so a grating must not
//! move past the midpoint to its neighbour.

use fbg_shared::spectrum::{DetectorConfig, NoiseEstimate, Spectrum, Window};

/// A peak's samples rise above this fraction of the highest peak (above the floor).
const LEVEL_FRACTION: f64 = 0.1;

/// Runs of samples above the level closer than this many samples are one candidate.
const MERGE_GAP: usize = 3;

/// A peak rises at least this many noise σ above the floor: noise alone crosses it about once
/// in three million samples.
const NOISE_SIGMAS: f64 = 5.0;

/// A candidate closer to a stronger peak than this many of that peak's FWHM belongs to it (a
/// uniform grating's side lobes lie within a few FWHM of its main lobe; gratings on one fibre
/// are spaced by many).
const MIN_SEPARATION_FWHM: f64 = 4.0;

/// The search windows of the peaks of `s`, in wavelength order (empty when nothing rises above
/// the noise).
pub(crate) fn windows(s: &Spectrum<'_, f64>, config: &DetectorConfig<f64>) -> Vec<Window<f64>> {
    // On a grid that samples a grating finely, noise is averaged over a part of the strongest
    // peak's width first: a peak is as wide, a noise excursion is not.
    let smoothed = smooth(s.samples());
    let s = &Spectrum::part(&smoothed, *s.grid(), s.first_pixel());
    let v = s.samples();
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let noise = NoiseEstimate::of(&finite);
    let vmax = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let height = vmax - noise.floor;
    if height.is_nan() || height <= 0.0 || (noise.sigma > 0.0 && height / noise.sigma < config.no_peak_snr) {
        return Vec::new();
    }
    let level = noise.floor + (LEVEL_FRACTION * height).max(config.no_peak_snr.max(NOISE_SIGMAS) * noise.sigma);
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
    // Candidates strongest first: (height of the maximum, its wavelength [nm], its FWHM [nm]).
    let mut candidates: Vec<(f64, f64, f64)> = runs
        .iter()
        .map(|r| {
            let top = v.get(r.2).copied().unwrap_or(f64::NAN);
            (top, grid.wavelength(r.2 as f64), fwhm_nm(s, r.2, noise.floor))
        })
        .collect();
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut kept: Vec<(f64, f64)> = Vec::new();
    for &(_, c, w) in &candidates {
        if kept.iter().all(|&(k, kw)| (c - k).abs() >= MIN_SEPARATION_FWHM * kw) {
            kept.push((c, w));
        }
    }
    let mut centres: Vec<f64> = kept.iter().map(|k| k.0).collect();
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

/// `v` averaged over a centred run of about a quarter of its strongest peak's width in samples
/// (itself when that is under eight samples, as on a spectrometer's coarse grid, or when
/// nothing rises above the floor); NaN samples are left out of the averages.
fn smooth(v: &[f64]) -> Vec<f64> {
    let finite: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    let floor = NoiseEstimate::of(&finite).floor;
    let top = (0..v.len())
        .filter(|&i| v.get(i).is_some_and(|x| x.is_finite()))
        .max_by(|&a, &b| v.get(a).copied().unwrap_or(f64::NAN).total_cmp(&v.get(b).copied().unwrap_or(f64::NAN)));
    let Some(top) = top else { return v.to_vec() };
    let (left, right) = half_height_span(v, top, floor);
    let h = (right - left + 1) / 8;
    // Nothing above the floor (a flat channel): nothing to average for.
    if h == 0 || v.get(top).is_none_or(|&x| x <= floor) {
        return v.to_vec();
    }
    (0..v.len())
        .map(|i| {
            let part = v.get(i.saturating_sub(h)..(i + h + 1).min(v.len())).unwrap_or_default();
            let (sum, n) = part.iter().filter(|x| x.is_finite()).fold((0.0, 0usize), |(s, n), &x| (s + x, n + 1));
            if n == 0 {
                f64::NAN
            } else {
                sum / n as f64
            }
        })
        .collect()
}

/// The full width at half height above `floor` \[nm\] of the peak whose maximum is sample
/// `top`: from the last samples at or above half height on either side (at least one step).
fn fwhm_nm(s: &Spectrum<'_, f64>, top: usize, floor: f64) -> f64 {
    let (left, right) = half_height_span(s.samples(), top, floor);
    let g = s.grid();
    let width = (g.wavelength(right as f64 + 0.5) - g.wavelength(left as f64 - 0.5)).abs();
    width.max(g.step_at(top as f64).abs())
}

/// The first and last sample of the run around sample `top` at or above half its height over
/// `floor`.
fn half_height_span(v: &[f64], top: usize, floor: f64) -> (usize, usize) {
    let half = floor + 0.5 * (v.get(top).copied().unwrap_or(f64::NAN) - floor);
    let above = |i: &usize| v.get(*i).is_some_and(|&x| x >= half);
    let left = (0..top).rev().take_while(above).last().unwrap_or(top);
    let right = (top + 1..v.len()).take_while(above).last().unwrap_or(top);
    (left, right)
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
