//! Random, valid models for the codec and inference tests: any dims (gratings, ambient,
//! measurands), any feature set, any number of centres up to the capacity, the shortest or the
//! longest provenance, with no, some or every memory slot in use. Each is a deterministic
//! function of its seed.

use fbg_shared::layout::{pad, Dims, Output, Quantity, MAX_GRATINGS, MAX_STAGE1, VAR_RANK};
use fbg_shared::{blob, Centre, Error, FeatureSet, Hyper, MemorySpec, ModelParams, Provenance, Sample};
use heapless::String;

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

/// A valid, well-conditioned random model of the paper's dims ([`Dims::PAPER`]) with `n`
/// centres: [`model_dims`].
pub fn model<const K: usize>(n: usize, seed: u64, fs: FeatureSet, prov: Provenance) -> ModelParams<f32, K> {
    model_dims(Dims::PAPER, n, seed, fs, prov)
}

/// Dims of `gratings` gratings, with or without ambient, and `m` measurands (at most
/// [`fbg_shared::layout::MAX_OUTPUTS`]) cycling through temperature, strain, pressure, then a second strain.
pub fn dims(gratings: usize, ambient: bool, m: usize) -> Result<Dims, Error> {
    let all = [
        Output::first(Quantity::Temperature),
        Output::first(Quantity::Strain),
        Output::first(Quantity::Pressure),
        Output { quantity: Quantity::Strain, index: 2 },
    ];
    Dims::new(gratings, ambient, all.get(..m).unwrap_or(&all))
}

/// A valid, well-conditioned random model of `dims` with `n` centres (at most `K`: the rest
/// are not made). Inputs it is meant for: Δλ in ±50 pm, T_amb in 0..40 °C, t in 0..1000 s
/// ([`random_samples`]); the envelope is ±60 pm, −5..45 °C.
pub fn model_dims<const K: usize>(
    dims: Dims,
    n: usize,
    seed: u64,
    fs: FeatureSet,
    prov: Provenance,
) -> ModelParams<f32, K> {
    let mut r = Rng(seed);
    let (m, s1, np, nz, ne) = (dims.n_outputs(), dims.stage1_len(), dims.poly_len(), dims.z_len(), dims.envelope_len());
    let mut p = ModelParams::<f32, K>::empty();
    p.dims = dims;
    p.hyper = hyper(fs);
    for row in p.stage1.iter_mut().take(m) {
        for (k, v) in row.iter_mut().enumerate().take(s1) {
            *v = if k == s1 - 1 { r.f32(-5.0, 5.0) } else { r.f32(-0.5, 0.5) };
        }
    }
    for (mu, s) in p.guess_mean.iter_mut().zip(p.guess_std.iter_mut()).take(m) {
        *mu = r.f32(-5.0, 5.0);
        *s = r.f32(1.0, 20.0);
    }
    for row in p.poly.iter_mut().take(m) {
        for v in row.iter_mut().take(np) {
            *v = r.f32(-2.0, 2.0);
        }
    }
    for i in 0..nz {
        let (mean, std) = if i < dims.gratings() {
            (0.0, 30.0)
        } else if dims.ambient() && i == dims.gratings() {
            (20.0, 10.0)
        } else if i == dims.z_time() {
            (500.0, 300.0)
        } else {
            (0.0, 1.0)
        };
        p.z_mean[i] = mean;
        p.z_std[i] = std;
    }
    let active = dims.z_active(fs);
    for _ in 0..n {
        let mut c = Centre::<f32>::default();
        for (mu, &on) in c.mu.iter_mut().zip(active.iter()) {
            *mu = if on { r.f32(-1.5, 1.5) } else { 0.0 };
        }
        for w in c.w.iter_mut().take(m) {
            *w = r.f32(-1.0, 1.0);
        }
        for v in c.v.iter_mut() {
            *v = r.f32(-1.0, 1.0);
        }
        if p.centres.push(c).is_err() {
            break;
        }
    }
    let mut g = 1.0f64;
    for v in p.var_inv_g.iter_mut().take(n.min(VAR_RANK)) {
        *v = g as f32;
        g *= r.uniform(0.3, 0.9);
    }
    p.var_inv_g_tail = if n > VAR_RANK { (g * 0.5) as f32 } else { 0.0 };
    for v in p.resid_var.iter_mut().take(m) {
        *v = r.f32(0.01, 1.0);
    }
    for o in 0..m {
        p.band_k[o] = fbg_shared::layout::Z95 as f32;
        p.fitted[o] = true;
    }
    for i in 0..ne {
        let amb = dims.ambient() && i == dims.gratings();
        p.envelope_lo[i] = if amb { -5.0 } else { -60.0 };
        p.envelope_hi[i] = if amb { 45.0 } else { 60.0 };
    }
    // The longest blob also has the longest field context (a known end of calibration).
    let long = prov.scenario.len() == prov.scenario.capacity();
    p.field = field_context(&dims, long);
    p.provenance = prov;
    p
}

/// A valid field context for `dims`: λ_ref 1530 + 5·g nm from the map, 1 pm tolerance, a day
/// of validated lead, outputs −100…100; with `long` a known end of calibration.
pub fn field_context(dims: &Dims, long: bool) -> fbg_shared::FieldContext {
    let mut f = fbg_shared::FieldContext::unknown();
    for g in 0..dims.gratings() {
        f.lambda_ref_nm[g] = 1530.0 + 5.0 * g as f64;
        f.lambda_ref_source[g] = fbg_shared::ZeroSource::Map;
    }
    f.lambda_ref_tol_pm = 1.0;
    f.cal_end_unix_s = long.then_some(1_767_571_200.0);
    f.lead_max_s = 86_400.0;
    for o in 0..dims.n_outputs() {
        f.output_lo[o] = -100.0;
        f.output_hi[o] = 100.0;
        f.band_max[o] = 10.0;
    }
    f
}

/// `n` random samples for a [`model_dims`] model of `dims` (Δλ in ±50 pm, T_amb in 0..40 °C,
/// NaN without ambient, t every 60 s from 0), then a few edge samples: far outside the
/// envelope, a NaN shift, an infinite time.
pub fn random_samples(dims: &Dims, n: usize, seed: u64) -> std::vec::Vec<Sample<f32>> {
    let mut r = Rng(seed);
    let g = dims.gratings().min(MAX_GRATINGS);
    let mut out = std::vec::Vec::with_capacity(n + 3);
    let mut walk = [0.0f64; MAX_GRATINGS];
    for i in 0..n {
        for w in walk.iter_mut().take(g) {
            *w = (*w + r.uniform(-4.0, 4.0)).clamp(-50.0, 50.0);
        }
        let t_amb = if dims.ambient() { r.f32(0.0, 40.0) } else { f32::NAN };
        let dl: std::vec::Vec<f32> = walk.iter().take(g).map(|&v| v as f32).collect();
        if let Ok(s) = Sample::from_slice(&dl, t_amb, 60.0 * i as f32) {
            out.push(s);
        }
    }
    let t_end = 60.0 * n as f32;
    let mut far = [10.0f32; MAX_GRATINGS];
    far[0] = 500.0;
    let mut nan = [1.0f32; MAX_GRATINGS];
    nan[g.saturating_sub(1)] = f32::NAN;
    let amb = if dims.ambient() { 20.0 } else { f32::NAN };
    for (dl, t) in [(far, t_end + 60.0), (nan, t_end + 120.0), ([0.0; MAX_GRATINGS], f32::INFINITY)] {
        if let Ok(s) = Sample::from_slice(dl.get(..g).unwrap_or(&[]), amb, t) {
            out.push(s);
        }
    }
    out
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
        observer_row: pad(&[0.1, -0.05, 0.02, 0.5, -3.0]),
    }
}

/// [`full_memory_spec`] for a model of `dims`: no ambient slot without ambient, no observer
/// without its slot, the observer's row a mix of the gratings plus half the ambient.
pub fn full_memory_spec_for(dims: &Dims) -> MemorySpec<f32> {
    let mut s = full_memory_spec();
    restrict(&mut s, dims);
    s
}

fn restrict(s: &mut MemorySpec<f32>, dims: &Dims) {
    if !dims.ambient() {
        s.ambient_tau_s = [0.0; 4];
    }
    let mut row = [0.0f32; MAX_STAGE1];
    let s1 = dims.stage1_len();
    for (k, v) in row.iter_mut().enumerate().take(s1) {
        *v = if k + 1 == s1 {
            -3.0
        } else if dims.ambient() && k + 2 == s1 {
            0.5
        } else {
            0.1 / (k + 1) as f32
        };
    }
    s.observer_row = row;
    if !dims.has_observer() {
        s.observer_lag_s = 0.0;
        s.observer_smooth_s = 0.0;
        s.observer_row = [0.0; MAX_STAGE1];
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
    s.observer_row = pad(&[0.05, -0.02, 0.03, 0.8, 4.0]);
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
    memory_model_dims(Dims::PAPER, n, seed, fs, prov, spec)
}

/// [`memory_model`] of `dims` ([`model_dims`] with `spec`, restricted to the slots the dims
/// have, and a random Γ on its used terms).
pub fn memory_model_dims<const K: usize>(
    dims: Dims,
    n: usize,
    seed: u64,
    fs: FeatureSet,
    prov: Provenance,
    spec: MemorySpec<f32>,
) -> ModelParams<f32, K> {
    let mut p = model_dims(dims, n, seed, fs, prov);
    let mut r = Rng(seed ^ 0x5EE_D0F6_A33A);
    let mut spec = spec;
    if dims != Dims::PAPER {
        restrict(&mut spec, &dims);
    }
    p.memory = spec;
    let nm = dims.memory_len();
    for row in p.gamma.iter_mut().take(dims.n_outputs()) {
        for (k, g) in row.iter_mut().enumerate().take(nm) {
            *g = if spec.term_active(&dims, k) { r.f32(-0.2, 0.2) } else { 0.0 };
        }
    }
    p
}

/// Encode into a fresh buffer of exactly `max_len_for(dims, K)` bytes (so a too-small bound fails).
pub fn encode_vec<const K: usize>(p: &ModelParams<f32, K>) -> Result<std::vec::Vec<u8>, Error> {
    let mut buf = vec![0u8; blob::max_len_for(&p.dims, K)];
    let n = blob::encode(p, &mut buf)?;
    buf.truncate(n);
    Ok(buf)
}
