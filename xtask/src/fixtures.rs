//! Test fixtures of the firmware, made by the trainer.
//!
//! [`ensure`] builds `fbg-trainer` (release) and runs it into `target/fixtures`:
//!
//! - `data.csv` (+ `data.meta.json`): `fbg-trainer simulate --seed 7` (the `paper` preset);
//! - `model.fbgm` (+ `model-p.fbgm`, `model.coefficients.json`): `fbg-trainer train` on it, the
//!   Model-H of the paper preset, seed 7, K = 32 — byte for byte what
//!   `firmware/model/default.fbgm` must be (`SOURCE_DATE_EPOCH=0` pins the provenance date;
//!   `cargo xtask fixtures --write-default` copies it there);
//! - `golden_inputs.bin`, `golden_expected.csv`, `golden_meta.json`: `fbg-trainer golden
//!   --samples 600` (raw LE f32 × 5 per sample: dl1_pm, dl2_pm, dl3_pm, T_amb_C, t_s; the f64
//!   answers of `fbg_shared::Compensator<f64>`; Model-H's hold-out RMSE as the tolerance scale);
//! - `device_golden_inputs.bin`, `device_golden_expected.csv`: what the QEMU golden test runs
//!   on the trainer's model, the trainer's 600 samples followed by [`edge_samples`] (out of the
//!   envelope, weak support, NaN and ∞ inputs, which the hold-out never has) with their host
//!   answers; the first 600 expected rows must equal the trainer's (checked here);
//! - `memory_model.fbgm`, `memory_golden_inputs.bin`, `memory_golden_expected.csv`: the second
//!   golden set, the synthetic K = 32 model of this file with every slot of the memory bank in
//!   use ([`synthetic_params`]) on [`golden_samples`] (an irregular clock with a 5 h gap, flags);
//! - `golden_pack.bin`: both sets as the golden image embeds them ([`pack_bytes`]).
//!
//! [`ensure_device`] adds the models of the link test and the bench: `update/model.fbgm`
//! (`train --features paper`, a second valid model with another feature set), the synthetic models of this file with and without the memory
//! bank at K = 0, 16, 32 and 64 (the trainer's grid stops at 32 centres; the 64-centre one is
//! also the model a K = 32 build must refuse), and the bench packs (`bench_pack_k32.bin`,
//! `bench_pack_k64.bin`: every model a bench image of that capacity runs, with its samples).
//!
//! Everything is regenerated when the trainer binary changes (a stamp in the directory), so
//! repeated calls cost one `cargo build` check.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use anyhow::{bail, ensure as check, Context, Result};
use fbg_shared::blob;
use fbg_shared::layout::{FeatureSet, N_MEMORY, N_OUTPUTS, N_STAGE1, VAR_RANK, Z_DIMS};
use fbg_shared::{
    Centre, Compensator, Estimate, Flags, Hyper, LatchBank, MemoryGroup, MemorySpec, ModelParams, Provenance, Sample,
};

/// Largest centre count the fixture tools handle.
pub const MAX_K: usize = 64;
/// Seed of the simulated dataset (the paper preset).
pub const SEED: u64 = 7;
/// Golden samples the trainer exports.
pub const GOLDEN_SAMPLES: usize = 600;
/// Samples of the synthetic memory golden set (≈ 30 h at 60 s: several of the longest τ, 4 h).
pub const MEMORY_GOLDEN_SAMPLES: usize = 1500;
/// Bump to regenerate the fixtures when this file changes what it writes.
const FIXTURES_VERSION: u32 = 4;

/// Paths of the trainer-made fixtures.
#[derive(Clone, Debug)]
pub struct Fixtures {
    /// The trainer binary.
    pub trainer: PathBuf,
    /// The simulated dataset (paper preset, seed 7).
    pub data: PathBuf,
    /// Model-H trained on it (K <= 32): the first golden model and the product's default.
    pub model: PathBuf,
    /// Golden inputs of the device run (raw LE f32 × 5 per sample): trainer + edge samples.
    pub golden_inputs: PathBuf,
    /// Host f64 results for them (CSV).
    pub golden_expected: PathBuf,
    /// The trainer's `golden_meta.json` (Model-H hold-out RMSE: the tolerance scale).
    pub golden_meta: PathBuf,
    /// The second golden model: synthetic, K = 32, every memory slot in use.
    pub memory_model: PathBuf,
    /// Its golden inputs ([`golden_samples`]: irregular clock, a gap, flagged samples).
    pub memory_inputs: PathBuf,
    /// Host f64 results for them (CSV).
    pub memory_expected: PathBuf,
    /// Both golden sets as the golden image embeds them.
    pub golden_pack: PathBuf,
}

/// Directory of the fixtures.
pub fn dir(root: &Path) -> PathBuf {
    root.join("target").join("fixtures")
}

/// Build the trainer (release) and return its binary.
pub fn trainer(root: &Path) -> Result<PathBuf> {
    crate::run(crate::cargo().current_dir(root).args(["build", "--release", "--locked", "-p", "fbg-trainer"]))
        .context("building fbg-trainer (it makes the firmware's fixtures)")?;
    let _ = root;
    let bin = crate::target_dir().join("release").join(format!("fbg-trainer{}", std::env::consts::EXE_SUFFIX));
    check!(bin.exists(), "{} is missing after the build", bin.display());
    Ok(bin)
}

/// Run the trainer with `args` (provenance date pinned; `--json` where the command has it,
/// to keep progress bars out of the log, its report discarded).
pub fn run_trainer(bin: &Path, args: &[&str]) -> Result<()> {
    let mut cmd = Command::new(bin);
    cmd.args(args).env("SOURCE_DATE_EPOCH", "0").stdout(Stdio::null());
    if args.first().is_some_and(|c| *c == "simulate" || *c == "train") {
        cmd.arg("--json");
    }
    crate::run(&mut cmd)
}

/// What the fixtures were made with: the trainer binary's size and time, and this file's
/// version. Equal stamps mean the files are current.
fn stamp_of(bin: &Path) -> Result<String> {
    let m = fs::metadata(bin)?;
    let t = m.modified()?.duration_since(std::time::UNIX_EPOCH).map(|d| d.as_nanos()).unwrap_or(0);
    Ok(format!("fixtures v{FIXTURES_VERSION}; trainer {} bytes, modified {t}\n", m.len()))
}

fn current(stamp: &Path, want: &str, files: &[&Path]) -> bool {
    fs::read_to_string(stamp).is_ok_and(|s| s == want) && files.iter().all(|f| f.exists())
}

fn p(path: &Path) -> &str {
    path.to_str().unwrap_or_default()
}

/// Make (or reuse) the trainer's fixtures and return their paths.
pub fn ensure(root: &Path) -> Result<Fixtures> {
    let d = dir(root);
    fs::create_dir_all(&d).with_context(|| format!("creating {}", d.display()))?;
    let bin = trainer(root)?;
    let fx = Fixtures {
        trainer: bin.clone(),
        data: d.join("data.csv"),
        model: d.join("model.fbgm"),
        golden_inputs: d.join("device_golden_inputs.bin"),
        golden_expected: d.join("device_golden_expected.csv"),
        golden_meta: d.join("golden_meta.json"),
        memory_model: d.join("memory_model.fbgm"),
        memory_inputs: d.join("memory_golden_inputs.bin"),
        memory_expected: d.join("memory_golden_expected.csv"),
        golden_pack: d.join("golden_pack.bin"),
    };
    let stamp = d.join("stamp-main.txt");
    let want = stamp_of(&bin)?;
    let files = [
        &fx.data,
        &fx.model,
        &fx.golden_inputs,
        &fx.golden_expected,
        &fx.golden_meta,
        &fx.memory_model,
        &fx.memory_inputs,
        &fx.memory_expected,
        &fx.golden_pack,
    ];
    if current(&stamp, &want, &files.map(PathBuf::as_path)) {
        return Ok(fx);
    }
    crate::step("fixtures: simulate, train and export golden vectors with fbg-trainer");
    let _ = fs::remove_file(&stamp);
    let seed = SEED.to_string();
    let n = GOLDEN_SAMPLES.to_string();
    run_trainer(&bin, &["simulate", "--seed", &seed, "--out", p(&fx.data)])?;
    run_trainer(&bin, &["train", "--data", p(&fx.data), "--out", p(&fx.model)])?;
    run_trainer(&bin, &["golden", "--data", p(&fx.data), "--model", p(&fx.model), "--out", p(&d), "--samples", &n])?;
    let model = fs::read(&fx.model)?;
    let params = decode(&model)?;
    check!(
        params.centres.len() <= 32,
        "the trainer's Model-H has {} centres, the product holds 32",
        params.centres.len()
    );

    // The device run: the trainer's samples, then the edge cases, streamed in one go.
    let trainer_inputs = read_inputs(&d.join("golden_inputs.bin"))?;
    let trainer_expected = read_expected(&d.join("golden_expected.csv"))?;
    check!(
        trainer_inputs.len() == trainer_expected.len(),
        "the trainer's golden inputs and expected rows differ in count"
    );
    let mut inputs = trainer_inputs.clone();
    inputs.extend(edge_samples(&params, &trainer_inputs));
    let expected = reference(&model, &inputs)?;
    // Our host reference must reproduce the trainer's (same code, same f64 model).
    for (i, (a, b)) in expected.iter().zip(trainer_expected.iter()).enumerate() {
        let same = |x: f64, y: f64| (x.is_nan() && y.is_nan()) || x == y || (x - y).abs() <= 1e-9 * y.abs().max(1e-9);
        check!(
            a.flags == b.flags && (0..3).all(|c| same(a.values[c], b.values[c]) && same(a.band95[c], b.band95[c])),
            "golden row {}: xtask's host reference {a:?} differs from the trainer's {b:?}",
            i + 2
        );
    }
    write_atomic(&fx.golden_inputs, &inputs_bytes(&inputs))?;
    write_atomic(&fx.golden_expected, expected_csv(&expected).as_bytes())?;

    // The second set: every operator of the memory bank, an irregular clock and a gap.
    let memory_model = synthetic_blob(32, 1, true)?;
    let memory_inputs = golden_samples(MEMORY_GOLDEN_SAMPLES, 11);
    let memory_expected = reference(&memory_model, &memory_inputs)?;
    write_atomic(&fx.memory_model, &memory_model)?;
    write_atomic(&fx.memory_inputs, &inputs_bytes(&memory_inputs))?;
    write_atomic(&fx.memory_expected, expected_csv(&memory_expected).as_bytes())?;
    write_atomic(&fx.golden_pack, &pack_bytes(&[(&model, &inputs), (&memory_model, &memory_inputs)]))?;
    write_atomic(&stamp, want.as_bytes())?;
    Ok(fx)
}

/// Models and samples as one file for a test image to embed: per record a u32 LE blob length,
/// the blob, a u32 LE sample count and the samples ([`inputs_bytes`]). Parsed on the device by
/// `fbg_firmware::pack`.
pub fn pack_bytes(records: &[(&[u8], &[Sample<f32>])]) -> Vec<u8> {
    let mut out = Vec::new();
    for (blob_bytes, samples) in records {
        out.extend_from_slice(&(blob_bytes.len() as u32).to_le_bytes());
        out.extend_from_slice(blob_bytes);
        out.extend_from_slice(&(samples.len() as u32).to_le_bytes());
        out.extend_from_slice(&inputs_bytes(samples));
    }
    out
}

/// Samples the hold-out does not contain, to run the device's flag paths against the host's:
/// a stretch far outside the Δλ1 envelope (out of envelope, and weak support), T_amb beyond the
/// envelope, a NaN and an infinite input, then ordinary samples again (from `base`).
pub fn edge_samples(p: &ModelParams<f32, MAX_K>, base: &[Sample<f32>]) -> Vec<Sample<f32>> {
    let mut out = Vec::new();
    let pick = |i: usize| base.get(i % base.len().max(1)).copied().unwrap_or_default();
    let span = |d: usize| p.envelope_hi[d] - p.envelope_lo[d];
    for i in 0..10 {
        let mut s = pick(i);
        s.dl_pm[0] = p.envelope_hi[0] + 3.0 * span(0);
        out.push(s);
    }
    for i in 10..12 {
        let mut s = pick(i);
        s.t_amb_c = p.envelope_hi[3] + 0.5 * span(3) + 5.0;
        out.push(s);
    }
    let mut s = pick(12);
    s.dl_pm[1] = f32::NAN;
    out.push(s);
    let mut s = pick(13);
    s.t_amb_c = f32::INFINITY;
    out.push(s);
    out.extend((20..40).map(pick));
    out
}

/// Extra fixtures of the device tests and the bench.
#[derive(Clone, Debug)]
pub struct DeviceFixtures {
    /// A second valid model (the trainer's with the paper feature set) for the update test.
    pub update_model: PathBuf,
    /// A valid model with more centres than a K = 32 build holds (synthetic K = 64).
    pub k64_model: PathBuf,
    /// Bench models and inputs, in the order the bench images run them.
    pub bench: Vec<BenchFixture>,
    /// The bench packs per build capacity (32: every model with up to 32 centres; 64).
    pub bench_packs: Vec<(usize, PathBuf)>,
}

/// The model and samples of one bench row.
#[derive(Clone, Debug)]
pub struct BenchFixture {
    /// Short name (JSON key and table row).
    pub name: &'static str,
    /// Centres of the model.
    pub k: usize,
    /// Whether the model has memory terms (and how many slots are in use).
    pub memory_terms: usize,
    /// Capacity of the bench image that runs it.
    pub capacity: usize,
    /// Model blob (its samples, at most 64 used, are in the bench pack).
    pub model: PathBuf,
    /// Where the model comes from.
    pub source: &'static str,
}

/// Memory slots in use in a blob.
pub fn memory_terms(blob_bytes: &[u8]) -> Result<usize> {
    let p = decode(blob_bytes)?;
    Ok((0..N_MEMORY).filter(|&k| p.memory.term_active(k)).count())
}

/// Make (or reuse) the device-test and bench fixtures.
pub fn ensure_device(root: &Path) -> Result<DeviceFixtures> {
    let fx = ensure(root)?;
    let d = dir(root);
    let update_model = d.join("update").join("model.fbgm");
    let k64_model = d.join("bench_k64.fbgm");
    let trainer_inputs = d.join("bench_inputs.bin");
    let synthetic_inputs = d.join("bench_inputs_synthetic.bin");
    let syn = |k: usize, mem: bool| d.join(format!("bench_synthetic_k{k}{}.fbgm", if mem { "_memory" } else { "" }));
    // (name, K, memory, capacity, model, inputs, source)
    let rows: Vec<(&'static str, usize, bool, usize, PathBuf, PathBuf, &'static str)> = vec![
        (
            "default",
            0,
            false,
            32,
            fx.model.clone(),
            trainer_inputs.clone(),
            "fbg-trainer train (paper preset, seed 7): the product's default model",
        ),
        (
            "memory_k0",
            0,
            true,
            32,
            syn(0, true),
            synthetic_inputs.clone(),
            "synthetic (xtask/src/fixtures.rs), the full memory bank (32 terms), no centres",
        ),
        (
            "memory_k16",
            16,
            true,
            32,
            syn(16, true),
            synthetic_inputs.clone(),
            "synthetic (xtask/src/fixtures.rs), the full memory bank (32 terms)",
        ),
        (
            "memory_k32",
            32,
            true,
            32,
            syn(32, true),
            synthetic_inputs.clone(),
            "synthetic (xtask/src/fixtures.rs), the full memory bank (32 terms)",
        ),
        (
            "plain_k16",
            16,
            false,
            32,
            syn(16, false),
            synthetic_inputs.clone(),
            "synthetic (xtask/src/fixtures.rs), no memory terms",
        ),
        (
            "plain_k32",
            32,
            false,
            32,
            syn(32, false),
            synthetic_inputs.clone(),
            "synthetic (xtask/src/fixtures.rs), no memory terms",
        ),
        (
            "plain_k64",
            64,
            false,
            64,
            k64_model.clone(),
            synthetic_inputs.clone(),
            "synthetic (xtask/src/fixtures.rs), no memory terms; the trainer's grid stops at 32 centres",
        ),
        (
            "memory_k64",
            64,
            true,
            64,
            syn(64, true),
            synthetic_inputs.clone(),
            "synthetic (xtask/src/fixtures.rs), the full memory bank (32 terms)",
        ),
    ];
    let bench_packs = vec![(32, d.join("bench_pack_k32.bin")), (64, d.join("bench_pack_k64.bin"))];
    let stamp = d.join("stamp-device.txt");
    let want = stamp_of(&fx.trainer)?;
    let mut files: Vec<&Path> = vec![&update_model, &k64_model, &trainer_inputs, &synthetic_inputs];
    files.extend(rows.iter().map(|r| r.4.as_path()));
    files.extend(bench_packs.iter().map(|(_, p)| p.as_path()));
    if !current(&stamp, &want, &files) {
        let _ = fs::remove_file(&stamp);
        fs::create_dir_all(d.join("update"))?;
        run_trainer(&fx.trainer, &["train", "--data", p(&fx.data), "--features", "paper", "--out", p(&update_model)])?;
        // In-envelope hold-out samples of the trainer's data (the golden ones carry no flag).
        let samples: Vec<Sample<f32>> = read_inputs(&d.join("golden_inputs.bin"))?.into_iter().take(64).collect();
        write_atomic(&trainer_inputs, &inputs_bytes(&samples))?;
        for (_, k, mem, _, path, _, _) in rows.iter().filter(|r| r.0 != "default") {
            write_atomic(path, &synthetic_blob(*k, 100 + *k as u64, *mem)?)?;
        }
        // In-envelope, unflagged samples of the synthetic installation on a regular 60 s clock
        // (the bench image continues the clock across its passes over them).
        let mut rng = Rng::new(21);
        let synthetic: Vec<Sample<f32>> = (0..64).map(|i| simulate(i, &mut rng)).collect();
        write_atomic(&synthetic_inputs, &inputs_bytes(&synthetic))?;
        for (cap, pack) in &bench_packs {
            let mut records: Vec<(Vec<u8>, Vec<Sample<f32>>)> = Vec::new();
            for r in rows.iter().filter(|r| r.3 == *cap) {
                records.push((fs::read(&r.4)?, read_inputs(&r.5)?));
            }
            let refs: Vec<(&[u8], &[Sample<f32>])> =
                records.iter().map(|(b, s)| (b.as_slice(), s.as_slice())).collect();
            write_atomic(pack, &pack_bytes(&refs))?;
        }
        write_atomic(&stamp, want.as_bytes())?;
    }
    let mut bench = Vec::new();
    for (name, _, _, capacity, model, _, source) in rows {
        let bytes = fs::read(&model)?;
        let k = decode(&bytes)?.centres.len();
        bench.push(BenchFixture { name, k, memory_terms: memory_terms(&bytes)?, capacity, model, source });
    }
    Ok(DeviceFixtures { update_model, k64_model, bench, bench_packs })
}

/// Write `bytes` to `path` through a temporary file and a rename (no half-written output).
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension(format!("{}.tmp", path.extension().and_then(|e| e.to_str()).unwrap_or("")));
    fs::write(&tmp, bytes).with_context(|| format!("writing {}", tmp.display()))?;
    fs::rename(&tmp, path).with_context(|| format!("renaming {} to {}", tmp.display(), path.display()))
}

// ---- deterministic random numbers ----------------------------------------------------------

/// SplitMix64: tiny, deterministic on every machine.
pub struct Rng(u64);

impl Rng {
    /// A generator for `seed`.
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Standard normal (Box-Muller).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }
}

// ---- the synthetic installation (the K = 64 bench model, which the trainer cannot make) -----

/// Nominal gauge matrix of DESIGN §3 (pm per °C, µε, kPa), rows FBG1..3.
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
fn simulate(i: usize, rng: &mut Rng) -> Sample<f32> {
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
    Sample { dl_pm: [dl[0] as f32, dl[1] as f32, dl[2] as f32], t_amb_c: t_amb as f32, t_s: (60.0 * x) as f32 }
}

/// Time stamps of a realistic acquisition [s] from `t0`: 60 s steps, with irregular ones mixed
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
    let mut rng = Rng::new(seed);
    let clock = irregular_clock(n, 3600.0);
    let mut out: Vec<Sample<f32>> = (0..n).map(|i| simulate(i, &mut rng)).collect();
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
        observer_row,
    }
}

/// A small Γ, non-zero on every term `spec` uses: per output unit `scale[o]`, 1e-3·scale per pm
/// (grating high-passes, stop terms), 1e-2·scale per °C (ambient high-passes), and 0.2 °C/°C
/// for the drift observer on T only (the trainer offers it to temperature outputs only).
pub fn small_gamma(spec: &MemorySpec<f64>, scale: [f64; N_OUTPUTS], seed: u64) -> [[f64; N_MEMORY]; N_OUTPUTS] {
    let mut rng = Rng::new(seed);
    let mut g = [[0.0; N_MEMORY]; N_OUTPUTS];
    for (o, row) in g.iter_mut().enumerate() {
        for (k, v) in row.iter_mut().enumerate() {
            let Some(term) = spec.term(k).filter(|t| t.parameter > 0.0) else { continue };
            let r = (0.5 + rng.uniform()) * if rng.uniform() < 0.5 { -1.0 } else { 1.0 };
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

/// A model blob with the full memory bank ([`full_memory_spec`] on its stage-1 T row, and
/// [`small_gamma`] scaled by its guess spread) in place of whatever memory it had: what the
/// device's memory is checked with when the trainer's model has none.
pub fn with_full_memory(blob_bytes: &[u8]) -> Result<Vec<u8>> {
    let p: ModelParams<f64, MAX_K> = decode(blob_bytes)?.convert().map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut p = p;
    p.memory = full_memory_spec(p.stage1[0]);
    p.gamma = small_gamma(&p.memory, p.guess_std, 5);
    encode_f64(&p)
}

fn encode_f64(p: &ModelParams<f64, MAX_K>) -> Result<Vec<u8>> {
    let p32: ModelParams<f32, MAX_K> = p.convert().map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut buf = vec![0u8; blob::max_len(MAX_K)];
    let n = blob::encode(&p32, &mut buf).map_err(|e| anyhow::anyhow!("encoding: {e}"))?;
    buf.truncate(n);
    Ok(buf)
}

/// A synthetic, valid K-centre hysteresis-aware model, deterministic in `seed`, with every
/// slot of the memory bank in use ([`full_memory_spec`], [`small_gamma`]); see
/// [`without_memory`] for the same model without.
pub fn synthetic_params(k: usize, seed: u64) -> Result<ModelParams<f64, MAX_K>> {
    check!(k <= MAX_K, "at most {MAX_K} centres");
    let mut rng = Rng::new(seed);
    let dead_band = 2.0;
    // A calibration run: centres are picked among its standardised inputs (as k-means++
    // would), so they sit where data is.
    let cal: Vec<Sample<f32>> = (0..2000).map(|i| simulate(i, &mut rng)).collect();
    let mut latches = LatchBank::new();
    let db_ticks = fbg_shared::direction_latch::ticks(dead_band);
    let zs: Vec<[f64; Z_DIMS]> = cal
        .iter()
        .map(|s| {
            let dl = [s.dl_pm[0] as f64, s.dl_pm[1] as f64, s.dl_pm[2] as f64];
            z_raw(s, latches.update(&dl, db_ticks))
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
    let fs = FeatureSet::HysteresisAware;
    let active = fs.active();

    let mut centres: heapless::Vec<Centre<f64>, MAX_K> = heapless::Vec::new();
    for j in 0..k {
        let src = &zs[(j * zs.len() / k.max(1) + 37) % zs.len()];
        let mut c = Centre::<f64>::default();
        for d in 0..Z_DIMS {
            if active[d] {
                c.mu[d] = ((src[d] - sc.mean[d]) / sc.std[d] + 0.1 * rng.normal()).clamp(-2.5, 2.5);
            }
        }
        c.w = [0.05 * rng.normal(), 2.0 * rng.normal(), 0.5 * rng.normal()];
        for v in c.v.iter_mut() {
            *v = rng.normal() / (k.max(1) as f64).sqrt();
        }
        if centres.push(c).is_err() {
            bail!("centre capacity");
        }
    }

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
    let mut envelope_lo = [0.0; 4];
    let mut envelope_hi = [0.0; 4];
    for d in 0..4 {
        let lo = zs.iter().map(|z| z[d]).fold(f64::INFINITY, f64::min);
        let hi = zs.iter().map(|z| z[d]).fold(f64::NEG_INFINITY, f64::max);
        let pad = margin * (hi - lo);
        envelope_lo[d] = lo - pad;
        envelope_hi[d] = hi + pad;
    }
    let var_inv_g = [0.8, 0.5, 0.3, 0.2];
    debug_assert_eq!(var_inv_g.len(), VAR_RANK);
    let params = ModelParams::<f64, MAX_K> {
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
        stage1,
        guess_mean: [T0, 0.0, P0],
        guess_std: Q_STD,
        poly,
        memory: MemorySpec::off(),
        gamma: [[0.0; N_MEMORY]; N_OUTPUTS],
        z_mean,
        z_std,
        centres,
        var_inv_g,
        var_inv_g_tail: 0.02,
        resid_var: [0.12f64.powi(2), 2.5f64.powi(2), 0.6f64.powi(2)],
        resid_var_growth: [0.0; 3],
        t_cal_end_s: 0.0,
        band_k: [1.959_964; 3],
        envelope_lo,
        envelope_hi,
        fitted: [true; 3],
        provenance: Provenance {
            seed,
            scenario: heapless::String::try_from("synthetic-fixture").unwrap_or_default(),
            trainer_version: heapless::String::try_from("xtask").unwrap_or_default(),
            date_yyyymmdd: 20260101,
            n_cal: cal.len() as u32,
        },
    };
    let mut params = params;
    // T_g = T0 + (row 0 of the inverse gauge matrix)·Δλ: the grating temperature.
    params.memory = full_memory_spec([inv[0][0], inv[0][1], inv[0][2], 0.0, T0]);
    params.gamma = small_gamma(&params.memory, Q_STD, seed ^ 0x6d65_6d6f);
    params.validate().map_err(|e| anyhow::anyhow!("synthetic model invalid: {e}"))?;
    Ok(params)
}

/// `p` without memory terms (spec off, Γ = 0).
pub fn without_memory(mut p: ModelParams<f64, MAX_K>) -> ModelParams<f64, MAX_K> {
    p.memory = MemorySpec::off();
    p.gamma = [[0.0; N_MEMORY]; N_OUTPUTS];
    p
}

/// [`synthetic_params`] (with the full memory bank when `memory`, else [`without_memory`])
/// encoded as a `.fbgm` blob.
pub fn synthetic_blob(k: usize, seed: u64, memory: bool) -> Result<Vec<u8>> {
    let p = synthetic_params(k, seed)?;
    encode_f64(&if memory { p } else { without_memory(p) })
}

/// Decode a blob (any K up to [`MAX_K`]) for the host reference.
pub fn decode(blob_bytes: &[u8]) -> Result<ModelParams<f32, MAX_K>> {
    blob::decode::<MAX_K>(blob_bytes).map_err(|e| anyhow::anyhow!("model blob: {e}"))
}

/// A fresh f64 host compensator of a blob.
pub fn host_compensator(blob_bytes: &[u8]) -> Result<Compensator<f64, MAX_K>> {
    Compensator::new(&decode(blob_bytes)?).map_err(|e| anyhow::anyhow!("{e}"))
}

/// The host f64 answers for `samples` on the model in `blob_bytes`.
pub fn reference(blob_bytes: &[u8], samples: &[Sample<f32>]) -> Result<Vec<Estimate<f64>>> {
    let mut c = host_compensator(blob_bytes)?;
    Ok(samples.iter().map(|s| c.step(&widen(s))).collect())
}

/// A device sample in f64.
pub fn widen(s: &Sample<f32>) -> Sample<f64> {
    Sample {
        dl_pm: [s.dl_pm[0] as f64, s.dl_pm[1] as f64, s.dl_pm[2] as f64],
        t_amb_c: s.t_amb_c as f64,
        t_s: s.t_s as f64,
    }
}

/// Per-channel comparison scale when no hold-out RMSE is known: the square root of the blob's
/// residual variance.
pub fn reference_scale(blob_bytes: &[u8]) -> Result<[f64; N_OUTPUTS]> {
    let p = decode(blob_bytes)?;
    Ok(p.resid_var.map(|v| (v as f64).sqrt()))
}

/// Golden inputs as raw little-endian f32 × 5.
pub fn inputs_bytes(samples: &[Sample<f32>]) -> Vec<u8> {
    let mut out = Vec::with_capacity(samples.len() * 20);
    for s in samples {
        for v in [s.dl_pm[0], s.dl_pm[1], s.dl_pm[2], s.t_amb_c, s.t_s] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out
}

/// Read golden inputs.
pub fn read_inputs(path: &Path) -> Result<Vec<Sample<f32>>> {
    let bytes = fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    check!(bytes.len() % 20 == 0, "{}: {} bytes is not a whole number of 5 × f32 samples", path.display(), bytes.len());
    Ok(bytes
        .chunks_exact(20)
        .map(|c| {
            let f = |i: usize| f32::from_le_bytes([c[4 * i], c[4 * i + 1], c[4 * i + 2], c[4 * i + 3]]);
            Sample { dl_pm: [f(0), f(1), f(2)], t_amb_c: f(3), t_s: f(4) }
        })
        .collect())
}

/// Header of the expected-results CSV.
pub const EXPECTED_HEADER: &str = "values_T,values_eps,values_p,band_T,band_eps,band_p,flags";

/// The expected-results CSV text.
pub fn expected_csv(rows: &[Estimate<f64>]) -> String {
    let mut s = String::from(EXPECTED_HEADER);
    s.push('\n');
    for e in rows {
        let v = e.values;
        let b = e.band95;
        let _ = writeln!(s, "{:?},{:?},{:?},{:?},{:?},{:?},{}", v[0], v[1], v[2], b[0], b[1], b[2], e.flags.0);
    }
    s
}

/// Read the expected-results CSV (the trainer's or ours).
pub fn read_expected(path: &Path) -> Result<Vec<Estimate<f64>>> {
    let text = fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut lines = text.lines();
    let header = lines.next().unwrap_or("");
    check!(
        header.trim() == EXPECTED_HEADER,
        "{}:1: header is `{header}`, expected `{EXPECTED_HEADER}`",
        path.display()
    );
    let mut out = Vec::new();
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cols: Vec<&str> = line.split(',').map(str::trim).collect();
        check!(cols.len() == 7, "{}:{}: expected 7 columns, found {}", path.display(), i + 2, cols.len());
        let mut f = [0.0f64; 6];
        for (k, (o, c)) in f.iter_mut().zip(cols.iter()).enumerate() {
            *o = parse_f64(c).with_context(|| format!("{}:{}: column {}", path.display(), i + 2, k + 1))?;
        }
        let flags: u8 = cols[6].parse().with_context(|| format!("{}:{}: column 7 (flags)", path.display(), i + 2))?;
        out.push(Estimate { values: [f[0], f[1], f[2]], band95: [f[3], f[4], f[5]], flags: Flags(flags) });
    }
    Ok(out)
}

fn parse_f64(s: &str) -> Result<f64> {
    match s.to_ascii_lowercase().as_str() {
        "nan" => Ok(f64::NAN),
        "inf" | "+inf" | "infinity" => Ok(f64::INFINITY),
        "-inf" | "-infinity" => Ok(f64::NEG_INFINITY),
        _ => s.parse::<f64>().with_context(|| format!("`{s}` is not a number")),
    }
}

/// Compare a device answer with the host reference: per channel |Δ| ≤ `tol` (NaN matches NaN,
/// ∞ matches ∞), flags identical. Returns a description of the first mismatch.
pub fn compare(
    dev_values: [f32; 3],
    dev_band: [f32; 3],
    dev_flags: Flags,
    want: &Estimate<f64>,
    tol: [f64; 3],
) -> Option<String> {
    if dev_flags != want.flags {
        return Some(format!("flags {} (device) vs {} (host)", dev_flags, want.flags));
    }
    let names = ["T", "eps", "p"];
    for c in 0..3 {
        for (what, d, h) in
            [("value", dev_values[c] as f64, want.values[c]), ("band", dev_band[c] as f64, want.band95[c])]
        {
            let ok = if h.is_nan() || d.is_nan() {
                h.is_nan() && d.is_nan()
            } else if h.is_infinite() || d.is_infinite() {
                h == d
            } else {
                (d - h).abs() <= tol[c]
            };
            if !ok {
                return Some(format!(
                    "{what} {}: device {d} vs host {h} (|Δ| {:e} > {:e})",
                    names[c],
                    (d - h).abs(),
                    tol[c]
                ));
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn synthetic_models_are_valid_deterministic_and_sized() {
        for k in [0, 16, 32, 64] {
            for mem in [false, true] {
                let a = synthetic_blob(k, 7, mem).unwrap();
                assert_eq!(a, synthetic_blob(k, 7, mem).unwrap());
                let p = decode(&a).unwrap();
                assert_eq!(p.centres.len(), k);
                assert_eq!(p.has_memory(), mem);
                assert_eq!(memory_terms(&a).unwrap(), if mem { N_MEMORY } else { 0 });
                assert!(a.len() <= blob::max_len(k));
            }
        }
        assert!(synthetic_blob(32, 1, true).unwrap().len() <= 4096, "blob target ≤ 4 KiB at K = 32");
    }

    #[test]
    fn golden_samples_exercise_every_flag_and_the_csv_round_trips() {
        let blob = synthetic_blob(32, 1, true).unwrap();
        let s = golden_samples(600, 11);
        let r = reference(&blob, &s).unwrap();
        let any = |f: Flags| r.iter().filter(|e| e.flags.contains(f)).count();
        assert_eq!(any(Flags::NON_FINITE), 1);
        assert!(any(Flags::OUT_OF_ENVELOPE) >= 10);
        assert!(any(Flags::WEAK_SUPPORT) >= 1);
        assert!(r.iter().filter(|e| e.flags.is_ok()).count() > 500);
        let dir = std::env::temp_dir().join(format!("fbg-fixtures-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let p = dir.join("e.csv");
        fs::write(&p, expected_csv(&r)).unwrap();
        let back = read_expected(&p).unwrap();
        assert_eq!(back.len(), r.len());
        for (a, b) in back.iter().zip(r.iter()) {
            assert!(compare(a.values.map(|v| v as f32), a.band95.map(|v| v as f32), a.flags, b, [1e-3; 3]).is_none());
        }
        let pi = dir.join("i.bin");
        fs::write(&pi, inputs_bytes(&s)).unwrap();
        let si = read_inputs(&pi).unwrap();
        assert_eq!(format!("{si:?}"), format!("{s:?}"));
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_memory_terms_move_the_answers_and_the_clock_is_irregular() {
        let with = synthetic_blob(32, 1, true).unwrap();
        let without = synthetic_blob(32, 1, false).unwrap();
        let s = golden_samples(600, 11);
        let a = reference(&with, &s).unwrap();
        let b = reference(&without, &s).unwrap();
        let moved = a.iter().zip(b.iter()).filter(|(x, y)| x.values[0].is_finite() && x.values != y.values).count();
        assert!(moved > 500, "{moved}");
        let dts: Vec<f32> = s.windows(2).map(|w| w[1].t_s - w[0].t_s).collect();
        for want in [0.0, 23.0, 60.0, 60.5, 131.0, 18000.0] {
            assert!(dts.contains(&want), "no step of {want} s");
        }
        let fm = with_full_memory(&without).unwrap();
        assert_eq!(memory_terms(&fm).unwrap(), N_MEMORY);
        let packed = pack_bytes(&[(&with, &s[..3])]);
        assert_eq!(packed.len(), 4 + with.len() + 4 + 60);
    }
}
