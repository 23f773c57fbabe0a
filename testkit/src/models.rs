//! Random, valid models for the codec and inference tests: any feature set, any number of
//! centres up to the capacity, the shortest or the longest provenance, with no, some or every
//! memory slot in use. Each is a deterministic function of its seed.

use fbg_shared::layout::{N_MEMORY, N_OUTPUTS, N_POLY, N_STAGE1, VAR_RANK};
use fbg_shared::{blob, Centre, Error, FeatureSet, Hyper, MemorySpec, ModelParams, Provenance};
use heapless::{String, Vec};

use crate::Rng;

/// The shortest provenance (every field at its one-byte encoding).
pub fn short_provenance() -> Provenance {
    Provenance::default()
}

/// Provenance with every field at its longest encoding.
pub fn long_provenance() -> Provenance {
    Provenance {
        seed: u64::MAX,
        scenario: String::try_from("abcdefghijklmnopqrstuvwx").unwrap_or_default(),
        trainer_version: String::try_from("0123456789abcdef").unwrap_or_default(),
        date_yyyymmdd: u32::MAX,
        n_cal: u32::MAX,
    }
}

/// Sensible hyper-parameters for a generated model.
pub fn hyper(feature_set: FeatureSet) -> Hyper<f32> {
    Hyper {
        feature_set,
        sigma_mult: 1.5,
        sigma: 1.0,
        alpha: 0.01,
        dead_band_pm: 2.0,
        weak_support: 0.05,
        envelope_margin: 0.1,
        flagged_band_factor: 2.0,
    }
}

/// A valid, well-conditioned random model with `n` centres (at most `K`: the rest are not
/// made). Inputs it is meant for: Δλ in ±50 pm, T_amb in 0..40 °C, t in 0..1000 s; the
/// envelope is ±60 pm, −5..45 °C.
pub fn model<const K: usize>(n: usize, seed: u64, fs: FeatureSet, prov: Provenance) -> ModelParams<f32, K> {
    let mut r = Rng(seed);
    let mut stage1 = [[0.0f32; N_STAGE1]; N_OUTPUTS];
    for row in stage1.iter_mut() {
        for (k, v) in row.iter_mut().enumerate() {
            *v = if k == N_STAGE1 - 1 { r.f32(-5.0, 5.0) } else { r.f32(-0.5, 0.5) };
        }
    }
    let mut guess_mean = [0.0f32; N_OUTPUTS];
    let mut guess_std = [0.0f32; N_OUTPUTS];
    for (m, s) in guess_mean.iter_mut().zip(guess_std.iter_mut()) {
        *m = r.f32(-5.0, 5.0);
        *s = r.f32(1.0, 20.0);
    }
    let mut poly = [[0.0f32; N_POLY]; N_OUTPUTS];
    for row in poly.iter_mut() {
        for v in row.iter_mut() {
            *v = r.f32(-2.0, 2.0);
        }
    }
    let z_mean = [0.0, 0.0, 0.0, 20.0, 500.0, 0.0, 0.0, 0.0];
    let z_std = [30.0, 30.0, 30.0, 10.0, 300.0, 1.0, 1.0, 1.0];
    let active = fs.active();
    let mut centres: Vec<Centre<f32>, K> = Vec::new();
    for _ in 0..n {
        let mut c = Centre::<f32>::default();
        for (m, &on) in c.mu.iter_mut().zip(active.iter()) {
            *m = if on { r.f32(-1.5, 1.5) } else { 0.0 };
        }
        for w in c.w.iter_mut() {
            *w = r.f32(-1.0, 1.0);
        }
        for v in c.v.iter_mut() {
            *v = r.f32(-1.0, 1.0);
        }
        if centres.push(c).is_err() {
            break;
        }
    }
    let mut var_inv_g = [0.0f32; VAR_RANK];
    let mut g = 1.0f64;
    for v in var_inv_g.iter_mut().take(n.min(VAR_RANK)) {
        *v = g as f32;
        g *= r.uniform(0.3, 0.9);
    }
    let var_inv_g_tail = if n > VAR_RANK { (g * 0.5) as f32 } else { 0.0 };
    let mut resid_var = [0.0f32; N_OUTPUTS];
    for v in resid_var.iter_mut() {
        *v = r.f32(0.01, 1.0);
    }
    ModelParams {
        hyper: hyper(fs),
        stage1,
        guess_mean,
        guess_std,
        poly,
        memory: MemorySpec::off(),
        gamma: [[0.0; N_MEMORY]; N_OUTPUTS],
        z_mean,
        z_std,
        centres,
        var_inv_g,
        var_inv_g_tail,
        resid_var,
        resid_var_growth: [0.0; 3],
        t_cal_end_s: 0.0,
        band_k: [fbg_shared::layout::Z95 as f32; 3],
        envelope_lo: [-60.0, -60.0, -60.0, -5.0],
        envelope_hi: [60.0, 60.0, 60.0, 45.0],
        fitted: [true; 3],
        provenance: prov,
    }
}

/// The same random model, with the feature set and the memory picked by `seed` too (no
/// memory, [`some_memory_spec`] or [`full_memory_spec`]; the blob length does not depend on it).
pub fn any_model<const K: usize>(n: usize, seed: u64, long: bool) -> ModelParams<f32, K> {
    let fs = FeatureSet::ALL[(seed % 3) as usize];
    let prov = if long { long_provenance() } else { short_provenance() };
    match (seed / 3) % 3 {
        0 => model(n, seed, fs, prov),
        1 => memory_model(n, seed, fs, prov, some_memory_spec()),
        _ => memory_model(n, seed, fs, prov, full_memory_spec()),
    }
}

/// Every memory slot used, over the time scales of long 1-s test streams: grating τ from 1 min
/// to 1 week, ambient τ from 10 min to 1 day,
/// plays of 2, 10 and 50 pm, and the drift observer (thermometer lag 10 min, smoothing 1 h,
/// T_g ≈ a mix of the gratings plus half the ambient).
pub fn full_memory_spec() -> MemorySpec<f32> {
    MemorySpec {
        grating_tau_s: [60.0, 600.0, 3600.0, 21_600.0, 86_400.0, 604_800.0],
        ambient_tau_s: [600.0, 3600.0, 21_600.0, 86_400.0],
        play_half_width_pm: [2.0, 10.0, 50.0],
        observer_lag_s: 600.0,
        observer_smooth_s: 3600.0,
        observer_row: [0.1, -0.05, 0.02, 0.5, -3.0],
    }
}

/// Some slots used, some not (τ in seconds of the 1-s test streams): two grating τ, one
/// ambient τ, one play and the observer.
pub fn some_memory_spec() -> MemorySpec<f32> {
    let mut s = MemorySpec::off();
    s.grating_tau_s[1] = 20.0;
    s.grating_tau_s[4] = 300.0;
    s.ambient_tau_s[2] = 50.0;
    s.play_half_width_pm[0] = 4.0;
    s.observer_lag_s = 30.0;
    s.observer_smooth_s = 120.0;
    s.observer_row = [0.05, -0.02, 0.03, 0.8, 4.0];
    s
}

/// [`model`] with memory terms: `spec` and a random Γ on its used terms (0 elsewhere), of a
/// size that moves the outputs by O(1) for terms of O(10) pm or °C.
pub fn memory_model<const K: usize>(
    n: usize,
    seed: u64,
    fs: FeatureSet,
    prov: Provenance,
    spec: MemorySpec<f32>,
) -> ModelParams<f32, K> {
    let mut p = model(n, seed, fs, prov);
    let mut r = Rng(seed ^ 0x5EE_D0F6_A33A);
    p.memory = spec;
    for row in p.gamma.iter_mut() {
        for (k, g) in row.iter_mut().enumerate() {
            *g = if spec.term_active(k) { r.f32(-0.2, 0.2) } else { 0.0 };
        }
    }
    p
}

/// Encode into a fresh buffer of exactly `max_len(K)` bytes (so a too-small bound fails).
pub fn encode_vec<const K: usize>(p: &ModelParams<f32, K>) -> Result<std::vec::Vec<u8>, Error> {
    let mut buf = vec![0u8; blob::max_len(K)];
    let n = blob::encode(p, &mut buf)?;
    buf.truncate(n);
    Ok(buf)
}
