//! The peak detector: per-grating windows, a method, thresholds and the quality checks.

use super::estimate::Estimate;
use super::flags::PeakFlags;
use super::gauss3::gaussian3;
use super::method::Method;
use super::num::{abs, positive, real};
use super::peak::Peak;
use super::region::{Region, Threshold};
use super::shape::{second_peak, HalfWidths};
use super::view::Spectrum;
use super::window::{Span, Window};
use crate::layout::MAX_GRATINGS;
use crate::real::Real;

/// The cross-correlation's default reference FWHM over the peak's own.
const REFERENCE_PER_FWHM: f64 = 2.0;

/// The detector's settings (coefficients; the detector keeps no state between spectra).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DetectorConfig<R> {
    /// The method (default [`Method::CrossCorrelation`]).
    pub method: Method,
    /// Where the peak's samples start (default 50 % of the height above the floor).
    pub threshold: Threshold<R>,
    /// The cross-correlation's reference FWHM \[nm\]; 0 or less (the default): twice each
    /// peak's own half-maximum width (a reference wider than the peak averages the pixel grid
    /// out of the correlation: less peak-locking on a coarse grid for a little more noise).
    pub reference_fwhm_nm: R,
    /// The detector's full scale in the spectrum's unit (a 16-bit frame: 65 535); a sample at
    /// or above it raises [`PeakFlags::SATURATED`]. Default +∞ (never).
    pub full_scale: R,
    /// [`PeakFlags::LOW_SNR`] below this height/σ (linear; default 10, i.e. 10 dB).
    pub min_snr: R,
    /// [`PeakFlags::NO_PEAK`] below this height/σ (linear; default 5, i.e. 7 dB: white noise
    /// alone in a window of a few hundred samples stays under it).
    pub no_peak_snr: R,
    /// [`PeakFlags::TOO_NARROW`] below this FWHM \[nm\] (default 0: never).
    pub min_fwhm_nm: R,
    /// [`PeakFlags::TOO_WIDE`] above this FWHM \[nm\] (default +∞: never).
    pub max_fwhm_nm: R,
    /// [`PeakFlags::ASYMMETRIC`] above this ratio of the half-widths at half maximum
    /// (default 1.5).
    pub max_asymmetry: R,
    /// [`PeakFlags::SECOND_PEAK`] when samples apart from the main peak rise above this
    /// fraction of its height (plus 3σ; default 0.25, above a uniform grating's 4.7 % side
    /// lobes).
    pub second_peak_fraction: R,
}

impl<R: Real> Default for DetectorConfig<R> {
    fn default() -> Self {
        DetectorConfig {
            method: Method::default(),
            threshold: Threshold::default(),
            reference_fwhm_nm: R::ZERO,
            full_scale: R::INFINITY,
            min_snr: R::from_f64(10.0),
            no_peak_snr: R::from_f64(5.0),
            min_fwhm_nm: R::ZERO,
            max_fwhm_nm: R::INFINITY,
            max_asymmetry: R::from_f64(1.5),
            second_peak_fraction: R::from_f64(0.25),
        }
    }
}

/// Peak detection for up to `N` ≤ [`MAX_GRATINGS`] gratings: one search window each, one
/// [`DetectorConfig`]. Immutable; `detect` borrows a spectrum and returns one result per slot.
///
/// ```
/// use fbg_shared::spectrum::{DetectorConfig, Grid, PeakDetector, Spectrum, Window};
/// // A Gaussian of 0.3 nm FWHM at 1550.0123 nm on an 8 pm grid.
/// let grid = Grid::uniform(1548.0f64, 0.008);
/// let s: Vec<f64> = (0..500)
///     .map(|i| {
///         let d = (grid.wavelength(i as f64) - 1550.0123) / (0.3 / 2.354_820_045);
///         (-0.5 * d * d).exp()
///     })
///     .collect();
/// let det = PeakDetector::<f64, 2>::new(DetectorConfig::default(), &[Window::centred(1550.0, 1.0)]).unwrap();
/// let [first, unused] = det.detect(&Spectrum::new(&s, grid));
/// let p = first.unwrap();
/// assert!((p.wavelength_nm - 1550.0123).abs() < 1e-9 && p.flags.is_ok());
/// assert!((p.fwhm_nm - 0.3).abs() < 1e-6);
/// assert!(unused.is_none());
/// ```
#[derive(Clone, Debug)]
pub struct PeakDetector<R, const N: usize> {
    config: DetectorConfig<R>,
    windows: heapless::Vec<Window<R>, N>,
}

impl<R: Real, const N: usize> PeakDetector<R, N> {
    const CAPACITY: () = assert!(N <= MAX_GRATINGS, "at most MAX_GRATINGS windows");

    /// A detector for `windows` (one per grating, in the order results come back); `None`
    /// when there are more than `N`.
    pub fn new(config: DetectorConfig<R>, windows: &[Window<R>]) -> Option<Self> {
        let () = Self::CAPACITY;
        Some(PeakDetector { config, windows: heapless::Vec::from_slice(windows).ok()? })
    }

    /// The settings.
    pub fn config(&self) -> &DetectorConfig<R> {
        &self.config
    }

    /// The windows.
    pub fn windows(&self) -> &[Window<R>] {
        &self.windows
    }

    /// One result per slot: `Some` for each window (a peak, or [`Peak::none`] with
    /// [`PeakFlags::NO_PEAK`]), `None` for the slots past the windows.
    pub fn detect(&self, spectrum: &Spectrum<'_, R>) -> [Option<Peak<R>>; N] {
        core::array::from_fn(|k| self.windows.get(k).map(|w| self.detect_in(spectrum, w)))
    }

    /// The peak in one window ([`DetectorConfig::detect`]).
    pub fn detect_in(&self, spectrum: &Spectrum<'_, R>, window: &Window<R>) -> Peak<R> {
        self.config.detect(spectrum, window)
    }
}

impl<R: Real> DetectorConfig<R> {
    /// The peak in one window with these settings: the detector's work for one grating. A
    /// [`Spectrum::part`] holding the window's pixels gives the peak the whole frame gives.
    pub fn detect(&self, spectrum: &Spectrum<'_, R>, window: &Window<R>) -> Peak<R> {
        self.detect_with(spectrum, window, |r, px| self.method.estimate(r, px))
    }

    /// [`DetectorConfig::detect`] with the method's estimator given, e.g.
    /// [`super::correlation::cross_correlation`]: a device that runs one method then links that
    /// one only. `self.method` must name it (it decides which width the peak reports); with
    /// the estimator of `self.method` the result is [`DetectorConfig::detect`]'s, bit for bit.
    pub fn detect_with(
        &self,
        spectrum: &Spectrum<'_, R>,
        window: &Window<R>,
        estimate: impl Fn(&Region<'_, R>, R) -> Estimate<R>,
    ) -> Peak<R> {
        match window.span(spectrum) {
            Some(span) => self.detect_span(spectrum, span, estimate),
            None => Peak::none(R::NAN, R::NAN, PeakFlags::OK),
        }
    }

    /// [`DetectorConfig::detect_with`] on the window's pixels `span`, found once when the
    /// window was set up ([`Window::span_of`] on the spectrum's grid): a device that keeps a
    /// window's pixels skips the two inversions of the pixel polynomial per frame. With the
    /// span [`Window::span`] gives, the result is `detect_with`'s, bit for bit; a span outside
    /// the spectrum's pixels gives no peak.
    pub fn detect_span(
        &self,
        spectrum: &Spectrum<'_, R>,
        span: Span,
        estimate: impl Fn(&Region<'_, R>, R) -> Estimate<R>,
    ) -> Peak<R> {
        let c = self;
        let nan = R::NAN;
        if span.last < span.first.saturating_add(2) {
            return Peak::none(nan, nan, PeakFlags::OK);
        }
        let off = spectrum.first_pixel();
        let Some(w) = spectrum.samples().get(span.first.wrapping_sub(off)..=span.last.wrapping_sub(off)) else {
            return Peak::none(nan, nan, PeakFlags::OK);
        };
        if !w.iter().all(|v| v.is_finite()) {
            return Peak::none(nan, nan, PeakFlags::OK);
        }
        let region = Region::new(w, c.threshold);
        let (floor, sigma) = (region.noise.floor, region.noise.sigma);
        let mut flags = PeakFlags::OK;
        flags.set_if(PeakFlags::SATURATED, region.vmax >= c.full_scale);
        flags.set_if(PeakFlags::AT_EDGE, region.imax == 0 || region.imax == region.last());
        let height0 = region.height();
        let snr0 = snr(height0, sigma);
        if !positive(height0) || snr0 < c.no_peak_snr {
            return Peak::none(floor, snr0, flags);
        }
        let reference_px = if c.reference_fwhm_nm > R::ZERO {
            c.reference_fwhm_nm / abs(spectrum.grid().step_at(real::<R>(span.first) + real(region.imax)))
        } else {
            R::from_f64(REFERENCE_PER_FWHM) * HalfWidths::of(&region, real(region.imax), height0).fwhm()
        };
        let est = estimate(&region, reference_px);
        // The half-maximum level from the method's height when it is sane (a fit's height on a
        // clipped top can be anything), else from the maximum.
        let h = if est.height > R::ZERO && est.height <= height0 + height0 { est.height } else { height0 };
        // Half-widths about the 3-point centre whatever the method: it sits at the maximum of
        // an asymmetric peak (where a centroid or a fit moves towards the wider side) and is
        // sub-pixel (where the maximum's own pixel would make any coarse peak look lopsided).
        let hw = HalfWidths::of(&region, gaussian3(&region).pixel, h);
        // The fits' own width; the 3-point's curvature is too noisy on a finely sampled peak, so
        // it reports the half-maximum crossings' like the maximum and the centroid.
        let fitted = matches!(c.method, Method::GaussianFit | Method::CrossCorrelation);
        let fwhm_px = if fitted && est.fwhm_px.is_finite() { est.fwhm_px } else { hw.fwhm() };
        let pixel = real::<R>(span.first) + est.pixel;
        let wavelength_nm = spectrum.grid().wavelength(pixel);
        if !wavelength_nm.is_finite() {
            return Peak::none(floor, snr0, flags);
        }
        let fwhm_nm = fwhm_px * abs(spectrum.grid().step_at(pixel));
        let snr = snr(h, sigma);
        flags.set_if(PeakFlags::LOW_SNR, snr < c.min_snr);
        flags.set_if(PeakFlags::TOO_WIDE, fwhm_nm > c.max_fwhm_nm);
        flags.set_if(PeakFlags::TOO_NARROW, fwhm_nm < c.min_fwhm_nm);
        flags.set_if(PeakFlags::ASYMMETRIC, hw.asymmetry() > c.max_asymmetry);
        flags.set_if(PeakFlags::SECOND_PEAK, second_peak(&region, height0, c.second_peak_fraction));
        Peak { wavelength_nm, pixel, amplitude: est.height, floor, fwhm_nm, snr, flags }
    }
}

/// height/σ, +∞ for σ = 0 and a positive height.
fn snr<R: Real>(height: R, sigma: R) -> R {
    if sigma > R::ZERO {
        height / sigma
    } else if height > R::ZERO {
        R::INFINITY
    } else {
        R::ZERO
    }
}
