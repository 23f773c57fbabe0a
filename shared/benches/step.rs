//! Host inference throughput of `Compensator::step` (criterion), f32 and f64, K = 16/32/64.
//!
//! `cargo bench -p fbg-shared --bench step` (`cargo xtask bench` runs it and reads
//! `target/criterion/step/<f32|f64>/<K>/new/estimates.json`). One iteration steps a stream of
//! [`BATCH`] samples through a compensator loaded with a synthetic hysteresis-aware model of K
//! centres (the cost of `step` does not depend on the coefficients' values, only on K and on
//! the exponentials being evaluated, which they are: the samples sit among the centres).
//!
//! The group `step_memory/<f32|f64>` measures the same model at K = 32 with every memory slot
//! on (6 grating τ, 4 ambient τ, 3 plays, the drift observer: 32 terms and Γ): id `32` on the
//! regular 60-s clock (smoothing factors cached), id `32-irregular-dt` with a different Δt on
//! every sample (12 smoothing factors recomputed per step), the memory's worst case.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fbg_shared::layout::{FeatureSet, N_MEMORY, N_OUTPUTS, VAR_RANK, Z_DIMS};
use fbg_shared::{Centre, Compensator, Hyper, MemorySpec, ModelParams, Real, Sample};

/// Samples per iteration.
const BATCH: usize = 1024;
/// Centre capacity of the benchmarked compensators.
const CAP: usize = 64;

/// xorshift64* in [0, 1) and a Box–Muller normal: a self-contained, seeded generator.
struct Rng(u64);
impl Rng {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn normal(&mut self) -> f64 {
        let u = self.uniform().max(1e-300);
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
    }
}

/// Raw inputs [Δλ1..3 pm, T_amb °C] scale and offset of the synthetic installation.
const MEAN: [f64; 4] = [0.0, 0.0, 0.0, 20.0];
const STD: [f64; 4] = [150.0, 40.0, 60.0, 3.0];

/// Every memory slot on, with Γ non-zero on every term (its values do not change the cost).
fn full_memory() -> (MemorySpec<f64>, [[f64; N_MEMORY]; N_OUTPUTS]) {
    let spec = MemorySpec {
        grating_tau_s: [60.0, 600.0, 3600.0, 21_600.0, 86_400.0, 604_800.0],
        ambient_tau_s: [600.0, 3600.0, 21_600.0, 86_400.0],
        play_half_width_pm: [5.0, 20.0, 80.0],
        observer_lag_s: 600.0,
        observer_smooth_s: 3600.0,
        observer_row: [0.01, 0.002, -0.003, 0.5, 0.0],
    };
    let gamma = std::array::from_fn(|o| std::array::from_fn(|k| 1e-3 * (1 + (k + o) % 5) as f64));
    (spec, gamma)
}

fn model(k: usize, memory: bool) -> ModelParams<f64, CAP> {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ k as u64);
    let fs = FeatureSet::HysteresisAware;
    let active = fs.active();
    let mut centres = heapless::Vec::new();
    for _ in 0..k {
        let mut c = Centre::<f64>::default();
        for (d, mu) in c.mu.iter_mut().enumerate() {
            if active[d] {
                *mu = if d >= 5 {
                    if rng.uniform() < 0.5 {
                        -1.0
                    } else {
                        1.0
                    }
                } else {
                    rng.normal()
                };
            }
        }
        c.w = std::array::from_fn(|_| rng.normal());
        c.v = std::array::from_fn(|_| rng.normal() / (k as f64).sqrt());
        let _ = centres.push(c);
    }
    let mut z_mean = [0.0; Z_DIMS];
    let mut z_std = [1.0; Z_DIMS];
    z_mean[..4].copy_from_slice(&MEAN);
    z_std[..4].copy_from_slice(&STD);
    ModelParams {
        hyper: Hyper {
            feature_set: fs,
            sigma_mult: 2.0,
            sigma: 1.5,
            alpha: 1e-2,
            dead_band_pm: 4.0,
            weak_support: 1e-4,
            envelope_margin: 0.1,
            flagged_band_factor: 2.0,
        },
        stage1: std::array::from_fn(|o| std::array::from_fn(|i| if i == o { 0.1 } else { 0.01 })),
        guess_mean: [0.0; N_OUTPUTS],
        guess_std: [1.0; N_OUTPUTS],
        poly: std::array::from_fn(|o| std::array::from_fn(|i| 0.1 * (i + o) as f64)),
        memory: if memory { full_memory().0 } else { MemorySpec::off() },
        gamma: if memory { full_memory().1 } else { [[0.0; N_MEMORY]; N_OUTPUTS] },
        z_mean,
        z_std,
        centres,
        var_inv_g: std::array::from_fn::<f64, VAR_RANK, _>(|i| 1.0 / (i + 1) as f64),
        var_inv_g_tail: 0.0,
        resid_var: [0.01, 4.0, 1.0],
        resid_var_growth: [1e-9; N_OUTPUTS],
        t_cal_end_s: 0.0,
        band_k: [1.96; N_OUTPUTS],
        envelope_lo: [-1000.0, -1000.0, -1000.0, -50.0],
        envelope_hi: [1000.0, 1000.0, 1000.0, 100.0],
        fitted: [true; N_OUTPUTS],
        provenance: Default::default(),
    }
}

/// A stream of samples among the centres: a random walk of the inputs, every 60 s, or with a
/// different Δt (60 ± up to 3 s) on every sample when `irregular`.
fn samples<F: Real>(irregular: bool) -> Vec<Sample<F>> {
    let mut rng = Rng(42);
    let mut x = [0.0f64; 4];
    (0..BATCH)
        .map(|i| {
            for v in x.iter_mut() {
                *v = 0.98 * *v + 0.2 * rng.normal();
            }
            Sample {
                dl_pm: std::array::from_fn(|d| F::from_f64(MEAN[d] + STD[d] * x[d])),
                t_amb_c: F::from_f64(MEAN[3] + STD[3] * x[3]),
                t_s: F::from_f64(60.0 * i as f64 + if irregular { (i % 7) as f64 } else { 0.0 }),
            }
        })
        .collect()
}

/// Step `xs` through `comp` once per iteration.
fn bench_stream<F: Real>(
    g: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: BenchmarkId,
    mut comp: Compensator<F, CAP>,
    xs: &[Sample<F>],
) {
    g.bench_with_input(id, xs, |b, xs| {
        b.iter(|| {
            let mut acc = F::ZERO;
            for s in xs {
                let e = comp.step(black_box(s));
                acc += e.values[1];
            }
            black_box(acc)
        })
    });
}

fn load<F: Real>(k: usize, memory: bool) -> Compensator<F, CAP> {
    let Ok(comp) = Compensator::<F, CAP>::new(&model(k, memory)) else {
        panic!("synthetic model with K = {k} (memory: {memory}) does not load");
    };
    assert_eq!(comp.has_memory(), memory);
    comp
}

fn bench_precision<F: Real>(c: &mut Criterion, name: &str) {
    let mut g = c.benchmark_group(format!("step/{name}"));
    g.throughput(Throughput::Elements(BATCH as u64));
    let xs = samples::<F>(false);
    for k in [16usize, 32, 64] {
        bench_stream(&mut g, BenchmarkId::from_parameter(k), load::<F>(k, false), &xs);
    }
    g.finish();
}

/// K = 32 with every memory slot on, on a regular and on an irregular clock.
fn bench_memory<F: Real>(c: &mut Criterion, name: &str) {
    let mut g = c.benchmark_group(format!("step_memory/{name}"));
    g.throughput(Throughput::Elements(BATCH as u64));
    for (id, irregular) in [("32", false), ("32-irregular-dt", true)] {
        bench_stream(&mut g, BenchmarkId::from_parameter(id), load::<F>(32, true), &samples::<F>(irregular));
    }
    g.finish();
}

fn benches(c: &mut Criterion) {
    bench_precision::<f32>(c, "f32");
    bench_precision::<f64>(c, "f64");
    bench_memory::<f32>(c, "f32");
    bench_memory::<f64>(c, "f64");
}

criterion_group!(step, benches);
criterion_main!(step);
