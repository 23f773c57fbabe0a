//! The simulated spectra: the grating's reflection spectrum against the
//! closed form of coupled-mode theory (physics, nothing tuned), the designs of a given FWHM,
//! the source, the detector's noise and counts at the stated SNR convention, the frames and
//! the spectra CSV.

use fbg_trainer::sim::spectrum::csv::write_spectra_csv;
use fbg_trainer::sim::spectrum::frames::{row_rng, wavelengths_at};
use fbg_trainer::sim::spectrum::grating::N_EFF;
use fbg_trainer::sim::spectrum::{
    Apodisation, DetectorModel, FrameSimulator, GratingDesign, PixelGrid, SourceEnvelope, SpectrumConfig,
};
use fbg_trainer::sim::{self, scenario::Preset};

const BRAGG: f64 = 1550.0;

/// A uniform grating of 5 mm, Δn = 1.5·10⁻⁴ (κL ≈ 1.52, R ≈ 0.82): no design solver involved.
fn uniform(sections: usize) -> GratingDesign {
    GratingDesign { apodisation: Apodisation::Uniform, length_mm: 5.0, delta_n: 1.5e-4, n_eff: N_EFF, sections }
}

#[test]
fn transfer_matrix_of_a_uniform_grating_is_the_closed_form() {
    for sections in [1, 7, 64] {
        let d = uniform(sections);
        for k in -400..=400 {
            let l = BRAGG + k as f64 * 0.005;
            let (tmm, closed) = (d.reflectivity(BRAGG, l), d.uniform_reflectivity(BRAGG, l));
            assert!((tmm - closed).abs() < 1e-9, "{sections} sections at {l} nm: {tmm} vs {closed}");
            assert!((0.0..=1.0).contains(&tmm));
        }
    }
}

#[test]
fn peak_reflectivity_is_tanh_squared_kappa_l() {
    let d = uniform(1);
    let kl = std::f64::consts::PI * d.delta_n / (BRAGG * 1e-9) * d.length_mm * 1e-3;
    let want = kl.tanh().powi(2);
    assert!((d.reflectivity(BRAGG, BRAGG) - want).abs() < 1e-12);
    assert!((d.peak_reflectivity(BRAGG) - want).abs() < 1e-12);
    // Apodised (pure): tanh²(∫κ dz) too, ∫κ dz over the sections' midpoints.
    for apod in [Apodisation::Gaussian, Apodisation::RaisedCosine] {
        let a = GratingDesign { apodisation: apod, sections: 100, ..d };
        let mean: f64 = (0..100).map(|i| apod.at((i as f64 + 0.5) / 100.0)).sum::<f64>() / 100.0;
        let want = (kl * mean).tanh().powi(2);
        assert!((a.reflectivity(BRAGG, BRAGG) - want).abs() < 1e-9, "{apod:?}");
        // The peak is the maximum: nothing higher within ±1 nm.
        let max = (-1000..=1000).map(|k| a.reflectivity(BRAGG, BRAGG + k as f64 * 1e-3)).fold(0.0, f64::max);
        assert!(max <= want + 1e-12, "{apod:?}: {max} > {want}");
    }
}

/// The wavelength where σ̂ = s (κ at that wavelength; fixed point, κ depends on λ weakly).
fn wavelength_of_detuning(d: &GratingDesign, s_sign: f64) -> f64 {
    let mut l = BRAGG;
    for _ in 0..20 {
        let kappa = d.kappa_per_m(l, 1.0);
        let l_m = d.length_mm * 1e-3;
        let s = s_sign * (kappa * kappa + (std::f64::consts::PI / l_m).powi(2)).sqrt();
        l = 1e9 / (1.0 / (BRAGG * 1e-9) + s / (std::f64::consts::TAU * N_EFF));
    }
    l
}

#[test]
fn first_zeros_are_where_coupled_mode_theory_puts_them() {
    let d = uniform(1);
    let (hi, lo) = (wavelength_of_detuning(&d, -1.0), wavelength_of_detuning(&d, 1.0));
    assert!(lo < BRAGG && hi > BRAGG);
    for z in [lo, hi] {
        assert!(d.reflectivity(BRAGG, z) < 1e-12, "R({z}) = {}", d.reflectivity(BRAGG, z));
    }
    // Their spacing: λ²·√(κ² + (π/L)²)/(π·n_eff) to first order.
    let kappa = d.kappa_per_m(BRAGG, 1.0);
    let approx = (BRAGG * 1e-9).powi(2) * (kappa * kappa + (std::f64::consts::PI / 5e-3).powi(2)).sqrt()
        / (std::f64::consts::PI * N_EFF)
        * 1e9;
    assert!(((hi - lo) - approx).abs() < 1e-3 * approx, "{} vs {approx}", hi - lo);
    // The main lobe falls monotonically to them; a side lobe rises beyond (present, below the
    // peak).
    let peak = d.reflectivity(BRAGG, BRAGG);
    let mut prev = peak;
    for k in 1..100 {
        let r = d.reflectivity(BRAGG, BRAGG + (hi - BRAGG) * k as f64 / 100.0);
        assert!(r < prev, "not monotonic at step {k}");
        prev = r;
    }
    let lobe = (1..200).map(|k| d.reflectivity(BRAGG, hi + k as f64 * 2e-3)).fold(0.0, f64::max);
    assert!(lobe > 0.02 * peak && lobe < 0.5 * peak, "side lobe {lobe} of a peak of {peak}");
}

#[test]
fn designs_have_the_asked_fwhm_and_apodisation_kills_the_side_lobes() {
    for apod in [Apodisation::Uniform, Apodisation::Gaussian, Apodisation::RaisedCosine] {
        for (fwhm, r) in [(0.3, 0.5), (0.2, 0.9)] {
            let d = GratingDesign::for_fwhm(apod, fwhm, r, 1535.0).unwrap();
            let w = d.fwhm_nm(1535.0);
            eprintln!("{apod:?} FWHM {fwhm} R {r}: L = {:.3} mm, Δn = {:.3e}, FWHM {w:.5} nm", d.length_mm, d.delta_n);
            assert!((w - fwhm).abs() < 1e-3, "{apod:?}: FWHM {w}");
            assert!((d.peak_reflectivity(1535.0) - r).abs() < 1e-9);
            // Beyond 3 FWHM: side lobes of a uniform grating, almost nothing of an apodised one.
            let far =
                (0..400).map(|k| d.reflectivity(1535.0, 1535.0 + 3.0 * fwhm + k as f64 * 2e-3)).fold(0.0, f64::max);
            if apod == Apodisation::Uniform {
                assert!(far > 1e-3 * r, "{apod:?}: {far}");
            } else {
                assert!(far < 1e-3 * r, "{apod:?}: {far}");
            }
        }
    }
    assert!(GratingDesign::for_fwhm(Apodisation::Uniform, 0.0, 0.5, 1550.0).is_err());
    assert!(GratingDesign::for_fwhm(Apodisation::Uniform, 0.3, 1.0, 1550.0).is_err());
}

#[test]
fn source_envelope_peaks_at_its_centre_with_its_fwhm() {
    let s = SourceEnvelope { tilt_per_nm: 0.0, ..SourceEnvelope::default() };
    assert!((s.power(1550.0) - 1.0).abs() < 1e-15);
    assert!((s.power(1575.0) - 0.5).abs() < 1e-12 && (s.power(1525.0) - 0.5).abs() < 1e-12);
    let t = SourceEnvelope::default();
    assert!(t.power(1560.0) > t.power(1540.0), "tilted towards the long wavelengths");
}

#[test]
fn grids_span_1510_to_1595_nm() {
    for (g, n, step) in [(PixelGrid::Spectrometer, 512, 0.166), (PixelGrid::Swept, 10_626, 0.008)] {
        let w = g.wavelengths();
        assert_eq!(w.len(), n);
        assert!((w[0] - 1510.0).abs() < 1e-9 && (w[n - 1] - 1595.0).abs() < 1e-9, "{g:?}");
        assert!(w.windows(2).all(|p| p[1] > p[0]));
        let mean_step = 85.0 / (n - 1) as f64;
        assert!((mean_step - step).abs() < 1e-3, "{g:?}");
    }
    // The spectrometer's polynomial is not linear: the step narrows along the array.
    let w = PixelGrid::Spectrometer.wavelengths();
    assert!(w[1] - w[0] > w[511] - w[510] + 0.01);
}

/// A frame with one grating at 1550 nm (the source's centre, so the reference height).
fn one_grating(grid: PixelGrid, snr_db: f64) -> (FrameSimulator, SpectrumConfig) {
    let cfg = SpectrumConfig {
        grid,
        detector: DetectorModel { snr_db, ..DetectorModel::default() },
        source: SourceEnvelope { tilt_per_nm: 0.0, ..SourceEnvelope::default() },
        ..SpectrumConfig::default()
    };
    (FrameSimulator::new(&cfg, &[BRAGG]).unwrap(), cfg)
}

#[test]
fn detector_noise_and_height_follow_the_snr_convention() {
    // Tuned nowhere: σ = H/10^(SNR/10) by construction; the test measures both on frames.
    for snr in [20.0, 30.0, 40.0] {
        let (f, cfg) = one_grating(PixelGrid::Swept, snr);
        let mut rng = row_rng(5, 0);
        let (mut scratch, mut counts) = (Vec::new(), Vec::new());
        let mut dark = Vec::new();
        let mut top = Vec::new();
        for _ in 0..20 {
            f.frame(0, &[BRAGG], &mut rng, &mut scratch, &mut counts);
            let w = f.wavelengths_nm();
            // Far from the grating: dark + noise.
            dark.extend(counts.iter().zip(w).filter(|(_, &l)| l < 1540.0).map(|(&c, _)| f64::from(c)));
            let i = w.iter().position(|&l| (l - BRAGG).abs() < 0.004).unwrap();
            top.push(f64::from(counts[i]));
        }
        let mean = dark.iter().sum::<f64>() / dark.len() as f64;
        let sd = (dark.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / dark.len() as f64).sqrt();
        let sigma = cfg.detector.sigma_counts();
        // The rounding adds 1/12 count².
        let want = (sigma * sigma + 1.0 / 12.0).sqrt();
        assert!((sd / want - 1.0).abs() < 0.03, "{snr} dB: σ {sd} vs {want}");
        assert!((mean - cfg.detector.dark_counts).abs() < 0.05 * sigma + 0.05);
        let height = top.iter().sum::<f64>() / top.len() as f64 - mean;
        assert!((height / cfg.detector.peak_counts - 1.0).abs() < 0.01 + 3.0 * sigma / 40_000.0, "{snr} dB: {height}");
        assert!(
            (10.0 * (height / sd).log10() - snr).abs() < 0.2,
            "{snr} dB: measured {}",
            10.0 * (height / sd).log10()
        );
    }
}

#[test]
fn counts_clamp_at_full_scale_and_zero() {
    let cfg = SpectrumConfig {
        detector: DetectorModel { peak_counts: 100_000.0, dark_counts: 0.0, snr_db: 20.0 },
        ..SpectrumConfig::default()
    };
    let f = FrameSimulator::new(&cfg, &[1550.0]).unwrap();
    let (mut scratch, mut counts) = (Vec::new(), Vec::new());
    f.frame(0, &[1550.0], &mut row_rng(1, 0), &mut scratch, &mut counts);
    assert_eq!(*counts.iter().max().unwrap(), u16::MAX);
    assert_eq!(*counts.iter().min().unwrap(), 0);
}

#[test]
fn frames_of_the_paper_preset_put_every_grating_on_one_channel_and_are_reproducible() {
    let mut sc = Preset::Paper.config();
    sc.clock.days = 0.05;
    let s = sim::simulate(&sc, 7);
    let cfg = SpectrumConfig::default();
    let nominal: Vec<f64> = s.data.meta.zero.iter().map(|z| z.nm).collect();
    let f = FrameSimulator::new(&cfg, &nominal).unwrap();
    assert_eq!(f.channels(), 1);
    assert_eq!(f.gratings_of(0), &[0, 1, 2]);
    // The windows: ±4 nm (10 nm apart: 4.5 nm capped at 4).
    let w = f.window(1);
    assert!((w.lo_nm - 1541.0).abs() < 1e-12 && (w.hi_nm - 1549.0).abs() < 1e-12);
    // Eight gratings 5 nm apart (array-8): still one fibre, windows ±2.25 nm.
    let a8 = Preset::Array8.config();
    let f8 = FrameSimulator::new(&cfg, &a8.gratings.nominal_nm).unwrap();
    assert_eq!(f8.channels(), 1);
    assert!((f8.window(3).hi_nm - f8.window(3).lo_nm - 4.5).abs() < 1e-9);
    // Two gratings 1 nm apart go on two channels.
    assert_eq!(FrameSimulator::new(&cfg, &[1550.0, 1551.0]).unwrap().channels(), 2);

    let mut a = Vec::new();
    write_spectra_csv(&mut a, &s.data, &f, 3).unwrap();
    let mut b = Vec::new();
    write_spectra_csv(&mut b, &s.data, &f, 3).unwrap();
    assert_eq!(a, b, "same seed, same bytes");
    let mut c = Vec::new();
    write_spectra_csv(&mut c, &s.data, &f, 4).unwrap();
    assert_ne!(a, c, "another seed, other noise");
    let text = String::from_utf8(a).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 2 + 512);
    assert_eq!(&header[..3], &["t_s", "channel", "1510.000"]);
    assert_eq!(header[513], "1595.000");
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), s.data.len());
    let first: Vec<&str> = rows[0].split(',').collect();
    assert_eq!(first.len(), 514);
    assert_eq!(first[1], "1");
    // The row's brightest pixel is by one of the gratings at its wavelength of the sample.
    let counts: Vec<u16> = first[2..].iter().map(|v| v.parse().unwrap()).collect();
    let imax = (0..512).max_by_key(|&i| counts[i]).unwrap();
    let wl = wavelengths_at(&s.data, 0);
    let lmax = f.wavelengths_nm()[imax];
    assert!(wl.iter().any(|&l| (l - lmax).abs() < 0.17), "max at {lmax} nm, gratings at {wl:?}");
}

#[test]
fn bad_settings_are_refused_naming_the_key() {
    let bad_snr = SpectrumConfig {
        detector: DetectorModel { snr_db: f64::NAN, ..DetectorModel::default() },
        ..SpectrumConfig::default()
    };
    let e = FrameSimulator::new(&bad_snr, &[1550.0]).unwrap_err().to_string();
    assert!(e.contains("snr_db"), "{e}");
    let bad_r = SpectrumConfig { peak_reflectivity: 1.5, ..SpectrumConfig::default() };
    let e = FrameSimulator::new(&bad_r, &[1550.0]).unwrap_err().to_string();
    assert!(e.contains("peak reflectivity"), "{e}");
    let e = FrameSimulator::new(&SpectrumConfig::default(), &[f64::NAN]).unwrap_err().to_string();
    assert!(e.contains("nominal_nm"), "{e}");
}
