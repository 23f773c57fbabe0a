//! A synthetic FBG installation and the models fitted to it by construction: the firmware's
//! golden and bench models beyond what the trainer makes (K = 64; every slot of the memory
//! bank in use) and the host inference bench's.
//!
//! Three gratings read (T, ε, p) through a nominal gauge matrix with a small T·ε cross-term and
//! 0.8 pm of noise; T, ε and p follow sines with turning points (and ε steps of ±30 µε), one
//! sample a minute. A model's stage 1 is the exact inverse of the gauge matrix, its centres are
//! picked among the standardised inputs of a 2 000-sample calibration run (so they sit where
//! the data are), its envelope is that run's range plus 10 %. Every value is a deterministic
//! function of the seeds: the fixtures made from them are pinned by the firmware's tests and
//! benchmarks, so changing anything here changes those.

use fbg_shared::layout::paper::{N_MEMORY, N_OUTPUTS, N_STAGE1, Z_DIMS};
use fbg_shared::layout::{pad, pad2, Dims, FeatureSet, MAX_MEMORY, MAX_OUTPUTS, VAR_RANK};
use fbg_shared::{Centre, Error, Hyper, LatchBank, MemoryGroup, MemorySpec, ModelParams, Provenance, Sample};

use crate::Rng;

/// Largest centre count of the synthetic models.
pub const MAX_K: usize = 64;

/// Nominal gauge matrix (pm per °C, µε, kPa), rows FBG1..3.
const GAUGE: [[f64; 3]; 3] = [[10.0, 1.20, 0.02], [9.8, 0.05, 0.01], [11.0, 0.10, 1.0]];
/// Reference point of the shifts.
const T0: f64 = 20.0;
const P0: f64 = 150.0;
/// Spread of the quantities over a calibration run (°C, µε, kPa).
const Q_STD: [f64; 3] = [3.0, 80.0, 15.0];

fn inverse3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let [[a, b, c], [d, e, f], [g, h, i]] = *m;
    let det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g);
    [
        [(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det],
        [(f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det],
        [(d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det],
    ]
}

/// One simulated sample at index `i`: true (T, ε, p) trajectories with turning points, the
/// measured shifts through the gauge matrix with a small cross-term and noise.
pub fn simulate(i: usize, rng: &mut Rng) -> Sample<f32> {
    let x = i as f64;
    let tau = std::f64::consts::TAU;
    let t = T0 + 4.0 * (tau * x / 300.0).sin() + 1.0 * (tau * x / 47.0).sin();
    let e = 100.0 * (tau * x / 170.0).sin() + if (i / 90).is_multiple_of(2) { 30.0 } else { -30.0 };
    let p = P0 + 20.0 * (tau * x / 230.0).sin();
    let q = [t - T0, e, p - P0];
    let mut dl = [0.0f64; 3];
    for (d, row) in dl.iter_mut().zip(GAUGE.iter()) {
        *d = row.iter().zip(q.iter()).map(|(k, v)| k * v).sum::<f64>() + 0.8 * rng.normal();
    }
    dl[0] += 1e-3 * q[0] * q[1]; // c_Tε cross-term
    let t_amb = t + 0.5 + 0.1 * rng.normal();
    Sample::new([dl[0] as f32, dl[1] as f32, dl[2] as f32], t_amb as f32, (60.0 * x) as f32)
}

/// `n` samples of the installation from sample 0 on its regular 60-s clock, noise from
/// `Rng::new(seed)`: inside the envelope of [`synthetic_params`]'s models, unflagged.
pub fn samples(n: usize, seed: u64) -> Vec<Sample<f32>> {
    let mut rng = Rng::new(seed);
    (0..n).map(|i| simulate(i, &mut rng)).collect()
}

/// Time stamps of a realistic acquisition \[s\] from `t0`: 60 s steps, with irregular ones mixed
/// in (every 7th step 60.5 s, every 53rd 23 s, every 89th 131 s, every 211th a repeated time
/// stamp) and one 5 h gap at 3/5 of the stream. The memory bank recomputes its smoothing
/// factors on every Δt change and holds its low-passes on a repeated stamp.
pub fn irregular_clock(n: usize, t0: f64) -> Vec<f64> {
    let mut t = t0;
    (0..n)
        .map(|i| {
            if i > 0 {
                t += if i == n * 3 / 5 {
                    5.0 * 3600.0
                } else if i % 211 == 0 {
                    0.0
                } else if i % 89 == 0 {
                    131.0
                } else if i % 53 == 0 {
                    23.0
                } else if i % 7 == 0 {
                    60.5
                } else {
                    60.0
                };
            }
            t
        })
        .collect()
}

/// `n` golden samples on [`irregular_clock`]: the trajectory, a stretch out of the Δλ1
/// envelope, two T_amb excursions and one NaN.
pub fn golden_samples(n: usize, seed: u64) -> Vec<Sample<f32>> {
    let clock = irregular_clock(n, 3600.0);
    let mut out = samples(n, seed);
    for (s, &t) in out.iter_mut().zip(clock.iter()) {
        s.t_s = t as f32;
    }
    let n = out.len();
    for (i, s) in out.iter_mut().enumerate() {
        if (n * 2 / 3..n * 2 / 3 + 10).contains(&i) {
            s.dl_pm[0] += 400.0; // far outside the envelope: out-of-envelope and weak support
        }
        if i == n * 5 / 6 || i == n * 5 / 6 + 1 {
            s.t_amb_c = 45.0;
        }
        if i == n * 3 / 4 {
            s.dl_pm[1] = f32::NAN;
        }
    }
    out
}

/// Mean and standard deviation of each RBF input of a feature set over a calibration run.
struct Scaler {
    mean: [f64; Z_DIMS],
    std: [f64; Z_DIMS],
}

fn z_raw(s: &Sample<f32>, latch: [f64; 3]) -> [f64; Z_DIMS] {
    [
        s.dl_pm[0] as f64,
        s.dl_pm[1] as f64,
        s.dl_pm[2] as f64,
        s.t_amb_c as f64,
        s.t_s as f64,
        latch[0],
        latch[1],
        latch[2],
    ]
}

/// Every slot of the memory bank in use: grating high-passes at τ = 300 s … 4 h, ambient ones
/// at 300 s … 1 h, plays of half-width 2, 4 and 8 pm, and the drift observer (the thermometer's
/// lag 1 200 s, smoothing 2 400 s) on `observer_row` (T_g [°C] from [Δλ1..3, T_amb, 1]).
pub fn full_memory_spec(observer_row: [f64; N_STAGE1]) -> MemorySpec<f64> {
    MemorySpec {
        grating_tau_s: [300.0, 900.0, 1800.0, 3600.0, 7200.0, 14400.0],
        ambient_tau_s: [300.0, 900.0, 1800.0, 3600.0],
        play_half_width_pm: [2.0, 4.0, 8.0],
        observer_lag_s: 1200.0,
        observer_smooth_s: 2400.0,
        observer_row: pad(&observer_row),
    }
}

/// A small Γ, non-zero on every term `spec` uses: per output unit `scale[o]`, 1e-3·scale per pm
/// (grating high-passes, stop terms), 1e-2·scale per °C (ambient high-passes), and 0.2 °C/°C
/// for the drift observer on T only (the trainer offers it to temperature outputs only).
pub fn small_gamma(spec: &MemorySpec<f64>, scale: [f64; N_OUTPUTS], seed: u64) -> [[f64; MAX_MEMORY]; MAX_OUTPUTS] {
    let mut rng = Rng::new(seed);
    let mut g = [[0.0; MAX_MEMORY]; MAX_OUTPUTS];
    let dims = Dims::PAPER;
    for (o, row) in g.iter_mut().enumerate().take(N_OUTPUTS) {
        for (k, v) in row.iter_mut().enumerate().take(N_MEMORY) {
            let Some(term) = spec.term(&dims, k).filter(|t| t.parameter > 0.0) else { continue };
            let r = (0.5 + rng.unit()) * if rng.unit() < 0.5 { -1.0 } else { 1.0 };
            *v = match term.group {
                MemoryGroup::GratingHighPass | MemoryGroup::Stop => 1e-3 * scale[o] * r,
                MemoryGroup::AmbientHighPass => 1e-2 * scale[o] * r,
                MemoryGroup::DriftObserver if o == 0 => 0.2,
                MemoryGroup::DriftObserver => 0.0,
            };
        }
    }
    g
}

/// A synthetic, valid K-centre hysteresis-aware model, deterministic in `seed`, with every
/// slot of the memory bank in use ([`full_memory_spec`], [`small_gamma`]); see
/// [`without_memory`] for the same model without.
pub fn synthetic_params(k: usize, seed: u64) -> Result<ModelParams<f64, MAX_K>, Error> {
    if k > MAX_K {
        return Err(Error::TooManyCentres { found: k, capacity: MAX_K });
    }
    let mut rng = Rng::new(seed);
    let dead_band = 2.0;
    // A calibration run: centres are picked among its standardised inputs (as k-means++
    // would), so they sit where data is.
    let (n_cal, zs, sc) = calibration_run(&mut rng, dead_band);
    let fs = FeatureSet::HysteresisAware;
    let active = fs.active();
    let centres = pick_centres(k, &zs, &sc, &active, &mut rng)?;

    // Stage 1: the exact inverse of the nominal gauge matrix plus a small T_amb term.
    let inv = inverse3(&GAUGE);
    let offsets = [T0, 0.0, P0];
    let amb = [0.002, -0.05, 0.01];
    let mut stage1 = [[0.0; 5]; N_OUTPUTS];
    for o in 0..N_OUTPUTS {
        stage1[o] = [inv[o][0], inv[o][1], inv[o][2], amb[o], offsets[o] - amb[o] * (T0 + 0.5)];
    }
    let poly = [
        [20.01, 3.0, 0.003, -0.002, 0.02, 0.0, 0.0, 0.004, 0.001, 0.0],
        [0.3, 0.4, 80.0, 0.1, 0.2, 0.6, 0.0, 0.9, 0.0, 0.05],
        [150.05, 0.1, 0.02, 15.0, 0.05, 0.0, 0.12, 0.0, 0.3, 0.02],
    ];
    let mut z_std = sc.std;
    let mut z_mean = sc.mean;
    for d in 0..Z_DIMS {
        if !active[d] {
            z_mean[d] = 0.0;
            z_std[d] = 1.0;
        }
    }
    let margin = 0.1;
    let (envelope_lo, envelope_hi) = envelope(&zs, margin);
    let var_inv_g = [0.8, 0.5, 0.3, 0.2];
    debug_assert_eq!(var_inv_g.len(), VAR_RANK);
    let params = ModelParams::<f64, MAX_K> {
        dims: Dims::PAPER,
        hyper: Hyper {
            feature_set: fs,
            sigma_mult: 1.5,
            sigma: 1.2,
            alpha: 1e-2,
            dead_band_pm: dead_band,
            weak_support: 0.02,
            envelope_margin: margin,
            flagged_band_factor: 2.0,
        },
        stage1: pad2(&stage1),
        guess_mean: pad(&[T0, 0.0, P0]),
        guess_std: pad(&Q_STD),
        poly: pad2(&poly),
        memory: MemorySpec::off(),
        gamma: [[0.0; MAX_MEMORY]; MAX_OUTPUTS],
        z_mean: pad(&z_mean),
        z_std: pad(&z_std),
        centres,
        var_inv_g,
        var_inv_g_tail: 0.02,
        resid_var: pad(&[0.12f64.powi(2), 2.5f64.powi(2), 0.6f64.powi(2)]),
        resid_var_growth: [0.0; MAX_OUTPUTS],
        t_cal_end_s: 0.0,
        band_k: pad(&[1.959_964; 3]),
        envelope_lo: pad(&envelope_lo),
        envelope_hi: pad(&envelope_hi),
        fitted: pad(&[true; 3]),
        provenance: Provenance {
            seed,
            scenario: heapless::String::try_from("synthetic-fixture").unwrap_or_default(),
            trainer_version: heapless::String::try_from("xtask").unwrap_or_default(),
            date_yyyymmdd: 20260101,
            n_cal,
        },
        field: fbg_shared::FieldContext {
            lambda_ref_nm: pad(&[1535.0, 1545.0, 1555.0]),
            lambda_ref_source: [fbg_shared::ZeroSource::Simulated; fbg_shared::layout::MAX_GRATINGS],
            lambda_ref_tol_pm: 1.0,
            cal_end_unix_s: Some(1_767_571_200.0),
            lead_max_s: 86_400.0,
            output_lo: pad(&[T0 as f32 - 30.0, -1000.0, P0 as f32 - 100.0]),
            output_hi: pad(&[T0 as f32 + 30.0, 1000.0, P0 as f32 + 100.0]),
            band_max: pad(&[0.3, 6.0, 1.5]),
        },
        trust: fbg_shared::TrustSpec::off(),
    };
    let mut params = params;
    // T_g = T0 + (row 0 of the inverse gauge matrix)·Δλ: the grating temperature.
    params.memory = full_memory_spec([inv[0][0], inv[0][1], inv[0][2], 0.0, T0]);
    params.gamma = small_gamma(&params.memory, Q_STD, seed ^ 0x6d65_6d6f);
    params.validate()?;
    Ok(params)
}

/// A simulated calibration run of 2000 samples: its raw RBF inputs (latches with `dead_band`
/// \[pm\]) and their scaler; the run's length.
fn calibration_run(rng: &mut Rng, dead_band: f64) -> (u32, Vec<[f64; Z_DIMS]>, Scaler) {
    let cal: Vec<Sample<f32>> = (0..2000).map(|i| simulate(i, rng)).collect();
    let mut latches = LatchBank::new();
    let db_ticks = fbg_shared::direction_latch::ticks(dead_band);
    let zs: Vec<[f64; Z_DIMS]> = cal
        .iter()
        .map(|s| {
            let dl = s.dl_pm.map(f64::from);
            let l = latches.update(&dl, 3, db_ticks);
            z_raw(s, [l[0], l[1], l[2]])
        })
        .collect();
    let nf = zs.len() as f64;
    let mut sc = Scaler { mean: [0.0; Z_DIMS], std: [1.0; Z_DIMS] };
    for d in 0..Z_DIMS {
        let m = zs.iter().map(|z| z[d]).sum::<f64>() / nf;
        let v = zs.iter().map(|z| (z[d] - m).powi(2)).sum::<f64>() / nf;
        sc.mean[d] = m;
        sc.std[d] = if v > 0.0 { v.sqrt() } else { 1.0 };
    }
    (cal.len() as u32, zs, sc)
}

/// `k` centres among the standardised inputs `zs` (jittered, on the `active` inputs), with
/// random weights and variance components.
fn pick_centres(
    k: usize,
    zs: &[[f64; Z_DIMS]],
    sc: &Scaler,
    active: &[bool; Z_DIMS],
    rng: &mut Rng,
) -> Result<heapless::Vec<Centre<f64>, MAX_K>, Error> {
    let mut centres: heapless::Vec<Centre<f64>, MAX_K> = heapless::Vec::new();
    for j in 0..k {
        let src = &zs[(j * zs.len() / k.max(1) + 37) % zs.len()];
        let mut c = Centre::<f64>::default();
        for d in 0..Z_DIMS {
            if active[d] {
                c.mu[d] = ((src[d] - sc.mean[d]) / sc.std[d] + 0.1 * rng.normal()).clamp(-2.5, 2.5);
            }
        }
        c.w = pad(&[0.05 * rng.normal(), 2.0 * rng.normal(), 0.5 * rng.normal()]);
        for v in c.v.iter_mut() {
            *v = rng.normal() / (k.max(1) as f64).sqrt();
        }
        centres.push(c).map_err(|_| Error::TooManyCentres { found: k, capacity: MAX_K })?;
    }
    Ok(centres)
}

/// The input envelope of the first four raw inputs (Δλ1..3, T_amb) of `zs`, widened by
/// `margin` of the range on each side.
fn envelope(zs: &[[f64; Z_DIMS]], margin: f64) -> ([f64; 4], [f64; 4]) {
    let mut envelope_lo = [0.0; 4];
    let mut envelope_hi = [0.0; 4];
    for d in 0..4 {
        let lo = zs.iter().map(|z| z[d]).fold(f64::INFINITY, f64::min);
        let hi = zs.iter().map(|z| z[d]).fold(f64::NEG_INFINITY, f64::max);
        let pad = margin * (hi - lo);
        envelope_lo[d] = lo - pad;
        envelope_hi[d] = hi + pad;
    }
    (envelope_lo, envelope_hi)
}

/// `p` without memory terms (spec off, Γ = 0).
pub fn without_memory(mut p: ModelParams<f64, MAX_K>) -> ModelParams<f64, MAX_K> {
    p.memory = MemorySpec::off();
    p.gamma = [[0.0; MAX_MEMORY]; MAX_OUTPUTS];
    p
}

/// [`synthetic_params`] (with the full memory bank when `memory`, else [`without_memory`])
/// encoded as a `.fbgm` blob.
pub fn synthetic_blob(k: usize, seed: u64, memory: bool) -> Result<Vec<u8>, Error> {
    let p = synthetic_params(k, seed)?;
    encode_f64(&if memory { p } else { without_memory(p) })
}

/// `p` in f32 as a `.fbgm` blob.
pub fn encode_f64(p: &ModelParams<f64, MAX_K>) -> Result<Vec<u8>, Error> {
    crate::models::encode_vec(&p.convert::<f32, MAX_K>()?)
}

/// The model in `blob_bytes` with the full memory bank ([`full_memory_spec`] on its stage-1 T
/// row, and [`small_gamma`] scaled by its guess spread) in place of whatever memory it had:
/// what the device's memory is checked with when the trainer's model has none.
pub fn with_full_memory(blob_bytes: &[u8]) -> Result<Vec<u8>, Error> {
    let mut p: ModelParams<f64, MAX_K> = fbg_shared::blob::decode::<MAX_K>(blob_bytes)?.convert()?;
    let [r0, r1, r2, r3, r4, ..] = p.stage1[0];
    p.memory = full_memory_spec([r0, r1, r2, r3, r4]);
    let [s0, s1, s2, _] = p.guess_std;
    p.gamma = small_gamma(&p.memory, [s0, s1, s2], 5);
    encode_f64(&p)
}
