//! Peak detection on analytic peaks at known sub-pixel positions: every method on a Gaussian,
//! a sinc² (a uniform grating's main lobe and side lobes) and an asymmetric peak (two
//! half-Gaussians), on an 8 pm grid and on a 512-pixel spectrometer grid over 1510–1595 nm,
//! noise-free (peak-locking) and with white noise at 20/30/40 dB (RMS error); the quality
//! flags; f32 against f64.
//!
//! SNR in dB is 10·log₁₀(peak height / noise σ), the optical-power convention
//! ([`Peak::snr_db`]). The table of every method × grid × shape × SNR is printed by
//! `cargo test -p fbg-shared --test shared spectrum::accuracy_table -- --nocapture`.

use fbg_shared::spectrum::{
    DetectorConfig, Grid, Method, Peak, PeakDetector, PeakFlags, Span, Spectrum, Threshold, Window,
};
use fbg_testkit::Rng;

/// FWHM of every test peak \[nm\].
const FWHM: f64 = 0.3;
/// 2·√(2 ln 2).
const FWHM_PER_SIGMA: f64 = 2.354_820_045_030_949;
/// FWHM of sinc²(v) = (sin πv / πv)² in v.
const SINC2_FWHM: f64 = 0.885_892_941_378_9;
/// The flat floor under every peak, as a fraction of the peak's height.
const FLOOR: f64 = 0.02;
/// Sub-pixel positions of the sweep over one pixel.
const STEPS: usize = 20;
/// Noise realisations per sub-pixel position.
const REALISATIONS: usize = 25;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    Gaussian,
    Sinc2,
    /// Half-widths at half maximum 0.12 nm left, 0.18 nm right (FWHM 0.3 nm).
    Asymmetric,
}

impl Shape {
    const ALL: [Shape; 3] = [Shape::Gaussian, Shape::Sinc2, Shape::Asymmetric];

    /// The shape at offset `x` \[nm\] from its maximum, 1 at the maximum.
    fn at(self, x: f64) -> f64 {
        match self {
            Shape::Gaussian => gauss(x, FWHM / FWHM_PER_SIGMA),
            Shape::Sinc2 => {
                let v = std::f64::consts::PI * x * SINC2_FWHM / FWHM;
                if v.abs() < 1e-12 {
                    1.0
                } else {
                    (v.sin() / v).powi(2)
                }
            }
            Shape::Asymmetric => {
                let hwhm = if x < 0.0 { 0.4 * FWHM } else { 0.6 * FWHM };
                gauss(x, 2.0 * hwhm / FWHM_PER_SIGMA)
            }
        }
    }
}

fn gauss(x: f64, s: f64) -> f64 {
    (-0.5 * (x / s).powi(2)).exp()
}

/// A test grid: the grid, its pixels, the nominal centre of the swept peak and the window's
/// half-width.
#[derive(Clone, Copy)]
struct Case {
    name: &'static str,
    grid: Grid<f64>,
    pixels: usize,
    nominal_px: usize,
    half_window_nm: f64,
}

/// 8 pm over 1546–1554 nm, the peak near 1550 nm, a ±1 nm window.
const FINE: Case = Case {
    name: "8 pm",
    grid: Grid::Uniform { start_nm: 1546.0, step_nm: 0.008 },
    pixels: 1000,
    nominal_px: 500,
    half_window_nm: 1.0,
};
/// 512 pixels over 1510–1595 nm (≈ 166 pm/pixel), a ±2 nm window.
const COARSE: Case = Case {
    name: "512 px",
    grid: Grid::Uniform { start_nm: 1510.0, step_nm: 85.0 / 511.0 },
    pixels: 512,
    nominal_px: 240,
    half_window_nm: 2.0,
};

/// `shape` with its maximum at `centre` nm, height 1 on the floor, plus white noise of σ =
/// 10^(−snr_db/10) when given.
fn spectrum(case: &Case, shape: Shape, centre: f64, snr_db: Option<f64>, rng: &mut Rng) -> Vec<f64> {
    let sigma = snr_db.map_or(0.0, |s| 10f64.powf(-s / 10.0));
    (0..case.pixels)
        .map(|i| {
            let noise = if sigma > 0.0 { sigma * rng.normal() } else { 0.0 };
            FLOOR + shape.at(case.grid.wavelength(i as f64) - centre) + noise
        })
        .collect()
}

fn detector(case: &Case, config: DetectorConfig<f64>) -> PeakDetector<f64, 1> {
    let w = Window::centred(case.grid.wavelength(case.nominal_px as f64), case.half_window_nm);
    PeakDetector::new(config, &[w]).unwrap()
}

fn with_method(method: Method) -> DetectorConfig<f64> {
    DetectorConfig { method, ..DetectorConfig::default() }
}

/// Errors \[pm\] of one method over the sub-pixel sweep.
#[derive(Debug, Default, Clone, Copy)]
struct Stats {
    /// RMS of all errors.
    rms: f64,
    /// Max − min of the per-position mean error.
    locking: f64,
    /// Mean error.
    bias: f64,
}

fn sweep(case: &Case, shape: Shape, method: Method, snr_db: Option<f64>, seed: u64) -> Stats {
    let det = detector(case, with_method(method));
    let mut rng = Rng::new(seed);
    let reps = if snr_db.is_some() { REALISATIONS } else { 1 };
    let (mut sq, mut sum, mut n) = (0.0, 0.0, 0.0);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..STEPS {
        let centre = case.grid.wavelength(case.nominal_px as f64 + k as f64 / STEPS as f64);
        let mut mean = 0.0;
        for _ in 0..reps {
            let s = spectrum(case, shape, centre, snr_db, &mut rng);
            let [p] = det.detect(&Spectrum::new(&s, case.grid));
            let p = p.unwrap();
            let e = (p.wavelength_nm - centre) * 1e3;
            assert!(e.is_finite(), "{} {shape:?} {method}: no wavelength ({})", case.name, p.flags);
            sq += e * e;
            sum += e;
            n += 1.0;
            mean += e / reps as f64;
        }
        lo = lo.min(mean);
        hi = hi.max(mean);
    }
    Stats { rms: (sq / n).sqrt(), locking: hi - lo, bias: sum / n }
}

/// The bounds each method is held to \[pm\]: noise-free peak-locking (max − min over the sweep)
/// and RMS at 30 dB, per grid and shape, in `Shape::ALL` order. The targets: RMS
/// ≤ 1 pm on the 8 pm grid and ≤ 3 pm on the 512-pixel grid at 30 dB, locking ≤ 0.5 pm p-p
/// for the default method; where a method misses one, its bound is what it reaches with a
/// margin and the comment says so.
struct Bounds {
    method: Method,
    fine: [(f64, f64); 3],
    coarse: [(f64, f64); 3],
}

// The bounds of `accuracy_table`: (noise-free peak-locking p-p, RMS at 30 dB) in pm, per shape
// in `Shape::ALL` order (Gaussian, sinc², asymmetric), on the 8 pm grid and on the 512-pixel
// grid. Each is what the method reaches (the table the test prints) with a margin; the issue's
// targets are ≤ 1 pm (8 pm grid) and ≤ 3 pm (512 pixels) RMS at 30 dB and ≤ 0.5 pm locking for
// the default method (`cross-correlation`).
//
// Targets the methods do not meet, and why (the figures are in the printed table):
// - asymmetric peak, every method but the maximum and the 3-point on the 8 pm grid: the RMS is
//   a bias, not noise. The truth is the maximum's wavelength; a centroid, a symmetric fit or a
//   symmetric reference puts the centre towards the wider flank (the wider the reference, the
//   further). Which centre a grating's "wavelength" is must be calibrated (λ_ref), and a
//   constant bias cancels in the shifts; the locking is what matters there.
// - default method, 512-pixel grid, asymmetric peak: locking above 0.5 pm (a peak 1.8 pixels
//   wide whose shape the symmetric reference does not match).
// - the Gaussian fit and the 3-point on the 512-pixel grid, sinc² and asymmetric peaks: a
//   Gaussian model on a non-Gaussian peak of 1.8 pixels FWHM has a bias that depends on the
//   sub-pixel position (within the RMS target, far above the locking one).
// - the maximum everywhere, the centroid on the 512-pixel grid (about two samples above half),
//   the 3-point on the 8 pm grid at 30 dB (its three samples barely differ at 0.3 nm FWHM).
const BOUNDS: [Bounds; 5] = [
    Bounds {
        method: Method::Maximum,
        // One pixel p-p, ±½ pixel: RMS 1/√12 pixel.
        fine: [(8.0, 4.5), (8.0, 4.5), (8.0, 4.5)],
        coarse: [(167.0, 55.0), (167.0, 55.0), (167.0, 55.0)],
    },
    Bounds {
        method: Method::Centroid,
        fine: [(0.2, 0.1), (0.2, 0.1), (0.2, 22.5)],
        coarse: [(35.0, 8.0), (35.0, 8.0), (32.0, 24.0)],
    },
    Bounds {
        method: Method::Gaussian3,
        fine: [(0.01, 2.5), (0.01, 2.6), (1.0, 3.0)],
        coarse: [(0.01, 0.25), (8.0, 3.0), (20.0, 29.5)],
    },
    Bounds {
        method: Method::GaussianFit,
        fine: [(0.01, 0.08), (0.12, 0.08), (0.8, 21.5)],
        coarse: [(0.01, 0.25), (6.5, 2.5), (12.5, 31.5)],
    },
    Bounds {
        method: Method::CrossCorrelation,
        fine: [(0.01, 0.08), (0.01, 0.08), (0.05, 38.0)],
        coarse: [(0.35, 0.35), (0.4, 0.35), (4.5, 38.0)],
    },
];

#[test]
fn accuracy_table() {
    eprintln!("| method | grid | shape | locking p-p (noise-free) | bias | RMS 20 dB | RMS 30 dB | RMS 40 dB |");
    eprintln!("|---|---|---|---|---|---|---|---|");
    let mut failures = Vec::new();
    for b in &BOUNDS {
        for (case, bounds) in [(&FINE, &b.fine), (&COARSE, &b.coarse)] {
            for (shape, &(lock_max, rms30_max)) in Shape::ALL.iter().zip(bounds) {
                let clean = sweep(case, *shape, b.method, None, 1);
                let rms: Vec<f64> =
                    [20.0, 30.0, 40.0].iter().map(|&snr| sweep(case, *shape, b.method, Some(snr), 7).rms).collect();
                eprintln!(
                    "| {} | {} | {:?} | {:.3} | {:+.3} | {:.3} | {:.3} | {:.3} |",
                    b.method, case.name, shape, clean.locking, clean.bias, rms[0], rms[1], rms[2]
                );
                if clean.locking > lock_max || rms[1] > rms30_max {
                    failures.push(format!(
                        "{} {} {shape:?}: locking {:.3} (≤ {lock_max}), RMS 30 dB {:.3} (≤ {rms30_max})",
                        b.method, case.name, clean.locking, rms[1]
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Flags raised over the sweep of clean peaks at 30 dB, per method and grid: none on a
/// Gaussian or a sinc², and the SNR estimate within ±4 dB of the truth.
#[test]
fn clean_peaks_raise_no_flag() {
    for method in Method::ALL {
        for case in [&FINE, &COARSE] {
            for shape in [Shape::Gaussian, Shape::Sinc2] {
                let det = detector(case, with_method(method));
                let mut rng = Rng::new(3);
                let (mut raised, mut snr_lo, mut snr_hi) = (PeakFlags::OK, f64::INFINITY, 0.0f64);
                for k in 0..STEPS {
                    let centre = case.grid.wavelength(case.nominal_px as f64 + k as f64 / STEPS as f64);
                    for _ in 0..5 {
                        let s = spectrum(case, shape, centre, Some(30.0), &mut rng);
                        let p = det.detect(&Spectrum::new(&s, case.grid))[0].unwrap();
                        raised.insert(p.flags);
                        snr_lo = snr_lo.min(p.snr_db());
                        snr_hi = snr_hi.max(p.snr_db());
                    }
                }
                eprintln!("{method} {} {shape:?}: flags {raised}, SNR estimate {snr_lo:.1}..{snr_hi:.1} dB", case.name);
                assert!(raised.is_ok(), "{method} {} {shape:?}: {raised}", case.name);
                // A sinc² on the 512-pixel grid: its side lobes, aliased, curve like noise and
                // count as such (the SNR comes out low, see the message); elsewhere ±4 dB.
                if !(shape == Shape::Sinc2 && case.name == COARSE.name) {
                    assert!(
                        snr_lo > 26.0 && snr_hi < 34.0,
                        "{method} {} {shape:?}: SNR {snr_lo}..{snr_hi} dB",
                        case.name
                    );
                }
            }
        }
    }
}

/// `f(λ)` + the floor + white noise of σ at every pixel of `case`.
fn render(case: &Case, f: impl Fn(f64) -> f64, sigma: f64, rng: &mut Rng) -> Vec<f64> {
    (0..case.pixels)
        .map(|i| FLOOR + f(case.grid.wavelength(i as f64)) + if sigma > 0.0 { sigma * rng.normal() } else { 0.0 })
        .collect()
}

fn detect(case: &Case, config: DetectorConfig<f64>, s: &[f64]) -> Peak<f64> {
    detector(case, config).detect(&Spectrum::new(s, case.grid))[0].unwrap()
}

fn nominal(case: &Case) -> f64 {
    case.grid.wavelength(case.nominal_px as f64 + 0.3)
}

#[test]
fn saturation_is_flagged() {
    for case in [&FINE, &COARSE] {
        let c = nominal(case);
        let mut rng = Rng::new(11);
        let s = render(case, |l| Shape::Gaussian.at(l - c), 1e-3, &mut rng);
        let clipped: Vec<f64> = s.iter().map(|&v| v.min(0.8)).collect();
        for method in Method::ALL {
            let cfg = DetectorConfig { method, full_scale: 0.8, ..DetectorConfig::default() };
            let p = detect(case, cfg, &clipped);
            assert!(
                p.flags.contains(PeakFlags::SATURATED) && p.flags.is_fault(),
                "{method} {}: {}",
                case.name,
                p.flags
            );
            let cfg = DetectorConfig { method, full_scale: 1.1, ..DetectorConfig::default() };
            assert!(!detect(case, cfg, &s).flags.contains(PeakFlags::SATURATED), "{method} {}", case.name);
        }
    }
}

#[test]
fn a_second_peak_in_the_window_is_flagged() {
    // Half as high, 0.7 nm away on the 8 pm grid (±1 nm window), 1.2 nm on the 512-pixel grid
    // (±2 nm); a lone sinc²'s side lobes (4.7 %) are not a second peak (`clean_peaks_raise_no_flag`).
    for (case, gap) in [(&FINE, 0.7), (&COARSE, 1.2)] {
        let c = nominal(case);
        let mut rng = Rng::new(12);
        let s = render(case, |l| Shape::Gaussian.at(l - c) + 0.5 * Shape::Gaussian.at(l - c - gap), 1e-3, &mut rng);
        for method in Method::ALL {
            let p = detect(case, with_method(method), &s);
            assert!(p.flags.contains(PeakFlags::SECOND_PEAK), "{method} {}: {}", case.name, p.flags);
            assert!((p.wavelength_nm - c).abs() < 0.1, "{method} {}: the higher peak is the one found", case.name);
        }
    }
}

#[test]
fn low_snr_and_no_peak_are_flagged() {
    let case = &FINE;
    let c = nominal(case);
    let mut rng = Rng::new(13);
    // 8.5 dB (height/σ = 7.1): between `no_peak_snr` (5) and `min_snr` (10).
    let sigma = 10f64.powf(-0.85);
    for _ in 0..50 {
        let s = render(case, |l| Shape::Gaussian.at(l - c), sigma, &mut rng);
        let p = detect(case, DetectorConfig::default(), &s);
        assert!(p.flags.contains(PeakFlags::LOW_SNR) && !p.flags.contains(PeakFlags::NO_PEAK), "{} {}", p.flags, p.snr);
        assert!((p.wavelength_nm - c).abs() < 0.15, "still found: {}", p.wavelength_nm);
    }
    // Noise alone: no peak, a NaN wavelength, but for the rare window whose largest noise
    // sample stands 5 σ above the floor (`no_peak_snr`): at most 2 % (see the message).
    for case in [&FINE, &COARSE] {
        let mut found = 0;
        for _ in 0..200 {
            let s = render(case, |_| 0.0, 0.01, &mut rng);
            let p = detect(case, DetectorConfig::default(), &s);
            if !p.flags.contains(PeakFlags::NO_PEAK) {
                found += 1;
            } else {
                assert!(p.wavelength_nm.is_nan() && p.flags.is_fault());
            }
        }
        eprintln!("{}: {found} of 200 noise-only windows gave a peak", case.name);
        assert!(found <= 4, "{}: {found} of 200 noise-only windows gave a peak", case.name);
    }
    // A flat window, a window off the spectrum, a NaN sample.
    let flat = vec![1.0; case.pixels];
    assert!(detect(case, DetectorConfig::default(), &flat).flags.contains(PeakFlags::NO_PEAK));
    let s = render(case, |l| Shape::Gaussian.at(l - c), 0.0, &mut rng);
    let det = PeakDetector::<f64, 1>::new(DetectorConfig::default(), &[Window::centred(1700.0, 1.0)]).unwrap();
    assert_eq!(det.detect(&Spectrum::new(&s, case.grid))[0].unwrap().flags, PeakFlags::NO_PEAK);
    let mut s = s;
    s[case.nominal_px + 10] = f64::NAN;
    assert_eq!(detect(case, DetectorConfig::default(), &s).flags, PeakFlags::NO_PEAK);
}

#[test]
fn an_asymmetric_peak_is_flagged() {
    // Half-widths in the ratio 2.75 against the default 1.5: 0.08 and 0.22 nm on the 8 pm grid;
    // 0.2 and 0.55 nm on the 512-pixel grid, where a half-width under a pixel or two has too
    // few samples for its asymmetry to be seen (0.08 nm is half a pixel there).
    for (case, (l_hw, r_hw)) in [(&FINE, (0.08, 0.22)), (&COARSE, (0.2, 0.55))] {
        let c = nominal(case);
        let mut rng = Rng::new(14);
        let lopsided = |x: f64| gauss(x, 2.0 * if x < 0.0 { l_hw } else { r_hw } / FWHM_PER_SIGMA);
        for k in 0..STEPS {
            let centre = c + k as f64 / STEPS as f64 * case.grid.step_at(0.0);
            let s = render(case, |l| lopsided(l - centre), 1e-3, &mut rng);
            for method in Method::ALL {
                let p = detect(case, with_method(method), &s);
                assert!(p.flags.contains(PeakFlags::ASYMMETRIC), "{method} {} k = {k}: {}", case.name, p.flags);
            }
        }
    }
}

#[test]
fn width_bounds_and_the_window_edge() {
    let case = &FINE;
    let c = nominal(case);
    let mut rng = Rng::new(15);
    let cfg = |method| DetectorConfig { method, min_fwhm_nm: 0.2, max_fwhm_nm: 0.4, ..DetectorConfig::default() };
    for method in Method::ALL {
        for (fwhm, want) in [(0.3, PeakFlags::OK), (0.6, PeakFlags::TOO_WIDE), (0.12, PeakFlags::TOO_NARROW)] {
            let s = render(case, |l| gauss(l - c, fwhm / FWHM_PER_SIGMA), 1e-3, &mut rng);
            let p = detect(case, cfg(method), &s);
            assert_eq!(p.flags, want, "{method} FWHM {fwhm}: measured {}", p.fwhm_nm);
            assert!(
                (p.fwhm_nm - fwhm).abs() < 0.15 * fwhm || method == Method::Maximum,
                "{method}: FWHM {}",
                p.fwhm_nm
            );
        }
        // A peak centred 0.3 nm past the window's upper edge.
        let s = render(case, |l| Shape::Gaussian.at(l - (c + 1.3)), 1e-3, &mut rng);
        let p = detect(case, with_method(method), &s);
        assert!(p.flags.contains(PeakFlags::AT_EDGE) && p.flags.is_fault(), "{method}: {}", p.flags);
    }
}

/// The same spectra through f32 (samples and grid rounded) and f64: every method agrees within
/// a fraction of a pm (an f32 wavelength near 1550 nm has a 0.12 pm ulp; see the message for the
/// worst difference).
#[test]
fn f32_agrees_with_f64() {
    for case in [&FINE, &COARSE] {
        let Grid::Uniform { start_nm, step_nm } = case.grid else { unreachable!() };
        let grid32 = Grid::uniform(start_nm as f32, step_nm as f32);
        let w = Window::centred(case.grid.wavelength(case.nominal_px as f64), case.half_window_nm);
        let w32 = Window::centred(w.lo_nm as f32 + case.half_window_nm as f32, case.half_window_nm as f32);
        let mut rng = Rng::new(16);
        for method in Method::ALL {
            let d64 = PeakDetector::<f64, 1>::new(with_method(method), &[w]).unwrap();
            let cfg32 = DetectorConfig { method, ..DetectorConfig::default() };
            let d32 = PeakDetector::<f32, 1>::new(cfg32, &[w32]).unwrap();
            let (mut worst, mut worst_fwhm) = (0.0f64, 0.0f64);
            for k in 0..STEPS {
                let centre = case.grid.wavelength(case.nominal_px as f64 + k as f64 / STEPS as f64);
                let s = spectrum(case, Shape::Gaussian, centre, Some(30.0), &mut rng);
                let s32: Vec<f32> = s.iter().map(|&v| v as f32).collect();
                let p64 = d64.detect(&Spectrum::new(&s, case.grid))[0].unwrap();
                let p32 = d32.detect(&Spectrum::new(&s32, grid32))[0].unwrap();
                assert_eq!(p64.flags, p32.flags, "{method} {}", case.name);
                worst = worst.max((f64::from(p32.wavelength_nm) - p64.wavelength_nm).abs() * 1e3);
                worst_fwhm = worst_fwhm.max((f64::from(p32.fwhm_nm) - p64.fwhm_nm).abs() * 1e3);
            }
            eprintln!("{method} {}: worst |λ32 − λ64| {worst:.3} pm, FWHM {worst_fwhm:.3} pm", case.name);
            // The correlation's FWHM is √(FWHM_C² − FWHM_ref²) with the reference twice the
            // peak: the subtraction amplifies f32's rounding of the correlation's curvature.
            let fwhm_tol = if method == Method::CrossCorrelation { 3.0 } else { 1.0 };
            assert!(worst_fwhm < fwhm_tol, "{method} {}: FWHM {worst_fwhm} pm", case.name);
            assert!(worst < 0.3, "{method} {}: {worst} pm", case.name);
        }
    }
}

/// A spectrometer's polynomial calibration (curved by 3 nm over 512 pixels): the default method
/// at 30 dB meets the 512-pixel grid's uniform-grid accuracy.
#[test]
fn a_polynomial_grid() {
    let grid = Grid::polynomial([1510.0, 0.16, 1.2e-5, -2.0e-9, 0.0, 0.0]);
    let case = Case { name: "polynomial", grid, pixels: 512, nominal_px: 240, half_window_nm: 2.0 };
    let (mut sq, mut n) = (0.0, 0.0);
    let det = detector(&case, DetectorConfig::default());
    let mut rng = Rng::new(17);
    for k in 0..STEPS {
        let centre = grid.wavelength(case.nominal_px as f64 + k as f64 / STEPS as f64);
        for _ in 0..REALISATIONS {
            let s = spectrum(&case, Shape::Gaussian, centre, Some(30.0), &mut rng);
            let p = det.detect(&Spectrum::new(&s, grid))[0].unwrap();
            assert!(p.flags.is_ok(), "{}", p.flags);
            let e = (p.wavelength_nm - centre) * 1e3;
            sq += e * e;
            n += 1.0;
        }
    }
    let rms = (sq / n).sqrt();
    eprintln!("polynomial grid, default method, 30 dB: RMS {rms:.3} pm");
    assert!(rms < 0.35, "{rms} pm");
}

/// Three gratings in one 512-pixel frame, a detector of capacity 4: three results in window
/// order, the fourth slot empty; dB input converted first gives the same peaks.
#[test]
fn three_gratings_in_one_frame() {
    let case = &COARSE;
    let centres = [1530.123, 1550.456, 1571.789];
    let mut rng = Rng::new(18);
    let s = render(case, |l| centres.iter().map(|&c| Shape::Gaussian.at(l - c)).sum(), 1e-3, &mut rng);
    let windows: Vec<Window<f64>> = [1530.0, 1550.0, 1572.0].iter().map(|&c| Window::centred(c, 2.0)).collect();
    let det = PeakDetector::<f64, 4>::new(DetectorConfig::default(), &windows).unwrap();
    let out = det.detect(&Spectrum::new(&s, case.grid));
    for (p, c) in out.iter().zip(centres) {
        let p = p.unwrap();
        assert!(p.flags.is_ok() && (p.wavelength_nm - c).abs() < 1e-3, "{c}: {p:?}");
    }
    assert!(out[3].is_none());
    let mut db: Vec<f64> = s.iter().map(|&v| 10.0 * v.log10()).collect();
    fbg_shared::spectrum::from_db_in_place(&mut db);
    let again = det.detect(&Spectrum::new(&db, case.grid));
    for (a, b) in out.iter().zip(&again).take(3) {
        assert!((a.unwrap().wavelength_nm - b.unwrap().wavelength_nm).abs() < 1e-9);
    }
    assert!(PeakDetector::<f64, 2>::new(DetectorConfig::default(), &windows).is_none(), "over capacity");
}

/// A threshold at k·σ above the floor instead of a fraction of the height: the centroid then
/// takes the whole peak above the noise (the 8 pm grid, 30 dB).
#[test]
fn a_noise_threshold() {
    let case = &FINE;
    let mut rng = Rng::new(19);
    let cfg =
        DetectorConfig { method: Method::Centroid, threshold: Threshold::Noise(5.0), ..DetectorConfig::default() };
    let det = detector(case, cfg);
    for k in 0..STEPS {
        let centre = case.grid.wavelength(case.nominal_px as f64 + k as f64 / STEPS as f64);
        let s = spectrum(case, Shape::Gaussian, centre, Some(30.0), &mut rng);
        let p = det.detect(&Spectrum::new(&s, case.grid))[0].unwrap();
        assert!(p.flags.is_ok() && (p.wavelength_nm - centre).abs() < 2e-3, "{p:?}");
    }
}

/// A grid whose wavelength falls with the pixel (a spectrometer read out the other way): the
/// same peak, the same wavelength; a window partly off the spectrum keeps the pixels inside.
#[test]
fn a_decreasing_grid_and_a_window_at_the_end() {
    let up = COARSE;
    let down = Case { name: "512 px, decreasing", grid: Grid::uniform(1595.0, -85.0 / 511.0), ..COARSE };
    let c = 1550.0371;
    let mut rng = Rng::new(20);
    for method in Method::ALL {
        let mut found = [0.0; 2];
        for (slot, case) in found.iter_mut().zip([&up, &down]) {
            let s = render(case, |l| Shape::Gaussian.at(l - c), 1e-3, &mut rng);
            let det = PeakDetector::<f64, 1>::new(with_method(method), &[Window::centred(1550.0, 2.0)]).unwrap();
            let p = det.detect(&Spectrum::new(&s, case.grid))[0].unwrap();
            assert!(p.flags.is_ok(), "{method} {}: {}", case.name, p.flags);
            *slot = p.wavelength_nm;
        }
        let tol = if method == Method::Maximum { 0.09 } else { 0.01 };
        assert!((found[0] - c).abs() < tol && (found[1] - c).abs() < tol, "{method}: {found:?}");
    }
    // 1594 ± 2 nm on the decreasing grid (λ = 1595 nm − 0.166 nm·p): pixels 0..=18 only; and
    // 1510.5 ± 2 nm: 496..=511.
    let s = vec![0.0; 512];
    let sp = Spectrum::new(&s, down.grid);
    let span = Window::centred(1594.0, 2.0).span(&sp).unwrap();
    assert_eq!((span.first, span.last), (0, 18));
    let span = Window::centred(1510.5, 2.0).span(&sp).unwrap();
    assert_eq!((span.first, span.last), (496, 511));
    assert!(Window::centred(1509.0, 0.2).span(&sp).is_none(), "off the end");
    assert!(Window::new(1550.0, 1550.1).span(&sp).is_none(), "under three pixels");
}

/// A polynomial grid's local spacing is the derivative of its wavelength, and its inverse
/// returns the pixel.
#[test]
fn polynomial_grid_step_and_inverse() {
    let g = Grid::polynomial([1510.0f64, 0.16, 1.2e-5, -2.0e-9, 3.0e-13, -1.0e-16]);
    for p in [0.0f64, 0.5, 100.25, 300.0, 511.0] {
        let h = 1e-4;
        let numeric = (g.wavelength(p + h) - g.wavelength(p - h)) / (2.0 * h);
        assert!((g.step_at(p) - numeric).abs() < 1e-9, "{p}: {} vs {numeric}", g.step_at(p));
        assert!((g.pixel(g.wavelength(p)) - p).abs() < 1e-9, "{p}");
    }
    let g32 = Grid::polynomial([1510.0f32, 0.16, 1.2e-5, -2.0e-9, 0.0, 0.0]);
    assert!((g32.pixel(g32.wavelength(300.25)) - 300.25).abs() < 2e-3);
}

/// A device sets a window's pixels up once (`Window::span_of` on the grid) and detects on them
/// per frame (`DetectorConfig::detect_span`): the same peak as `detect` bit for bit, on the
/// whole frame and on a part holding the window's pixels, for every method, on a uniform and a
/// polynomial grid, in f32 as the device runs it; a span under three pixels or outside the
/// spectrum gives no peak.
#[test]
fn a_span_found_at_set_up_detects_as_the_window_does() {
    let poly = Case { grid: Grid::polynomial([1510.0, 0.16, 1.2e-5, -2.0e-9, 0.0, 0.0]), name: "polynomial", ..COARSE };
    let mut rng = Rng::new(23);
    for case in [FINE, COARSE, poly] {
        let grid32 = match case.grid {
            Grid::Uniform { start_nm, step_nm } => Grid::uniform(start_nm as f32, step_nm as f32),
            Grid::Polynomial { coefficients } => Grid::polynomial(coefficients.map(|c| c as f32)),
        };
        let w = Window::centred(case.grid.wavelength(case.nominal_px as f64) as f32, case.half_window_nm as f32);
        let span = w.span_of(&grid32, 0, case.pixels).unwrap();
        for method in Method::ALL {
            let config = DetectorConfig { method, ..DetectorConfig::default() };
            for k in 0..6 {
                let centre = case.grid.wavelength(case.nominal_px as f64 + k as f64 / 6.0);
                let s: Vec<f32> =
                    spectrum(&case, Shape::Gaussian, centre, Some(25.0), &mut rng).iter().map(|&v| v as f32).collect();
                let whole = Spectrum::new(&s, grid32);
                let want = config.detect(&whole, &w);
                let bits = |p: &Peak<f32>| (p.wavelength_nm.to_bits(), p.fwhm_nm.to_bits(), p.snr.to_bits(), p.flags);
                assert_eq!(bits(&config.detect_span(&whole, span, |r, px| method.estimate(r, px))), bits(&want));
                let part = Spectrum::part(&s[span.first..=span.last], grid32, span.first);
                assert_eq!(bits(&config.detect_span(&part, span, |r, px| method.estimate(r, px))), bits(&want));
                assert_eq!(bits(&config.detect(&part, &w)), bits(&want), "{} {method:?}", case.name);
            }
            let none =
                |sp: Span| config.detect_span(&Spectrum::new(&[1.0f32; 8], grid32), sp, |r, px| method.estimate(r, px));
            assert!(none(Span { first: 2, last: 3 }).wavelength_nm.is_nan());
            assert!(none(Span { first: 6, last: 12 }).wavelength_nm.is_nan());
            assert!(none(Span { first: 2, last: 4 }).wavelength_nm.is_nan(), "a flat spectrum has no peak");
        }
    }
}
