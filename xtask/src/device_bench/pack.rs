//! One bench image (one capacity, its models embedded as a pack) under `qemu-system-arm -icount
//! shift=0`: build, run, and the instructions per step of each model from its output.

use std::collections::HashMap;
use std::fs;
use std::path::Path;
use std::time::Duration;

use anyhow::{bail, ensure, Context, Result};

use super::ops::step_ops_of;
use super::{SpectrumBench, StepBench, TypeSizes, VerifyBench};
use crate::cmd::step;
use crate::firmware::emulator::{out_dir, Qemu};
use crate::firmware::{self};
use crate::fixtures::{self, BenchFixture};
use crate::signing;

fn parse_kv(line: &str) -> HashMap<String, String> {
    line.split_whitespace().filter_map(|w| w.split_once('=')).map(|(k, v)| (k.to_string(), v.to_string())).collect()
}

fn num(m: &HashMap<String, String>, key: &str) -> Result<f64> {
    m.get(key)
        .with_context(|| format!("bench output lacks `{key}`"))?
        .parse::<f64>()
        .with_context(|| format!("bench `{key}`"))
}

/// What the bench image printed.
#[derive(Default)]
struct Output {
    /// (instructions, ticks) of the calibration loop.
    calib: Option<(f64, f64)>,
    /// (idx, mode) -> [(n, empty_ticks, step_ticks, empty_cycles, step_cycles)]
    runs: HashMap<(usize, String), Vec<[f64; 5]>>,
    /// Centres of each model as the image loaded it.
    centres: HashMap<usize, usize>,
    stack_peak: u32,
    /// (signed model bytes, ticks, stack peak) of the signature check.
    verify: Option<(u64, f64, u32)>,
    sizes: Option<TypeSizes>,
    /// [n, empty_ticks, frame_ticks, 0, 0] of the spectrum bench's runs.
    spectrum: Vec<[f64; 5]>,
    /// The same for each part of a frame's cost (`spectrum_part what=…`).
    spectrum_parts: HashMap<String, Vec<[f64; 5]>>,
}

fn parse_output(text: &str) -> Result<Output> {
    let mut o = Output::default();
    for line in text.lines() {
        let kv = parse_kv(line);
        if line.starts_with("calib ") {
            o.calib = Some((num(&kv, "insns")?, num(&kv, "ticks")?));
        } else if line.starts_with("run ") {
            let idx = num(&kv, "idx")? as usize;
            let mode = kv.get("mode").cloned().unwrap_or_default();
            o.runs.entry((idx, mode)).or_default().push([
                num(&kv, "n")?,
                num(&kv, "empty_ticks")?,
                num(&kv, "step_ticks")?,
                num(&kv, "empty_cycles")?,
                num(&kv, "step_cycles")?,
            ]);
        } else if line.starts_with("verify ") {
            ensure!(num(&kv, "ok")? == 1.0, "the bench image's signed model did not pass the signature check: {line}");
            o.verify = Some((num(&kv, "bytes")? as u64, num(&kv, "ticks")?, num(&kv, "stack_peak")? as u32));
        } else if line.starts_with("spectrum ") {
            ensure!(
                num(&kv, "readings")? == num(&kv, "n")?,
                "the spectrum bench's frames did not all make a reading: {line}"
            );
            o.spectrum.push([num(&kv, "n")?, num(&kv, "empty_ticks")?, num(&kv, "frame_ticks")?, 0.0, 0.0]);
        } else if line.starts_with("spectrum_part ") {
            let what = kv.get("what").cloned().unwrap_or_default();
            o.spectrum_parts.entry(what).or_default().push([
                num(&kv, "n")?,
                num(&kv, "empty_ticks")?,
                num(&kv, "ticks")?,
                0.0,
                0.0,
            ]);
        } else if line.starts_with("stack ") {
            o.stack_peak = num(&kv, "peak")? as u32;
        } else if line.starts_with("model ") {
            o.centres.insert(num(&kv, "idx")? as usize, num(&kv, "centres")? as usize);
        } else if line.starts_with("sizes ") {
            o.sizes = Some(TypeSizes {
                k: num(&kv, "k")? as usize,
                memory_state: num(&kv, "memory_state")? as u64,
                stream_state: num(&kv, "stream_state")? as u64,
                memory_bank: num(&kv, "memory_bank")? as u64,
                compensator: num(&kv, "compensator")? as u64,
                model_params: num(&kv, "model_params")? as u64,
                reader: num(&kv, "reader")? as u64,
                staging: num(&kv, "staging")? as u64,
            });
        }
    }
    Ok(o)
}

/// Per-step cost from two runs: (per-run values, per-step instructions, DWT cycles per step).
type Cost = (Vec<(u32, f64)>, f64, f64);

/// The cost of a step from the runs of n1 and n2 steps at `ipt` instructions per tick: the
/// difference between the runs (fixed costs cancel), each run's own estimate within 2 %.
fn cost(r: &[[f64; 5]], ipt: f64) -> Result<Cost> {
    ensure!(r.len() == 2, "expected two runs, got {}", r.len());
    let [n1, e1, s1, ec1, sc1] = r[0];
    let [n2, e2, s2, ec2, sc2] = r[1];
    let per_run = vec![(n1 as u32, (s1 - e1) * ipt / n1), (n2 as u32, (s2 - e2) * ipt / n2)];
    let per_step = ((s2 - e2) - (s1 - e1)) * ipt / (n2 - n1);
    let spread = (per_run[0].1 - per_run[1].1).abs() / per_run[1].1;
    ensure!(
        spread < 0.02,
        "per-step cost is not linear in the step count: {:.1} vs {:.1} instructions",
        per_run[0].1,
        per_run[1].1
    );
    Ok((per_run, per_step, ((sc2 - ec2) - (sc1 - ec1)) / (n2 - n1)))
}

/// Build the bench image of `capacity` with `pack` embedded and spectrum frames, run it under QEMU -icount and
/// return what it printed.
fn build_and_run(root: &Path, q: &Path, capacity: usize, pack: &Path) -> Result<String> {
    let k = capacity;
    // With spectrum frames, so that the image also times them.
    let elf = firmware::build_spectrum(root, k, Some(pack), &["bench"])?.join("bench");
    let dir = out_dir(root)?;
    let uart = dir.join(format!("bench_k{k}.txt"));
    let _ = fs::remove_file(&uart);
    let mut run = Qemu::start(
        q,
        &elf,
        &format!("file:{}", uart.display()),
        &dir.join(format!("bench_k{k}.defmt")),
        &["-icount", "shift=0"],
    )?;
    let st = run.wait(Duration::from_secs(600))?;
    let text = fs::read_to_string(&uart).unwrap_or_default();
    if !st.success() || !text.lines().any(|l| l.trim() == "done") {
        run.show_log();
        bail!("bench image failed ({st}); output:\n{text}");
    }
    Ok(text)
}

/// The step bench of every model of `capacity`; the type sizes and the signature check the
/// image reports go to `sizes` and `verify`.
pub(super) fn bench_pack(
    root: &Path,
    q: &Path,
    capacity: usize,
    sizes: &mut Option<TypeSizes>,
    verify: &mut Option<VerifyBench>,
    spectrum: &mut Option<SpectrumBench>,
) -> Result<Vec<StepBench>> {
    step(&format!("bench: instructions per step, capacity {capacity} (QEMU -icount shift=0)"));
    let fx = fixtures::ensure(root)?;
    let d = fixtures::ensure_device(root)?;
    let rows: Vec<&BenchFixture> = d.bench.iter().filter(|b| b.capacity == capacity).collect();
    let pack = &d
        .bench_packs
        .iter()
        .find(|(c, _)| *c == capacity)
        .with_context(|| format!("no bench pack for capacity {capacity}"))?
        .1;
    for b in &rows {
        eprintln!("xtask: {} (K = {}, {} memory terms): {}", b.name, b.k, b.memory_terms, b.source);
    }
    signing::bench_signed(root, &fx)?;
    let out = parse_output(&build_and_run(root, q, capacity, pack)?)?;
    if out.sizes.is_some() {
        *sizes = out.sizes.clone();
    }
    let (ci, ct) = out.calib.context("no calibration line")?;
    ensure!(ct > 0.0, "SysTick did not count during calibration (is -icount on?)");
    let ipt = ci / ct;
    // The line carries ticks: instructions through the same calibration as the steps.
    if let Some((bytes, ticks, stack_peak)) = out.verify {
        *verify = Some(VerifyBench { bytes, instructions: ticks * ipt, stack_peak });
    }
    if !out.spectrum.is_empty() {
        let (per_run, insns_per_frame, _) = cost(&out.spectrum, ipt).context("spectrum bench")?;
        let part = |what: &str| -> Result<f64> {
            let runs = out.spectrum_parts.get(what).with_context(|| format!("no spectrum part `{what}`"))?;
            Ok(cost(runs, ipt).with_context(|| what.to_string())?.1)
        };
        *spectrum = Some(SpectrumBench {
            insns_per_frame,
            per_run,
            ingest_per_frame: part("ingest")?,
            window_maximum: part("window_maximum")?,
            window_cross_correlation: part("window_cross_correlation")?,
        });
    }
    let mut steps = Vec::new();
    for (idx, b) in rows.iter().enumerate() {
        let got =
            out.centres.get(&idx).copied().with_context(|| format!("the bench ran no model {idx} ({})", b.name))?;
        ensure!(got == b.k, "bench model {} has {got} centres, expected {}", b.name, b.k);
        let runs = |mode: &str| {
            out.runs.get(&(idx, mode.to_string())).with_context(|| format!("no {mode} runs for {}", b.name))
        };
        let (per_run, insns_per_step, cycles_per_step) = cost(runs("regular")?, ipt).with_context(|| b.name)?;
        let (_, insns_per_step_jitter, _) = cost(runs("jitter")?, ipt).with_context(|| b.name)?;
        let blob = fs::read(&b.model)?;
        let blob_bytes = blob.len() as u64;
        let lower_bound_ops = step_ops_of(&blob)?;
        println!(
            "{:<13} K = {:>2}, {:>2} memory terms: {insns_per_step:>7.0} instructions per step ({:.0} / {:.0} over {} / {} steps; {ipt:.2} per SysTick tick); \
             {insns_per_step_jitter:.0} when every Δt differs; blob {blob_bytes} B",
            b.name, b.k, b.memory_terms, per_run[0].1, per_run[1].1, per_run[0].0, per_run[1].0
        );
        steps.push(StepBench {
            name: b.name,
            k: b.k,
            memory_terms: b.memory_terms,
            capacity,
            insns_per_tick: ipt,
            insns_per_step,
            per_run,
            insns_per_step_jitter,
            stack_peak: out.stack_peak,
            blob_bytes,
            lower_bound_ops,
            cycles_per_step,
            model_source: b.source,
        });
    }
    Ok(steps)
}
