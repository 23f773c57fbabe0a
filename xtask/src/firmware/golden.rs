//! The golden vectors: the `golden` image compensates every golden set of the fixtures on the
//! emulated Cortex-M4F; each estimate is compared with the host's f64 answer.

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use fbg_link::parity::{abs_diff, compare, REL_TOL};
use fbg_shared::protocol::{DeviceMsg, Feed, FrameReader, DEVICE_MAX_FRAME};

use crate::firmware::emulator::{out_dir, Machine, Qemu};
use crate::firmware::Bins;
use crate::fixtures::{self, Fixtures};

/// Per-channel scale of the golden tolerance: Model-H's hold-out RMSE from the trainer's
/// `golden_meta.json` (`holdout_rmse_h`), else the square root of the blob's residual variance.
pub fn golden_scale(fx: &Fixtures, model: &[u8]) -> Result<(Vec<f64>, &'static str)> {
    if let Ok(text) = fs::read_to_string(&fx.golden_meta) {
        if let Some(v) = json_number_array(&text, "holdout_rmse_h") {
            ensure!(
                v.len() == 3 && v.iter().all(|x| x.is_finite() && *x > 0.0),
                "{}: holdout_rmse_h must be three positive numbers, found {v:?}",
                fx.golden_meta.display()
            );
            return Ok((v, "Model-H hold-out RMSE"));
        }
    }
    Ok((fixtures::reference_scale(model)?, "sqrt(resid_var)"))
}

/// Per-channel scale of the golden tolerance of a trained set: Model-H's hold-out RMSE from the
/// trainer's `golden_meta.json` beside it (`holdout_rmse_h`), which must be there, belong to
/// `model` (same centre count) and give one positive number per output of the model.
pub fn holdout_scale(meta: &Path, model: &[u8]) -> Result<Vec<f64>> {
    let text = fs::read_to_string(meta).with_context(|| format!("reading {}", meta.display()))?;
    let v: serde_json::Value = serde_json::from_str(&text).with_context(|| format!("{}: not JSON", meta.display()))?;
    let p = fixtures::decode(model)?;
    let centres = v["centres"].as_u64().with_context(|| format!("{}: no `centres`", meta.display()))?;
    ensure!(
        centres as usize == p.centres.len(),
        "{}: written for a model of {centres} centres, the set's model has {}",
        meta.display(),
        p.centres.len()
    );
    let rmse: Vec<f64> = v["holdout_rmse_h"]
        .as_array()
        .with_context(|| format!("{}: no `holdout_rmse_h` array", meta.display()))?
        .iter()
        .map(|x| x.as_f64().unwrap_or(f64::NAN))
        .collect();
    let m = p.dims.n_outputs();
    ensure!(
        rmse.len() == m && rmse.iter().all(|x| x.is_finite() && *x > 0.0),
        "{}: holdout_rmse_h must be {m} positive numbers (one per output of the model), found {rmse:?}",
        meta.display()
    );
    Ok(rmse)
}

/// The numbers of `"key": [a, b, ...]` in a JSON text (enough for the trainer's metadata).
fn json_number_array(text: &str, key: &str) -> Option<Vec<f64>> {
    let at = text.find(&format!("\"{key}\""))?;
    let rest = &text[at..];
    let open = rest.find('[')?;
    let close = rest[open..].find(']')? + open;
    rest[open + 1..close].split(',').map(|x| x.trim().parse::<f64>().ok()).collect()
}

/// All device messages in a byte stream.
pub fn parse_frames(bytes: &[u8]) -> (Vec<DeviceMsg>, usize) {
    let mut r = FrameReader::<DEVICE_MAX_FRAME>::new();
    let mut out = Vec::new();
    let mut bad = 0;
    let mut w = bytes;
    while !w.is_empty() {
        let (ev, rest) = r.feed::<DeviceMsg>(w);
        w = rest;
        match ev {
            Feed::Pending => {}
            Feed::Message(m) => out.push(m),
            Feed::Malformed(_) => bad += 1,
        }
    }
    (out, bad)
}

/// One golden set: its model, inputs, expected host answers, tolerance scale and its name.
struct GoldenSet {
    name: String,
    model: Vec<u8>,
    inputs: Vec<fbg_shared::Sample<f32>>,
    expected: Vec<fbg_shared::Estimate<f64>>,
    scale: Vec<f64>,
    scale_name: &'static str,
}

/// The golden sets in the order of the golden pack: the paper model, the synthetic memory
/// model, the random dims models, then the trained models of the other presets (every one of
/// [`fixtures::TRAINED_PRESETS`] must be there).
fn golden_sets(fx: &Fixtures) -> Result<Vec<GoldenSet>> {
    let model = fs::read(&fx.model)?;
    let (scale, scale_name) = golden_scale(fx, &model)?;
    let memory_model = fs::read(&fx.memory_model)?;
    let mut sets = vec![
        GoldenSet {
            name: "trainer's Model-H (hold-out and edge samples)".into(),
            inputs: fixtures::read_inputs(&fx.golden_inputs)?,
            expected: fixtures::read_expected(&fx.golden_expected)?,
            model,
            scale,
            scale_name,
        },
        GoldenSet {
            name: "synthetic K = 32 with the full memory bank (irregular clock, 5 h gap)".into(),
            inputs: fixtures::read_inputs(&fx.memory_inputs)?,
            expected: fixtures::read_expected(&fx.memory_expected)?,
            scale: fixtures::reference_scale(&memory_model)?,
            model: memory_model,
            scale_name: "the model's residual σ",
        },
    ];
    for (name, (model, inputs, expected)) in
        ["random 2 → 2 without ambient, K = 8, memory bank", "random 8 → 4 with ambient, K = 16, memory bank"]
            .into_iter()
            .zip(fx.dims_sets.iter())
    {
        let model = fs::read(model)?;
        sets.push(GoldenSet {
            name: name.into(),
            inputs: fixtures::read_inputs(inputs)?,
            expected: fixtures::read_expected(expected)?,
            scale: fixtures::reference_scale(&model)?,
            model,
            scale_name: "the model's residual σ",
        });
    }
    ensure!(
        fx.trained_sets.len() == fixtures::TRAINED_PRESETS.len()
            && fx.trained_sets.iter().zip(fixtures::TRAINED_PRESETS).all(|(s, t)| s.preset == t.preset),
        "the fixtures do not have a trained golden set for every preset of TRAINED_PRESETS"
    );
    for t in &fx.trained_sets {
        let model = fs::read(&t.model).with_context(|| format!("the trained golden set `{}` is missing", t.name))?;
        let p = fixtures::decode(&model)?;
        sets.push(GoldenSet {
            name: format!(
                "trainer's Model-H, {} preset ({}{} → {}, K = {}, {} memory terms; hold-out and edge samples)",
                t.preset,
                p.dims.gratings(),
                if p.dims.ambient() { " + ambient" } else { "" },
                p.dims.n_outputs(),
                p.centres.len(),
                fixtures::memory_terms(&model)?
            ),
            inputs: fixtures::read_inputs(&t.inputs)?,
            expected: fixtures::read_expected(&t.expected)?,
            scale: holdout_scale(&t.meta, &model)?,
            model,
            scale_name: "Model-H hold-out RMSE",
        });
    }
    for g in &sets {
        ensure!(
            g.inputs.len() == g.expected.len(),
            "golden set `{}`: {} inputs, {} expected rows",
            g.name,
            g.inputs.len(),
            g.expected.len()
        );
        let m = fixtures::decode(&g.model)?.dims.n_outputs();
        ensure!(
            g.scale.len() == m && g.expected.iter().all(|e| usize::from(e.outputs) == m),
            "golden set `{}`: the model has {m} outputs; {} tolerance scales, expected rows of other widths",
            g.name,
            g.scale.len()
        );
    }
    // The pack the golden image embeds must hold exactly these sets, in this order.
    let pack = fs::read(&fx.golden_pack).with_context(|| format!("reading {}", fx.golden_pack.display()))?;
    let records: Vec<_> = fbg_shared::golden::records(&pack).collect();
    ensure!(
        records.len() == sets.len(),
        "{} holds {} golden sets, the test has {}",
        fx.golden_pack.display(),
        records.len(),
        sets.len()
    );
    for (i, (r, g)) in records.iter().zip(&sets).enumerate() {
        let r = r.as_ref().with_context(|| format!("{}: record {i} is malformed", fx.golden_pack.display()))?;
        // Bytes, not samples: NaN inputs compare unequal to themselves.
        ensure!(
            r.blob == g.model.as_slice() && r.samples == fbg_link::golden::inputs_bytes(&g.inputs).as_slice(),
            "{}: record {i} is not golden set `{}` (its model or samples differ)",
            fx.golden_pack.display(),
            g.name
        );
    }
    Ok(sets)
}

pub(crate) fn golden_test(root: &Path, qemu: &Path, bins: &Bins, fx: &Fixtures) -> Result<()> {
    run_golden(root, qemu, Machine::Mps2An386, &bins.golden, "golden", fx).map(|_| ())
}

/// What a golden run compared.
#[derive(Clone, Copy, Debug)]
pub struct GoldenRun {
    /// Golden sets (models) the image ran.
    pub sets: usize,
    /// Estimates compared with the host's, all within tolerance.
    pub samples: usize,
    /// Of them, estimates the device flagged (flags identical to the host's).
    pub flagged: usize,
    /// Wall time of the emulator run \[s\].
    pub run_secs: f64,
}

/// Run the golden image `elf` (any image that sends the golden pack's estimates on serial0 and
/// exits through semihosting) on `machine`, and compare every estimate with the host's f64
/// answer; `name` names its outputs in `target/qemu/`.
pub fn run_golden(
    root: &Path,
    qemu: &Path,
    machine: Machine,
    elf: &Path,
    name: &str,
    fx: &Fixtures,
) -> Result<GoldenRun> {
    let dir = out_dir(root)?;
    let uart = dir.join(format!("{name}.uart"));
    let _ = fs::remove_file(&uart);
    let log = dir.join(format!("{name}.defmt"));
    let started = Instant::now();
    let mut q = Qemu::start_on(machine, qemu, elf, &format!("file:{}", uart.display()), &log, &[])?;
    let status = q.wait(Duration::from_secs(120))?;
    let run_secs = started.elapsed().as_secs_f64();
    if !status.success() {
        q.show_log();
        bail!("golden image failed with {status}");
    }
    let sets = golden_sets(fx)?;
    let total: usize = sets.iter().map(|g| g.inputs.len()).sum();
    let (msgs, bad) = parse_frames(&fs::read(&uart)?);
    ensure!(bad == 0, "{bad} malformed frames in the golden output {}", uart.display());
    ensure!(msgs.len() == total, "device sent {} estimates for {total} samples", msgs.len());
    eprintln!(
        "xtask: {name} ({machine:?}): {} sets, {total} samples compensated by the device in {run_secs:.1} s",
        sets.len()
    );
    let mut failures = Vec::new();
    let mut flagged_total = 0;
    let mut at = 0usize;
    for g in &sets {
        let tol: Vec<f64> = g.scale.iter().map(|s| REL_TOL * s).collect();
        let m = g.scale.len();
        let mut flagged = 0;
        let mut worst = [0.0f64; fbg_shared::layout::MAX_OUTPUTS];
        for (j, want) in g.expected.iter().enumerate() {
            let i = at + j;
            let DeviceMsg::Estimate(e) = &msgs[i] else { bail!("message {i} is {:?}, not an estimate", msgs[i]) };
            ensure!(e.seq == i as u32, "estimate {i} carries seq {}", e.seq);
            if !e.flags.is_ok() {
                flagged += 1;
            }
            if let Err(why) = compare(e, want, &tol) {
                failures.push(format!("{}: sample {j}: {why}", g.name));
            }
            for (w, d) in worst.iter_mut().zip(abs_diff(&e.values, &want.values)) {
                *w = w.max(d);
            }
        }
        let abs: Vec<String> = worst.iter().take(m).map(|w| format!("{w:.3e}")).collect();
        let rel: Vec<String> = worst.iter().zip(&g.scale).map(|(w, s)| format!("{:.4} %", 100.0 * w / s)).collect();
        eprintln!(
            "xtask: {name}, {}: {} samples ({flagged} flagged, flags identical); max |device − host| per output = {} \
             ({} of {}; limit {} %)",
            g.name,
            g.inputs.len(),
            abs.join(", "),
            rel.join(", "),
            g.scale_name,
            100.0 * REL_TOL
        );
        at += g.inputs.len();
        flagged_total += flagged;
    }
    if !failures.is_empty() {
        let n = failures.len();
        failures.truncate(10);
        bail!("{n} golden samples differ beyond tolerance:\n  {}", failures.join("\n  "));
    }
    Ok(GoldenRun { sets: sets.len(), samples: total, flagged: flagged_total, run_secs })
}
