//! Device measurements (DESIGN §8): `cargo xtask size` and the device part of `cargo xtask bench`.
//!
//! - Instructions per `Compensator::step` at K = 16, 32, 64: the `bench` image runs under
//!   `qemu-system-arm -icount shift=0` (one instruction = 1 ns of virtual time), counts SysTick
//!   ticks around `n` steps and around the same loop without the step, for n = 200 and 800.
//!   Ticks become instructions through a calibration loop of known length; the cost per step is
//!   `Δ(step − empty) / Δn` between the two runs (fixed costs cancel), and the per-run values
//!   must agree within 2 % (linearity).
//! - Flash and static RAM of the product image from its ELF sections ([`crate::elf`]).
//! - Stack high-water mark of the product image by stack painting, read over the link from
//!   `Status::stack_peak_bytes`: after boot, after streaming, after a model update.
//!
//! Results are printed and written to `target/bench/device.json`.

use std::collections::HashMap;
use std::fmt::Write as _;
use std::fs;
use std::path::Path;
use std::time::Duration;

use anyhow::{bail, ensure, Context, Result};

use crate::elf::{self, Footprint};
use crate::fixtures;
use crate::qemu::{self, LinkSession, Qemu, PRODUCT_K};

/// Targets of DESIGN §8.
pub const TARGET_INSNS_K32: f64 = 2500.0;
/// Flash target in bytes.
pub const TARGET_FLASH: u64 = 32 * 1024;
/// Static RAM + stack target in bytes.
pub const TARGET_RAM: u64 = 8 * 1024;
/// Blob size target in bytes (K = 32).
pub const TARGET_BLOB: u64 = 4 * 1024;

/// Footprint of the product image.
#[derive(Clone, Debug)]
pub struct SizeReport {
    /// ELF sections.
    pub footprint: Footprint,
    /// Stack peak during boot (embedded model decoded and folded) [B].
    pub stack_boot: u32,
    /// Stack peak while serving samples, status and pings (painted again after boot) [B].
    pub stack_serving: u32,
    /// Stack peak once a model update went through the link (includes serving) [B].
    pub stack_update: u32,
    /// Size of the embedded default blob [B].
    pub blob_bytes: u64,
}

/// One K of the step bench.
#[derive(Clone, Debug)]
pub struct StepBench {
    /// Centres.
    pub k: usize,
    /// Instructions per SysTick tick from the calibration loop.
    pub insns_per_tick: f64,
    /// Instructions per step from the two-run difference.
    pub insns_per_step: f64,
    /// Per-run estimates ((step − empty) / n) for n = 200 and 800.
    pub per_run: Vec<(u32, f64)>,
    /// Stack peak of the bench image [B].
    pub stack_peak: u32,
    /// Blob size of the bench model [B].
    pub blob_bytes: u64,
    /// DWT cycles per step (0 under QEMU, which does not model cycles).
    pub cycles_per_step: f64,
    /// Where the model comes from.
    pub model_source: &'static str,
}

fn product_images(root: &Path) -> Result<qemu::Bins> {
    let fx = fixtures::ensure(root)?;
    qemu::build(root, PRODUCT_K, &fx, None)
}

/// `cargo xtask size`: flash, static RAM and measured stack of the product image.
pub fn size(root: &Path) -> Result<SizeReport> {
    let q = qemu::ensure_qemu()?;
    let bins = product_images(root)?;
    let report = measure_size(root, &q, &bins)?;
    print_size(&report);
    Ok(report)
}

fn measure_size(root: &Path, q: &Path, bins: &qemu::Bins) -> Result<SizeReport> {
    crate::step("size: product image footprint and stack high-water mark");
    let footprint = elf::footprint(&bins.product)?;
    let fx = fixtures::ensure(root)?;
    let dfx = fixtures::ensure_device(root)?;
    let default = fs::read(qemu::firmware_dir(root).join("model/default.fbgm"))?;
    let update = fs::read(&dfx.update_model)?;
    let mut s = LinkSession::start(root, q, &bins.product, "size")?;
    s.link()?.ping(1)?;
    let stack_boot = s.link()?.status()?.stack_boot_bytes;
    // Serving: the golden samples (hold-out, then the flagged and non-finite edge cases).
    let samples = fixtures::read_inputs(&fx.golden_inputs)?;
    for (i, x) in samples.iter().enumerate() {
        s.link()?.compensate(i as u32, x)?;
    }
    let _ = s.link()?.status()?;
    let stack_serving = s.link()?.status()?.stack_peak_bytes;
    // Model updates: a refused one (it fails in the fold, after a full parse) and an accepted
    // one (parse and fold), then serving again.
    let mut p = fixtures::decode(&update)?;
    p.hyper.sigma = 1e-38; // valid, but 1/σ overflows f32 when folded
    let mut refused = vec![0u8; fbg_shared::blob::max_len(fixtures::MAX_K)];
    let n = fbg_shared::blob::encode(&p, &mut refused).map_err(|e| anyhow::anyhow!("{e}"))?;
    refused.truncate(n);
    match s.link()?.update_model(&refused)? {
        fbg_shared::protocol::UpdateResult::Rejected(_) => {}
        other => bail!("the size run's corrupted update was accepted: {other:?}"),
    }
    match s.link()?.update_model(&update)? {
        fbg_shared::protocol::UpdateResult::Accepted { .. } => {}
        other => bail!("the size run's model update was refused: {other:?}"),
    }
    for (i, x) in samples.iter().take(50).enumerate() {
        s.link()?.compensate(i as u32, x)?;
    }
    let stack_update = s.link()?.status()?.stack_peak_bytes;
    s.disconnect()?;
    s.check_alive()?;
    Ok(SizeReport { footprint, stack_boot, stack_serving, stack_update, blob_bytes: default.len() as u64 })
}

fn verdict(ok: bool) -> &'static str {
    if ok {
        "meets target"
    } else {
        "MISSES target"
    }
}

fn print_size(r: &SizeReport) {
    let f = &r.footprint;
    println!("product image (K = {PRODUCT_K}):");
    for (name, size, ram) in &f.sections {
        println!("  {name:<16} {size:>7} B  {}", if *ram { "RAM" } else { "flash" });
    }
    println!(
        "  flash            {:>7} B  ({:.1} KiB; target ≤ 32 KiB: {})",
        f.flash,
        f.flash as f64 / 1024.0,
        verdict(f.flash <= TARGET_FLASH)
    );
    println!("  static RAM       {:>7} B", f.ram_static);
    println!(
        "  stack peak       {:>7} B serving samples; {} B during a model update; {} B during boot",
        r.stack_serving, r.stack_update, r.stack_boot
    );
    for (what, stack) in [("serving", r.stack_serving), ("model update", r.stack_update), ("boot", r.stack_boot)] {
        let total = f.ram_static + stack as u64;
        println!(
            "  static + stack   {:>7} B  ({:.1} KiB) {what}; target ≤ 8 KiB: {}",
            total,
            total as f64 / 1024.0,
            verdict(total <= TARGET_RAM)
        );
    }
    println!("  model blob       {:>7} B  (target ≤ 4 KiB: {})", r.blob_bytes, verdict(r.blob_bytes <= TARGET_BLOB));
}

fn parse_kv(line: &str) -> HashMap<String, String> {
    line.split_whitespace()
        .filter_map(|w| w.split_once('='))
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect()
}

fn num(m: &HashMap<String, String>, key: &str) -> Result<f64> {
    m.get(key).with_context(|| format!("bench output lacks `{key}`"))?.parse::<f64>().with_context(|| format!("bench `{key}`"))
}

fn bench_k(root: &Path, q: &Path, k: usize) -> Result<StepBench> {
    crate::step(&format!("bench: instructions per step at K = {k} (QEMU -icount shift=0)"));
    let fx = fixtures::ensure(root)?;
    let d = fixtures::ensure_device(root)?;
    let b = d.bench.iter().find(|b| b.k == k).with_context(|| format!("no bench model for K = {k}"))?;
    let model = b.model.clone();
    let model_source = b.source;
    eprintln!("xtask: K = {k} model: {model_source}");
    let fw = qemu::firmware_dir(root);
    crate::run(
        crate::cargo()
            .current_dir(&fw)
            .args(["build", "--release", "--locked", "--bin", "bench"])
            .envs(qemu::build_env(k, &fx, Some((&model, &b.inputs)))),
    )?;
    let elf = fw.join("target/thumbv7em-none-eabihf/release/bench");
    let dir = qemu::out_dir(root)?;
    let uart = dir.join(format!("bench_k{k}.txt"));
    let _ = fs::remove_file(&uart);
    let mut run = Qemu::start(
        q,
        &elf,
        &format!("file:{}", uart.display()),
        &dir.join(format!("bench_k{k}.defmt")),
        &["-icount", "shift=0"],
    )?;
    let st = run.wait(Duration::from_secs(120))?;
    let text = fs::read_to_string(&uart).unwrap_or_default();
    if !st.success() || !text.lines().any(|l| l.trim() == "done") {
        run.show_log();
        bail!("bench image failed ({st}); output:\n{text}");
    }
    let mut calib = None;
    let mut runs = Vec::new();
    let mut stack_peak = 0;
    for line in text.lines() {
        let kv = parse_kv(line);
        if line.starts_with("calib ") {
            calib = Some((num(&kv, "insns")?, num(&kv, "ticks")?));
        } else if line.starts_with("run ") {
            runs.push((
                num(&kv, "n")? as u32,
                num(&kv, "empty_ticks")?,
                num(&kv, "step_ticks")?,
                num(&kv, "empty_cycles")?,
                num(&kv, "step_cycles")?,
            ));
        } else if line.starts_with("stack ") {
            stack_peak = num(&kv, "peak")? as u32;
        } else if line.starts_with("model ") {
            ensure!(num(&kv, "centres")? as usize == k, "bench model has {} centres, expected {k}", num(&kv, "centres")?);
        }
    }
    let (ci, ct) = calib.context("no calibration line")?;
    ensure!(ct > 0.0, "SysTick did not count during calibration (is -icount on?)");
    let ipt = ci / ct;
    ensure!(runs.len() == 2, "expected two runs, got {}", runs.len());
    let (n1, e1, s1, ec1, sc1) = runs[0];
    let (n2, e2, s2, ec2, sc2) = runs[1];
    let per_run = vec![(n1, (s1 - e1) * ipt / n1 as f64), (n2, (s2 - e2) * ipt / n2 as f64)];
    let insns_per_step = ((s2 - e2) - (s1 - e1)) * ipt / (n2 - n1) as f64;
    let spread = (per_run[0].1 - per_run[1].1).abs() / per_run[1].1;
    ensure!(
        spread < 0.02,
        "per-step cost is not linear in the step count: {:.1} vs {:.1} instructions",
        per_run[0].1,
        per_run[1].1
    );
    let cycles_per_step = ((sc2 - ec2) - (sc1 - ec1)) / (n2 - n1) as f64;
    let blob_bytes = fs::metadata(&model)?.len();
    println!(
        "K = {k:>2}: {insns_per_step:>7.0} instructions per step ({:.0} / {:.0} over {n1} / {n2} steps; {ipt:.2} instructions per SysTick tick), stack peak {stack_peak} B, blob {blob_bytes} B",
        per_run[0].1, per_run[1].1
    );
    Ok(StepBench { k, insns_per_tick: ipt, insns_per_step, per_run, stack_peak, blob_bytes, cycles_per_step, model_source })
}

/// `cargo xtask bench` (device part): step cost at K = 16, 32, 64 and the footprint; writes
/// `target/bench/device.json`.
pub fn run(root: &Path) -> Result<(Vec<StepBench>, SizeReport)> {
    let q = qemu::ensure_qemu()?;
    let mut steps = Vec::new();
    for k in [16, 32, 64] {
        steps.push(bench_k(root, &q, k)?);
    }
    let bins = product_images(root)?;
    let size = measure_size(root, &q, &bins)?;
    println!();
    for s in &steps {
        let target = if s.k == 32 { format!("  (target ≤ {TARGET_INSNS_K32:.0}: {})", verdict(s.insns_per_step <= TARGET_INSNS_K32)) } else { String::new() };
        println!("K = {:>2}: {:>7.0} instructions per step{target}", s.k, s.insns_per_step);
    }
    print_size(&size);
    let json = to_json(&steps, &size);
    let dir = root.join("target").join("bench");
    fs::create_dir_all(&dir)?;
    let path = dir.join("device.json");
    fixtures::write_atomic(&path, json.as_bytes())?;
    println!("wrote {}", path.display());
    Ok((steps, size))
}

fn to_json(steps: &[StepBench], size: &SizeReport) -> String {
    let mut s = String::from("{\n  \"method\": \"qemu-system-arm mps2-an386 -icount shift=0, SysTick deltas, (step - empty loop) difference between n=200 and n=800 steps\",\n  \"step\": [\n");
    for (i, b) in steps.iter().enumerate() {
        let _ = write!(
            s,
            "    {{\"k\": {}, \"model\": {:?}, \"instructions_per_step\": {:.1}, \"per_run\": [{}], \"instructions_per_systick_tick\": {:.4}, \"dwt_cycles_per_step\": {:.1}, \"stack_peak_bytes\": {}, \"blob_bytes\": {}}}{}",
            b.k,
            b.model_source,
            b.insns_per_step,
            b.per_run.iter().map(|(n, v)| format!("{{\"n\": {n}, \"instructions_per_step\": {v:.1}}}")).collect::<Vec<_>>().join(", "),
            b.insns_per_tick,
            b.cycles_per_step,
            b.stack_peak,
            b.blob_bytes,
            if i + 1 < steps.len() { "," } else { "" }
        );
        s.push('\n');
    }
    let f = &size.footprint;
    let total = f.ram_static + size.stack_update.max(size.stack_boot) as u64;
    let serving = f.ram_static + size.stack_serving as u64;
    let k32 = steps.iter().find(|b| b.k == 32).map(|b| b.insns_per_step).unwrap_or(f64::NAN);
    let _ = write!(
        s,
        "  ],\n  \"product\": {{\"k\": {PRODUCT_K}, \"flash_bytes\": {}, \"static_ram_bytes\": {}, \"stack_peak_boot_bytes\": {}, \"stack_peak_serving_bytes\": {}, \"stack_peak_update_bytes\": {}, \"static_ram_plus_stack_bytes\": {}, \"static_ram_plus_serving_stack_bytes\": {}, \"default_blob_bytes\": {}}},\n",
        f.flash, f.ram_static, size.stack_boot, size.stack_serving, size.stack_update, total, serving, size.blob_bytes
    );
    let _ = write!(
        s,
        "  \"targets\": {{\"instructions_per_step_k32\": {{\"target\": {TARGET_INSNS_K32}, \"measured\": {k32:.1}, \"met\": {}}}, \"flash_bytes\": {{\"target\": {TARGET_FLASH}, \"measured\": {}, \"met\": {}}}, \"static_ram_plus_stack_bytes\": {{\"target\": {TARGET_RAM}, \"measured\": {total}, \"met\": {}, \"serving_only\": {serving}, \"serving_only_met\": {}}}, \"blob_bytes\": {{\"target\": {TARGET_BLOB}, \"measured\": {}, \"met\": {}}}}}\n}}",
        k32 <= TARGET_INSNS_K32,
        f.flash,
        f.flash <= TARGET_FLASH,
        total <= TARGET_RAM,
        serving <= TARGET_RAM,
        size.blob_bytes,
        size.blob_bytes <= TARGET_BLOB
    );
    s.push('\n');
    s
}
