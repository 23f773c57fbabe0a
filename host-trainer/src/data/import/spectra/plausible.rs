//! Peaks no grating can make: a frame whose peak stands far above the grating's usual height
//! (one hot pixel, a cosmic ray, a stray reflection) or is far narrower than the grating's
//! usual width (narrower than the optics spread any line). The detector takes such a frame's
//! maximum for the grating and may flag it only `asymmetric`; its wavelength would be the
//! spike's. It is a fault here: the frame's value is a gap, counted as `implausible`.
//!
//! The grating's usual height and width are the medians over its frames (the peaks the
//! detector found without a fault), so a slow change of source power or of the grating's shape
//! is followed and only a frame that breaks with the rest is taken.

use super::kept::{Found, Kept};

/// A peak higher above its floor than this many times the grating's median height is not the
/// grating's: a source does not brighten tenfold between frames, and a clipped top is flagged
/// `saturated` before it could.
pub(crate) const MAX_HEIGHT_RATIO: f64 = 10.0;

/// A peak narrower than this fraction of the grating's median FWHM is not the grating's: the
/// spectrometer's optics give every line at least their own width, which the grating's usual
/// width includes.
pub(crate) const MIN_WIDTH_RATIO: f64 = 0.5;

/// Frames a grating needs before its medians are trusted.
const MIN_FRAMES: usize = 3;

/// The name counted in the summary and written in the peaks table.
pub(crate) const IMPLAUSIBLE: &str = "implausible";

/// Per frame of one grating's `peaks`: whether its peak is implausible (see the module).
pub(crate) fn implausible<T: Kept>(peaks: &[Option<T>]) -> Vec<bool> {
    let found = || peaks.iter().map(|p| p.map(T::into));
    let usable = || {
        found().flatten().filter(|p: &Found| {
            !p.flags.is_fault() && p.amplitude.is_finite() && p.fwhm_nm.is_finite() && p.fwhm_nm > 0.0
        })
    };
    let mut heights: Vec<f64> = usable().map(|p| p.amplitude).collect();
    let mut widths: Vec<f64> = usable().map(|p| p.fwhm_nm).collect();
    if heights.len() < MIN_FRAMES {
        return vec![false; peaks.len()];
    }
    let (h, w) = (median(&mut heights), median(&mut widths));
    found().map(|p| p.is_some_and(|p| p.amplitude > MAX_HEIGHT_RATIO * h || p.fwhm_nm < MIN_WIDTH_RATIO * w)).collect()
}

/// The median of `v` (non-empty, finite), reordering it.
fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match (v.get(n / 2), v.get(n.saturating_sub(1) / 2)) {
        (Some(a), Some(b)) => 0.5 * (a + b),
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fbg_shared::spectrum::{Peak, PeakFlags};

    fn peak(amplitude: f64, fwhm_nm: f64) -> Option<Peak<f64>> {
        Some(Peak {
            wavelength_nm: 1550.0,
            pixel: 0.0,
            amplitude,
            floor: 0.0,
            fwhm_nm,
            snr: 100.0,
            flags: PeakFlags::OK,
        })
    }

    #[test]
    fn a_spike_or_a_sliver_breaks_with_the_grating_and_a_slow_change_does_not() {
        let mut p: Vec<_> = (0..20).map(|k| peak(1000.0 * (1.0 - 0.02 * k as f64), 0.3)).collect();
        p[5] = peak(100_000.0, 0.31);
        p[9] = peak(1000.0, 0.01);
        p[12] = None;
        let bad = implausible(&p);
        assert_eq!(bad.iter().enumerate().filter(|(_, &b)| b).map(|(k, _)| k).collect::<Vec<_>>(), [5, 9]);
        assert_eq!(implausible(&p[..2]), [false, false]);
    }
}
