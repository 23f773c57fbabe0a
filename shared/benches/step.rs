//! Host inference throughput of `Compensator::step` (criterion), f32 and f64, K = 16/32/64.
//!
//! `cargo bench -p fbg-shared --bench step` (`cargo xtask bench` runs it and reads
//! `target/criterion/step/<f32|f64>/<K>/new/estimates.json`). One iteration steps a stream of
//! [`BATCH`] samples through a compensator loaded with a hysteresis-aware model of K centres of
//! the test kit's synthetic installation (`fbg_testkit::installation`, the firmware bench's
//! models), on that installation's samples (the cost of `step` does not depend on the
//! coefficients' values, only on K and on the exponentials being evaluated, which they are:
//! the samples sit among the centres).
//!
//! The group `step_memory/<f32|f64>` measures the same model at K = 32 with every memory slot
//! on (6 grating τ, 4 ambient τ, 3 plays, the drift observer: 32 terms and Γ): id `32` on the
//! regular 60-s clock (smoothing factors cached), id `32-irregular-dt` with a different Δt on
//! every sample (12 smoothing factors recomputed per step), the memory's worst case.

// A bench crate: the panicking shorthand is fine here, and criterion's macros generate public
// functions without docs.
#![allow(missing_docs, clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fbg_shared::{Compensator, Real, Sample};
use fbg_testkit::installation::{self, MAX_K};

/// Samples per iteration.
const BATCH: usize = 1024;
/// Centre capacity of the benchmarked compensators.
const CAP: usize = MAX_K;

/// The installation's samples on its 60-s clock, or with a different Δt (60 + 0..6 s) on
/// every sample when `irregular`.
fn samples<F: Real>(irregular: bool) -> Vec<Sample<F>> {
    installation::samples(BATCH, 42)
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let mut s = s.cast::<F>();
            if irregular {
                s.t_s += F::from_f64((i % 7) as f64);
            }
            s
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
    let model = installation::synthetic_params(k, 100 + k as u64)
        .map(|p| if memory { p } else { installation::without_memory(p) })
        .and_then(|p| Compensator::<F, CAP>::new(&p));
    let Ok(comp) = model else {
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

/// `step_batch` against `step` at K = 32 on the same stream (group `step_batch/<f32|f64>`,
/// ids `step` and `batch`): the batch path's gain on the host, whose compiler runs its lanes
/// as vectors (the plain x86-64 target: SSE2). Alone: `cargo bench -p fbg-shared --bench step
/// -- step_batch`.
fn bench_batch<F: Real>(c: &mut Criterion, name: &str) {
    let mut g = c.benchmark_group(format!("step_batch/{name}"));
    g.throughput(Throughput::Elements(BATCH as u64));
    let xs = samples::<F>(false);
    bench_stream(&mut g, BenchmarkId::from_parameter("step"), load::<F>(32, false), &xs);
    let mut comp = load::<F>(32, false);
    let mut out = vec![fbg_shared::Estimate::<F>::default(); BATCH];
    g.bench_with_input(BenchmarkId::from_parameter("batch"), &xs, |b, xs| {
        b.iter(|| {
            comp.step_batch(black_box(xs), &mut out);
            black_box(out[1].values[1])
        })
    });
    g.finish();
}

fn benches(c: &mut Criterion) {
    bench_precision::<f32>(c, "f32");
    bench_precision::<f64>(c, "f64");
    bench_memory::<f32>(c, "f32");
    bench_memory::<f64>(c, "f64");
    bench_batch::<f64>(c, "f64");
    bench_batch::<f32>(c, "f32");
}

criterion_group!(step, benches);
criterion_main!(step);
