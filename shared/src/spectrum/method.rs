//! The peak-finding methods, by name.

use super::centroid::{centroid, maximum};
use super::correlation::cross_correlation;
use super::estimate::Estimate;
use super::gauss3::gaussian3;
use super::gauss_fit::gaussian_fit;
use super::region::Region;
use crate::real::Real;

/// How a window's peak centre is found (each documented at its function; accuracy and cost in
/// the [module docs](super)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Method {
    /// The pixel of the maximum ([`super::centroid::maximum`]).
    Maximum,
    /// The centroid above the threshold ([`super::centroid::centroid`]).
    Centroid,
    /// The Gaussian 3-point log-parabola ([`super::gauss3::gaussian3`]).
    Gaussian3,
    /// The Gaussian least-squares fit ([`super::gauss_fit::gaussian_fit`]).
    GaussianFit,
    /// Cross-correlation with a Gaussian reference ([`super::correlation::cross_correlation`]):
    /// the default (with the detector's default reference, twice the peak's own width, it
    /// locks the least to the pixel grid on symmetric peaks).
    #[default]
    CrossCorrelation,
}

impl Method {
    /// Every method, in the order above.
    pub const ALL: [Method; 5] =
        [Method::Maximum, Method::Centroid, Method::Gaussian3, Method::GaussianFit, Method::CrossCorrelation];

    /// Its code on the link (its position in [`Method::ALL`]: 0 maximum … 4
    /// cross-correlation).
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The method of a link code, `None` for an unknown one.
    pub fn from_code(code: u8) -> Option<Method> {
        Method::ALL.get(usize::from(code)).copied()
    }

    /// Its name (`maximum`, `centroid`, `gaussian3`, `gaussian-fit`, `cross-correlation`).
    pub const fn name(self) -> &'static str {
        match self {
            Method::Maximum => "maximum",
            Method::Centroid => "centroid",
            Method::Gaussian3 => "gaussian3",
            Method::GaussianFit => "gaussian-fit",
            Method::CrossCorrelation => "cross-correlation",
        }
    }

    /// The method's estimate on an analysed window; `reference_fwhm_px` is the
    /// cross-correlation's reference width \[pixels\].
    pub fn estimate<R: Real>(self, region: &Region<'_, R>, reference_fwhm_px: R) -> Estimate<R> {
        match self {
            Method::Maximum => maximum(region),
            Method::Centroid => centroid(region),
            Method::Gaussian3 => gaussian3(region),
            Method::GaussianFit => gaussian_fit(region),
            Method::CrossCorrelation => cross_correlation(region, reference_fwhm_px),
        }
    }
}

impl core::fmt::Display for Method {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}
