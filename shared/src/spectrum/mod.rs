//! Peak detection in a spectrum: from a spectrometer's or a swept laser's frame to each
//! grating's peak wavelength, with quality flags.
//!
//! `no_std`, no heap, fixed capacity, generic over [`Real`](crate::Real) (f32 on the device,
//! f64 on the host). One concept per file:
//!
//! - [`Grid`]: the wavelength of each pixel (uniform, or a pixel-to-wavelength polynomial);
//! - [`Spectrum`]: borrowed linear intensities on a grid ([`from_db`] converts dB levels);
//! - [`Window`]: a grating's search window \[nm\] and its pixels ([`Span`]);
//! - [`NoiseEstimate`]: the window's floor (lower quartile) and noise σ (median second
//!   difference), from a fixed-size strided selection;
//! - [`Region`]: a window analysed — maximum, floor, noise, the run above the [`Threshold`];
//! - the methods, each an [`Estimate`] in the window's pixels: [`centroid::maximum`],
//!   [`centroid::centroid`], [`gauss3::gaussian3`], [`gauss_fit::gaussian_fit`],
//!   [`correlation::cross_correlation`], chosen by [`Method`]; and [`template::template_fit`],
//!   a fit of the grating's own shape (a [`Template`]) from a method's first estimate;
//! - [`HalfWidths`] and [`shape::second_peak`]: the shape checks;
//! - [`Peak`] with its [`PeakFlags`]; [`PeakDetector`] with its [`DetectorConfig`];
//! - [`ShiftRef`]: a grating's λ_ref split in two reals, for the shift Δλ in f32.
//!
//! # Accuracy and cost
//!
//! Measured on analytic peaks (a Gaussian, a sinc² with its side lobes, two half-Gaussians of
//! different widths; 0.3 nm FWHM) swept over one pixel in 20 steps, on an 8 pm grid and on a
//! 512-pixel grid over 1510–1595 nm, noise-free (peak-locking: max − min of the error over the
//! sweep) and with white noise at 20, 30 and 40 dB (RMS error; SNR = 10·log₁₀(height/σ)):
//! `cargo test -p fbg-shared --test shared spectrum::accuracy_table -- --nocapture` prints the table
//! and asserts each method's bounds; the figures are in BENCHMARKS.md once `cargo xtask bench`
//! carries them. What the table shows:
//!
//! | method | accuracy | cost per window, beyond the common part |
//! |---|---|---|
//! | [`Method::Maximum`] | locks to the grid: error uniform over ±½ pixel | none |
//! | [`Method::Centroid`] | unbiased on a symmetric peak with many samples above the threshold; locks on a peak a few pixels wide; pulled towards an asymmetric peak's wider flank | per sample of the run: 1 subtract, 1 add, 1 multiply-add; 1 divide |
//! | [`Method::Gaussian3`] | exact on a noise-free Gaussian at any sampling; locks on other shapes on a coarse grid; noisy on a fine grid (three samples that barely differ) | 3 logarithms, 1 exponential, ≈ 15 operations |
//! | [`Method::GaussianFit`] | exact on a noise-free Gaussian; the least noise on a fine grid; on a coarse grid, locks on shapes other than a Gaussian; pulled towards an asymmetric peak's wider flank | per sample of the fitted span (the run, at least imax ± 2): 1 logarithm and ≈ 8 multiply-adds, then per Gauss–Newton step (≤ 5) 1 exponential and ≈ 14 multiply-adds; ≈ 30 operations per 3 × 3 solve |
//! | [`Method::CrossCorrelation`] (default) | with the default reference (twice the peak's width), the least peak-locking on symmetric peaks on a coarse grid and none to speak of on a fine one, a little more noise than the fit; pulled furthest towards an asymmetric peak's wider flank | h + 1 exponentials for the reference (h = ⌈1.5·FWHM_ref⌉ ≤ 128 pixels), then 2h + 1 multiply-adds per shift, ≥ 3 shifts; 3 logarithms, 1 exponential, 1 square root; the default reference adds the half-maximum crossings (5 logarithms) |
//!
//! Common part, every method, for a window of n samples: 3 passes (finiteness, maximum, the
//! second peak's level) of one compare per sample, the noise estimate (two selections among
//! m ≤ 32 strided samples, ≈ 2–3·m compares each, and one pass of a second difference, a
//! compare and an add per sample), the run above the threshold, the half-widths (4
//! logarithms) and the 3-point centre they are taken about (3 logarithms, 1 exponential).
//!
//! Quality flags ([`PeakFlags`]) and their tests: saturation, a second peak, low SNR and no
//! peak, asymmetry, width bounds, a peak at the window's edge (`shared/tests/spectrum.rs`);
//! f32 against f64 on the same spectra (`f32_agrees_with_f64`).

pub mod centroid;
pub mod correlation;
mod detector;
mod estimate;
mod flags;
pub mod gauss3;
pub mod gauss_fit;
mod grid;
mod method;
mod noise;
mod num;
mod peak;
mod region;
pub mod shape;
mod shift;
pub mod template;
mod view;
mod window;

pub use detector::{DetectorConfig, PeakDetector};
pub use estimate::Estimate;
pub use flags::PeakFlags;
pub use grid::{Grid, POLY_COEFFS};
pub use method::Method;
pub use noise::{NoiseEstimate, NOISE_SAMPLES};
pub use peak::Peak;
pub use region::{Region, Threshold};
pub use shape::HalfWidths;
pub use shift::ShiftRef;
pub use template::Template;
pub use view::{from_db, from_db_in_place, Spectrum};
pub use window::{Span, Window};
