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
//!   golden set, the synthetic K = 32 model of the test kit's installation with every slot of
//!   the memory bank in use (`fbg_testkit::installation::synthetic_params`) on its
//!   `golden_samples` (an irregular clock with a 5 h gap, flags);
//! - the random models of other dims (`dims_2x2`, `dims_8x4`: [`DIMS_MODELS`]) with their
//!   samples and host answers;
//! - `preset-<name>/` for every preset of [`TRAINED_PRESETS`] (`strain-pair`, `temperature-1`,
//!   `array-8`): the same chain as the paper set on that preset's record (`fbg-trainer simulate
//!   --preset P --seed 7`, `train`, `golden`), i.e. a genuine trained Model-H of the preset's
//!   dims, its `device_golden_inputs.bin` / `device_golden_expected.csv` (the trainer's hold-out
//!   samples plus [`edge_samples`], cross-checked against the trainer's answers like the paper
//!   set) and the trainer's `golden_meta.json` (that model's hold-out RMSE: its tolerance scale);
//! - `golden_pack.bin`: every set as the golden image embeds them (`fbg_link::golden::pack_bytes`),
//!   in the order of [`Fixtures`]' fields (paper, synthetic memory, dims, trained sets).
//!
//! [`ensure_device`] adds the models of the link test and the bench: `update/model.fbgm`
//! (`train --features paper`, a second valid model with another feature set), the synthetic
//! models of the test kit's installation with and without the memory
//! bank at K = 0, 16, 32 and 64 (the trainer's grid stops at 32 centres; the 64-centre one is
//! also the model a K = 32 build must refuse), and the bench packs (`bench_pack_k32.bin`,
//! `bench_pack_k64.bin`: every model a bench image of that capacity runs, with its samples;
//! the K = 32 pack also has the trained models of [`TRAINED_PRESETS`] on their first 48
//! hold-out samples).
//!
//! Everything is regenerated when the trainer binary's content changes (a stamp in the
//! directory), so repeated calls cost one `cargo build` check and a hash of the binary.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};

use anyhow::{ensure as check, Context, Result};
use fbg_link::golden::{expected_csv, inputs_bytes, pack_bytes};
use fbg_shared::{ModelParams, Sample};
pub use fbg_testkit::installation::MAX_K;
use fbg_testkit::installation::{golden_samples, synthetic_blob};

use crate::cmd::{self, write_atomic};
use crate::targets::{PRODUCT_K, TARGET_BLOB};

mod device;
mod host;

pub use device::{ensure_device, BenchFixture, DeviceFixtures};
pub use host::{decode, host_compensator, memory_terms, read_expected, read_inputs, reference, reference_scale};

/// Seed of the simulated dataset (the paper preset).
pub const SEED: u64 = 7;
/// Golden samples the trainer exports.
pub const GOLDEN_SAMPLES: usize = 600;
/// Samples of the synthetic memory golden set (≈ 30 h at 60 s: several of the longest τ, 4 h).
pub const MEMORY_GOLDEN_SAMPLES: usize = 1500;
/// Bump to regenerate the fixtures when this file changes what it writes.
const FIXTURES_VERSION: u32 = 10;

/// A preset besides `paper` whose trained Model-H the golden image runs (and the K = 32 bench
/// image times): simulated with seed [`SEED`] and trained with the trainer's defaults, like the
/// paper model.
#[derive(Clone, Copy, Debug)]
pub struct TrainedPreset {
    /// Set name (directory `preset-<name>`, bench row).
    pub name: &'static str,
    /// The `--preset` of `fbg-trainer simulate`.
    pub preset: &'static str,
    /// Hold-out samples the trainer exports (the edge samples come on top). Kept small: the
    /// golden pack is in the flash of the golden and bench images (256 KiB each), 44 B per
    /// sample.
    pub samples: usize,
    /// Where the model comes from (bench rows).
    pub source: &'static str,
}

/// The trained golden sets besides the paper one: a strain grating with its temperature
/// reference (2 gratings + ambient → T, ε), one temperature grating (1 + ambient → T) and the
/// eight-grating array (8 + ambient → T, ε, ε2, p).
pub const TRAINED_PRESETS: [TrainedPreset; 3] = [
    TrainedPreset {
        name: "strain_pair",
        preset: "strain-pair",
        samples: 600,
        source: "fbg-trainer train (strain-pair preset, seed 7): 2 gratings + ambient → T, ε",
    },
    TrainedPreset {
        name: "temperature_1",
        preset: "temperature-1",
        samples: 300,
        source: "fbg-trainer train (temperature-1 preset, seed 7): 1 grating + ambient → T",
    },
    TrainedPreset {
        name: "array_8",
        preset: "array-8",
        samples: 300,
        source: "fbg-trainer train (array-8 preset, seed 7): 8 gratings + ambient → T, ε, ε2, p",
    },
];

/// The files of one golden set made by the trainer on a preset's record.
#[derive(Clone, Debug)]
pub struct TrainedSet {
    /// Set name (`strain_pair`, …; the paper set is `paper`).
    pub name: &'static str,
    /// The trainer's `--preset`.
    pub preset: &'static str,
    /// The simulated record (seed 7).
    pub data: PathBuf,
    /// Model-H trained on it.
    pub model: PathBuf,
    /// Golden inputs of the device run: the trainer's hold-out samples, then [`edge_samples`].
    pub inputs: PathBuf,
    /// Host f64 results for them (CSV).
    pub expected: PathBuf,
    /// The trainer's `golden_meta.json` (Model-H's hold-out RMSE per measurand).
    pub meta: PathBuf,
}

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
    /// The golden sets of other dims (model, inputs, expected): a random 2 → 2 model without
    /// ambient and a random 8 → 4 one (`fbg_testkit::models`), each with the memory bank.
    pub dims_sets: [(PathBuf, PathBuf, PathBuf); 2],
    /// The trained models of the other presets ([`TRAINED_PRESETS`], in that order).
    pub trained_sets: Vec<TrainedSet>,
    /// Every golden set as the golden image embeds them: the paper model, the synthetic
    /// memory model, the dims models, then the trained sets.
    pub golden_pack: PathBuf,
}

/// The random models of other dims the golden and bench images run: (name, gratings, ambient,
/// measurands, centres, seed).
pub const DIMS_MODELS: [(&str, usize, bool, usize, usize, u64); 2] =
    [("dims_2x2", 2, false, 2, 8, 22), ("dims_8x4", 8, true, 4, 16, 84)];

/// The random model of `DIMS_MODELS[i]` (hysteresis-aware features, every memory slot its dims
/// have) as a blob, and its samples: `n` on a 60-s clock, then out-of-envelope, NaN and ∞ ones
/// when `edges`.
pub fn dims_model(i: usize, n: usize, edges: bool) -> Result<(Vec<u8>, Vec<Sample<f32>>)> {
    use fbg_testkit::models::{dims, full_memory_spec_for, memory_model_dims, random_samples, short_provenance};
    let (_, g, amb, m, k, seed) = DIMS_MODELS.get(i).copied().context("no such dims model")?;
    let d = dims(g, amb, m).map_err(|e| anyhow::anyhow!("{e}"))?;
    let p: ModelParams<f32, MAX_K> = memory_model_dims(
        d,
        k,
        seed,
        fbg_shared::FeatureSet::HysteresisAware,
        short_provenance(),
        full_memory_spec_for(&d),
    );
    // Random centres in up to 17 dimensions rarely support a random sample: a low threshold
    // keeps most samples unflagged, so the device's ordinary path is what the set checks.
    let mut p = p;
    p.hyper.weak_support = 1e-12;
    let blob = fbg_testkit::models::encode_vec(&p).map_err(|e| anyhow::anyhow!("{e}"))?;
    let mut s = random_samples(&d, n, seed);
    if !edges {
        s.truncate(n);
    }
    Ok((blob, s))
}

/// Directory of the fixtures.
pub fn dir(root: &Path) -> PathBuf {
    root.join("target").join("fixtures")
}

/// Every golden set as the golden image embeds them ([`Fixtures::golden_pack`]).
pub fn golden_pack(root: &Path) -> PathBuf {
    dir(root).join("golden_pack.bin")
}

/// Set once `cargo test --workspace --release` has built the trainer binary in this run.
static BUILT_BY_TESTS: AtomicBool = AtomicBool::new(false);

/// The host tests' build has just made the trainer binary (`cargo xtask test`): use that one.
/// `cargo build -p fbg-trainer` alone resolves its dependencies' features without the
/// workspace's dev-dependencies (criterion turns more on), so it would compile the trainer and
/// the crates under it a second time and replace the binary the tests ran.
pub fn trainer_built_by_tests() {
    BUILT_BY_TESTS.store(true, Ordering::Relaxed);
}

/// Whether the host tests' build made the trainer in this run (with clippy, `cmd::with_clippy`).
pub fn built_by_tests() -> bool {
    BUILT_BY_TESTS.load(Ordering::Relaxed)
}

/// Build the trainer (release), unless the host tests' build has made it, and return its
/// binary.
pub fn trainer(root: &Path) -> Result<PathBuf> {
    if !built_by_tests() {
        cmd::run(cmd::cargo().current_dir(root).args(["build", "--release", "--locked", "-p", "fbg-trainer"]))
            .context("building fbg-trainer (it makes the firmware's fixtures)")?;
    }
    let bin = cmd::target_dir().join("release").join(format!("fbg-trainer{}", std::env::consts::EXE_SUFFIX));
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
    cmd::run(&mut cmd)
}

/// What the fixtures were made with: a hash of the trainer binary's content (a rebuild that
/// yields the same binary keeps them) and this file's version. Equal stamps mean the files are
/// current.
fn stamp_of(bin: &Path) -> Result<String> {
    let hash = cmd::content_hash(&[bin.to_path_buf()])?;
    Ok(format!("fixtures v{FIXTURES_VERSION}; trainer {hash:016x}\n"))
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
        dims_sets: [0, 1].map(|i| {
            let n = DIMS_MODELS[i].0;
            (d.join(format!("{n}.fbgm")), d.join(format!("{n}_inputs.bin")), d.join(format!("{n}_expected.csv")))
        }),
        trained_sets: TRAINED_PRESETS
            .iter()
            .map(|t| {
                let sd = d.join(format!("preset-{}", t.name));
                TrainedSet {
                    name: t.name,
                    preset: t.preset,
                    data: sd.join("data.csv"),
                    model: sd.join("model.fbgm"),
                    inputs: sd.join("device_golden_inputs.bin"),
                    expected: sd.join("device_golden_expected.csv"),
                    meta: sd.join("golden_meta.json"),
                }
            })
            .collect(),
        golden_pack: golden_pack(root),
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
        &fx.dims_sets[0].0,
        &fx.dims_sets[1].2,
    ];
    let mut files: Vec<&Path> = files.map(PathBuf::as_path).to_vec();
    for t in &fx.trained_sets {
        files.extend([t.data.as_path(), &t.model, &t.inputs, &t.expected, &t.meta]);
    }
    if current(&stamp, &want, &files) {
        return Ok(fx);
    }
    cmd::step("fixtures (simulate, train and export golden vectors with fbg-trainer)");
    let _ = fs::remove_file(&stamp);
    let paper = TrainedSet {
        name: "paper",
        preset: "paper",
        data: fx.data.clone(),
        model: fx.model.clone(),
        inputs: fx.golden_inputs.clone(),
        expected: fx.golden_expected.clone(),
        meta: fx.golden_meta.clone(),
    };
    // The paper set with the trainer's default scenario (no `--preset`: the product's model).
    let (model, inputs) = make_trained(&bin, &paper, GOLDEN_SAMPLES, false)?;
    let mut trained_records = Vec::new();
    for (set, t) in fx.trained_sets.iter().zip(TRAINED_PRESETS) {
        trained_records.push(make_trained(&bin, set, t.samples, true)?);
    }

    // The second set: every operator of the memory bank, an irregular clock and a gap.
    let memory_model = synthetic_blob(32, 1, true)?;
    let memory_inputs = golden_samples(MEMORY_GOLDEN_SAMPLES, 11);
    let memory_expected = reference(&memory_model, &memory_inputs)?;
    write_atomic(&fx.memory_model, &memory_model)?;
    write_atomic(&fx.memory_inputs, &inputs_bytes(&memory_inputs))?;
    write_atomic(&fx.memory_expected, expected_csv(&memory_expected).as_bytes())?;
    // Other dims: a random 2 → 2 model without ambient and a random 8 → 4 one.
    let mut dims_records = Vec::new();
    for (i, (m_path, i_path, e_path)) in fx.dims_sets.iter().enumerate() {
        let (blob_bytes, samples) = dims_model(i, 300, true)?;
        write_atomic(m_path, &blob_bytes)?;
        write_atomic(i_path, &inputs_bytes(&samples))?;
        write_atomic(e_path, expected_csv(&reference(&blob_bytes, &samples)?).as_bytes())?;
        dims_records.push((blob_bytes, samples));
    }
    let mut records: Vec<(&[u8], &[Sample<f32>])> = vec![(&model, &inputs), (&memory_model, &memory_inputs)];
    records.extend(dims_records.iter().map(|(b, s)| (b.as_slice(), s.as_slice())));
    records.extend(trained_records.iter().map(|(b, s)| (b.as_slice(), s.as_slice())));
    write_atomic(&fx.golden_pack, &pack_bytes(&records))?;
    write_atomic(&stamp, want.as_bytes())?;
    Ok(fx)
}

/// The chain of one trained golden set in the directory of `set.meta`: `fbg-trainer simulate`
/// (seed [`SEED`]; `--preset set.preset` when `with_preset`, else the trainer's default, the
/// paper preset), `train` (its defaults), `golden --samples n`; then the device inputs (the
/// trainer's samples followed by [`edge_samples`]) and xtask's host answers for them, whose
/// first `n` rows must equal the trainer's. Returns the blob and the device inputs.
fn make_trained(bin: &Path, set: &TrainedSet, n: usize, with_preset: bool) -> Result<(Vec<u8>, Vec<Sample<f32>>)> {
    let what = format!("golden set `{}` (preset {})", set.name, set.preset);
    let dir = set.meta.parent().with_context(|| format!("{what}: {} has no directory", set.meta.display()))?;
    fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let seed = SEED.to_string();
    let mut simulate = vec!["simulate", "--seed", &seed, "--out", p(&set.data)];
    if with_preset {
        simulate.extend(["--preset", set.preset]);
    }
    let samples = n.to_string();
    (|| {
        run_trainer(bin, &simulate)?;
        run_trainer(bin, &["train", "--data", p(&set.data), "--out", p(&set.model)])?;
        run_trainer(
            bin,
            &["golden", "--data", p(&set.data), "--model", p(&set.model), "--out", p(dir), "--samples", &samples],
        )
    })()
    .with_context(|| format!("making {what} with fbg-trainer"))?;
    let model = fs::read(&set.model).with_context(|| format!("reading {}", set.model.display()))?;
    let params = decode(&model).with_context(|| what.clone())?;
    check!(
        params.centres.len() <= PRODUCT_K && model.len() <= TARGET_BLOB as usize,
        "{what}: the trainer's Model-H has {} centres and {} B; the product holds {} centres and a {} B blob",
        params.centres.len(),
        model.len(),
        PRODUCT_K,
        TARGET_BLOB
    );

    // The device run: the trainer's samples, then the edge cases, streamed in one go.
    let trainer_inputs = read_inputs(&dir.join("golden_inputs.bin"))?;
    let trainer_expected = read_expected(&dir.join("golden_expected.csv"))?;
    check!(
        trainer_inputs.len() == n && trainer_expected.len() == n,
        "{what}: the trainer wrote {} golden inputs and {} expected rows, {n} were asked for",
        trainer_inputs.len(),
        trainer_expected.len()
    );
    let mut inputs = trainer_inputs.clone();
    inputs.extend(edge_samples(&params, &trainer_inputs));
    let expected = reference(&model, &inputs)?;
    // Our host reference must reproduce the trainer's (same code, same f64 model).
    for (i, (a, b)) in expected.iter().zip(trainer_expected.iter()).enumerate() {
        let same = |x: f64, y: f64| (x.is_nan() && y.is_nan()) || x == y || (x - y).abs() <= 1e-9 * y.abs().max(1e-9);
        let m = usize::from(b.outputs).min(fbg_shared::layout::MAX_OUTPUTS);
        check!(
            a.flags == b.flags
                && a.outputs == b.outputs
                && (0..m).all(|c| same(a.values[c], b.values[c]) && same(a.band95[c], b.band95[c])),
            "{what}: golden row {}: xtask's host reference {a:?} differs from the trainer's {b:?}",
            i + 2
        );
    }
    write_atomic(&set.inputs, &inputs_bytes(&inputs))?;
    write_atomic(&set.expected, expected_csv(&expected).as_bytes())?;
    Ok((model, inputs))
}

/// Samples the hold-out does not contain, to run the device's flag paths against the host's:
/// a stretch far outside the Δλ1 envelope (out of envelope, and weak support), T_amb beyond the
/// envelope, a NaN and an infinite input, then ordinary samples again (from `base`). For any
/// dims: the NaN goes to Δλ2 (Δλ1 with one grating); without an ambient input the last
/// grating leaves its envelope instead of T_amb, and Δλ1 is the infinite input.
pub fn edge_samples(p: &ModelParams<f32, MAX_K>, base: &[Sample<f32>]) -> Vec<Sample<f32>> {
    let mut out = Vec::new();
    let g = p.dims.gratings().clamp(1, fbg_shared::layout::MAX_GRATINGS);
    let ambient = p.dims.ambient();
    let pick = |i: usize| base.get(i % base.len().max(1)).copied().unwrap_or_default();
    let span = |d: usize| p.envelope_hi[d] - p.envelope_lo[d];
    for i in 0..10 {
        let mut s = pick(i);
        s.dl_pm[0] = p.envelope_hi[0] + 3.0 * span(0);
        out.push(s);
    }
    // The envelope is [Δλ_1..N, T_amb (with ambient)].
    for i in 10..12 {
        let mut s = pick(i);
        if ambient {
            s.t_amb_c = p.envelope_hi[g] + 0.5 * span(g) + 5.0;
        } else {
            s.dl_pm[g - 1] = p.envelope_hi[g - 1] + 0.5 * span(g - 1) + 5.0;
        }
        out.push(s);
    }
    let mut s = pick(12);
    s.dl_pm[1.min(g - 1)] = f32::NAN;
    out.push(s);
    let mut s = pick(13);
    if ambient {
        s.t_amb_c = f32::INFINITY;
    } else {
        s.dl_pm[0] = f32::INFINITY;
    }
    out.push(s);
    out.extend((20..40).map(pick));
    out
}

#[cfg(test)]
mod tests;
