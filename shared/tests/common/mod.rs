//! Helpers of the compensator tests: streams of samples, models, bit patterns.

#![allow(dead_code)] // each test crate uses its own share

pub mod blob;

use fbg_shared::{Compensator, Estimate, FeatureSet, Flags, ModelParams, Sample};
use fbg_testkit::models::{memory_model, model, short_provenance, some_memory_spec};
use fbg_testkit::Rng;

pub const K: usize = 8;

pub fn sample(dl: [f32; 3], t_amb_c: f32, t_s: f32) -> Sample<f32> {
    Sample::new(dl, t_amb_c, t_s)
}

/// The first three shifts of a paper sample.
pub fn dl3<F: Copy>(s: &Sample<F>) -> [F; 3] {
    [s.dl_pm[0], s.dl_pm[1], s.dl_pm[2]]
}

/// A random walk inside the calibration range (±50 pm, 0..40 °C), t = 0, 1, 2, ... s.
pub fn stream(seed: u64, n: usize) -> Vec<Sample<f32>> {
    let mut r = Rng(seed);
    let mut dl = [0.0f64; 3];
    (0..n)
        .map(|k| {
            for d in dl.iter_mut() {
                *d = (*d + r.uniform(-6.0, 6.0)).clamp(-50.0, 50.0);
            }
            sample([dl[0] as f32, dl[1] as f32, dl[2] as f32], r.f32(0.0, 40.0), k as f32)
        })
        .collect()
}

/// Rising (or falling) by 10 pm per sample on every grating: latches end at ±1.
pub fn ramp(up: bool, n: usize) -> Vec<Sample<f32>> {
    let s = if up { 10.0 } else { -10.0 };
    (0..n).map(|k| sample([s * k as f32 - 20.0 * s.signum(); 3], 20.0, k as f32)).collect()
}

pub fn bits(e: &Estimate<f32>) -> ([u32; 4], [u32; 4], Flags) {
    (e.values.map(f32::to_bits), e.band95.map(f32::to_bits), e.flags)
}

pub fn run(c: &mut Compensator<f32, K>, ss: &[Sample<f32>]) {
    for s in ss {
        c.step(s);
    }
}

pub fn params(n: usize, seed: u64, fs: FeatureSet) -> ModelParams<f32, K> {
    model(n, seed, fs, short_provenance())
}

pub fn memory_params(n: usize, seed: u64, fs: FeatureSet) -> ModelParams<f32, K> {
    memory_model(n, seed, fs, short_provenance(), some_memory_spec())
}

pub fn to64(s: &Sample<f32>) -> Sample<f64> {
    s.cast::<f64>()
}

/// [`stream`] on an irregular clock: Δt from {1, 2, 5, 30} s, with a repeated time stamp and a
/// 1000-s gap now and then.
pub fn irregular(seed: u64, n: usize) -> Vec<Sample<f32>> {
    let mut r = Rng(seed ^ 0xC10C);
    let mut t = 0.0f32;
    let mut ss = stream(seed, n);
    for (k, s) in ss.iter_mut().enumerate() {
        t += match k % 97 {
            40 => 0.0,
            80 => 1000.0,
            _ => [1.0, 2.0, 5.0, 30.0][(r.next_u64() % 4) as usize],
        };
        s.t_s = t;
    }
    ss
}
