//! Host throughput of the peak detector (criterion): 512-pixel spectra with 3 gratings, every
//! method, f64 and f32 (the host target: ≥ 10⁵ spectra per second on one core for the
//! default method).
//!
//! `cargo bench -p fbg-shared --bench spectrum` (`cargo xtask bench` runs it and reads
//! `target/criterion/spectrum_<f64|f32>/<method>/new/estimates.json`). One iteration detects
//! the three peaks of each of [`BATCH`] spectra with one reused `PeakDetector` (three windows of
//! ±4 nm). The spectra: a 512-pixel grid over 1510–1595 nm, three sinc² peaks (a uniform
//! grating's main lobe and side lobes) of 0.3 nm FWHM near 1535, 1545 and 1555 nm at sub-pixel
//! positions that differ from spectrum to spectrum, on a floor, with white noise at 30 dB
//! (height/σ, the detector's convention); the counts' conversion to floating point is outside
//! the clock.

#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fbg_shared::spectrum::{DetectorConfig, Grid, Method, PeakDetector, Spectrum, Window};
use fbg_shared::Real;
use fbg_testkit::Rng;

/// Spectra per iteration.
const BATCH: usize = 64;
/// Pixels per spectrum.
const PIXELS: usize = 512;
/// The gratings' nominal wavelengths \[nm\].
const NOMINAL: [f64; 3] = [1535.0, 1545.0, 1555.0];
/// FWHM of sinc²(v) = (sin πv/πv)² in v.
const SINC2_FWHM: f64 = 0.885_892_941_378_9;

fn grid() -> Grid<f64> {
    Grid::uniform(1510.0, 85.0 / (PIXELS - 1) as f64)
}

/// [`BATCH`] spectra: 1000 + 40 000·Σ sinc² + N(0, 40) counts (30 dB).
fn spectra() -> Vec<Vec<f64>> {
    let g = grid();
    let mut rng = Rng::new(31);
    (0..BATCH)
        .map(|k| {
            let centres: Vec<f64> =
                NOMINAL.iter().map(|&n| n + 0.5 * (k as f64 / BATCH as f64 - 0.5) + 0.01 * k as f64).collect();
            (0..PIXELS)
                .map(|i| {
                    let l = g.wavelength(i as f64);
                    let peaks: f64 = centres
                        .iter()
                        .map(|c| {
                            let v = std::f64::consts::PI * (l - c) * SINC2_FWHM / 0.3;
                            if v.abs() < 1e-12 {
                                1.0
                            } else {
                                (v.sin() / v).powi(2)
                            }
                        })
                        .sum();
                    1000.0 + 40_000.0 * peaks + 40.0 * rng.normal()
                })
                .collect()
        })
        .collect()
}

fn bench_precision<R: Real>(c: &mut Criterion, name: &str, methods: &[Method]) {
    let g64 = grid();
    let g = match g64 {
        Grid::Uniform { start_nm, step_nm } => Grid::uniform(R::from_f64(start_nm), R::from_f64(step_nm)),
        Grid::Polynomial { .. } => unreachable!(),
    };
    let data: Vec<Vec<R>> = spectra().iter().map(|s| s.iter().map(|&v| R::from_f64(v)).collect()).collect();
    let windows: Vec<Window<R>> = NOMINAL.iter().map(|&n| Window::centred(R::from_f64(n), R::from_f64(4.0))).collect();
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(BATCH as u64));
    for &method in methods {
        let cfg = DetectorConfig { method, full_scale: R::from_f64(65_535.0), ..DetectorConfig::default() };
        let det = PeakDetector::<R, 3>::new(cfg, &windows).unwrap();
        // Every spectrum's three peaks are found (the bench measures work actually done).
        for s in &data {
            for p in det.detect(&Spectrum::new(s, g)).into_iter().flatten() {
                assert!(p.wavelength_nm.is_finite() && p.flags.is_ok(), "{method}: {:?}", p.flags);
            }
        }
        group.bench_with_input(BenchmarkId::from_parameter(method.name()), &data, |b, data| {
            b.iter(|| {
                let mut acc = R::ZERO;
                for s in data {
                    for p in det.detect(black_box(&Spectrum::new(s, g))).into_iter().flatten() {
                        acc += p.wavelength_nm;
                    }
                }
                acc
            })
        });
    }
    group.finish();
}

fn spectrum(c: &mut Criterion) {
    bench_precision::<f64>(c, "spectrum_f64", &Method::ALL);
    bench_precision::<f32>(c, "spectrum_f32", &[Method::default()]);
}

criterion_group!(benches, spectrum);
criterion_main!(benches);
