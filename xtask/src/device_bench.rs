//! Device measurements (DESIGN §8): `cargo xtask size` and the device part of `cargo xtask bench`.
//!
//! - Instructions per `Compensator::step` for every bench model (`fixtures::ensure_device`):
//!   the trainer's default model, the synthetic model with the full memory bank at K = 0, 16,
//!   32 (and 64) and without memory at K = 16, 32, 64, the random models of other dims
//!   (2 → 2, 8 → 4) and the trainer's Model-H of the other presets
//!   (`fixtures::TRAINED_PRESETS`: strain-pair, temperature-1, array-8). The `bench` image (one build per
//!   capacity, 32 and 64, each embedding its models) runs under `qemu-system-arm -icount
//!   shift=0` (one instruction = 1 ns of virtual time), counts SysTick ticks around `n` steps
//!   and around the same loop without the step, for n = 200 and 800. Ticks become instructions
//!   through a calibration loop of known length; the cost per step is `Δ(step − empty) / Δn`
//!   between the two runs (fixed costs cancel), and the per-run values must agree within 2 %
//!   (linearity). Mode `regular` replays the samples on their 60 s clock (the memory bank's
//!   smoothing factors cached), mode `jitter` gives every step a new Δt (recomputed).
//! - The sizes of the device's types (`MemoryState<f32>`, `Compensator<f32, 32>`, …) as the
//!   bench image reports them (`size_of` on the target).
//! - Flash and static RAM of the product image from its ELF sections ([`crate::elf`]).
//! - Stack high-water mark of the product image by stack painting, read over the link from
//!   `Status::stack_peak_bytes`: after boot, after streaming, after a (signed) model update,
//!   whose peak includes the signature verification.
//! - Instructions of one signature check of a model update (`fbg_firmware_app::authenticate`:
//!   trailer, key lookup, Ed25519 verification, serial) on the default model signed with the
//!   QEMU test key, timed by the bench image like a step, with the stack it reached.
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

/// Targets of DESIGN §8: instructions per step of the default model (with its memory bank).
pub const TARGET_INSNS_K32: f64 = 2500.0;
/// Flash target in bytes (DESIGN §8: 32 KiB, ≤ 48 KiB once the signature verifier is in; it
/// is).
pub const TARGET_FLASH: u64 = 48 * 1024;
/// Static RAM + stack target while serving, in bytes.
pub const TARGET_RAM: u64 = 8 * 1024;
/// Static RAM + stack target at the peak of a model load (boot, update: where the signature
/// verification will run), in bytes (DESIGN §8: ≤ 12 KiB at the verification peak).
pub const TARGET_RAM_LOAD: u64 = 12 * 1024;
/// Blob size target in bytes (K = 32).
pub const TARGET_BLOB: u64 = 4 * 1024;

/// Footprint of the product image.
#[derive(Clone, Debug)]
pub struct SizeReport {
    /// ELF sections.
    pub footprint: Footprint,
    /// Stack peak during boot (embedded model decoded and folded) \[B\].
    pub stack_boot: u32,
    /// Stack peak while serving samples, status and pings (painted again after boot) \[B\].
    pub stack_serving: u32,
    /// Stack peak once a model update went through the link (includes serving) \[B\].
    pub stack_update: u32,
    /// Size of the embedded default blob \[B\].
    pub blob_bytes: u64,
    /// The flash slot model updates are staged in (`STAGING` of `memory.x`; flash outside the
    /// image, neither RAM nor part of the image) \[B\].
    pub staging_slot: u64,
}

/// One signature check of a model update, timed by the bench image.
#[derive(Clone, Debug, Default)]
pub struct VerifyBench {
    /// Bytes of the signed model checked.
    pub bytes: u64,
    /// Instructions of one `authenticate` call.
    pub instructions: f64,
    /// Stack the check reached, in bytes (the bench's own frames included).
    pub stack_peak: u32,
}

/// One model of the step bench.
#[derive(Clone, Debug)]
pub struct StepBench {
    /// Row name (`default`, `memory_k32`, `plain_k64`, …).
    pub name: &'static str,
    /// Centres of the model.
    pub k: usize,
    /// Memory slots the model uses (0: no memory bank).
    pub memory_terms: usize,
    /// Capacity of the bench image.
    pub capacity: usize,
    /// Instructions per SysTick tick from the calibration loop.
    pub insns_per_tick: f64,
    /// Instructions per step from the two-run difference, regular clock.
    pub insns_per_step: f64,
    /// Per-run estimates ((step − empty) / n) for n = 200 and 800, regular clock.
    pub per_run: Vec<(u32, f64)>,
    /// Instructions per step when every step has a new Δt (mode `jitter`).
    pub insns_per_step_jitter: f64,
    /// Stack peak of the bench image \[B\] (all its models).
    pub stack_peak: u32,
    /// Blob size of the bench model \[B\].
    pub blob_bytes: u64,
    /// Arithmetic operations of one step of this model (`bench::device::step_ops_of`).
    pub lower_bound_ops: usize,
    /// DWT cycles per step (0 under QEMU, which does not model cycles).
    pub cycles_per_step: f64,
    /// Where the model comes from.
    pub model_source: &'static str,
}

/// Sizes of the device's types \[B\], from the bench image (`size_of` on the target).
#[derive(Clone, Debug, Default)]
pub struct TypeSizes {
    /// Capacity they were measured at.
    pub k: usize,
    /// `MemoryState<f32>`: the memory bank's stream state.
    pub memory_state: u64,
    /// `StreamState<f32>`: latches and memory state.
    pub stream_state: u64,
    /// `MemoryBank<f32>`: the bank's coefficients, cached factors and state.
    pub memory_bank: u64,
    /// `Compensator<f32, K>`.
    pub compensator: u64,
    /// `ModelParams<f32, K>`: the parameter slot a model is parsed into (on the stack of a load).
    pub model_params: u64,
    /// `FrameReader<HOST_MAX_FRAME>`: the link's frame reader.
    pub reader: u64,
    /// The longest update the build stages (in its flash slot, not in RAM): `STAGING_LEN`.
    pub staging: u64,
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
    let update = fs::read(crate::signing::sign_one(root, &fx, &dfx.update_model, 1)?)?;
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
    // Signed, so that it passes the signature check and fails in the fold after a full parse.
    let refused_path = qemu::out_dir(root)?.join("size-refused.fbgm");
    fs::write(&refused_path, &refused)?;
    let refused = fs::read(crate::signing::sign_one(root, &fx, &refused_path, 1)?)?;
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
    let staging_slot = staging_slot(root)?;
    Ok(SizeReport {
        footprint,
        stack_boot,
        stack_serving,
        stack_update,
        blob_bytes: default.len() as u64,
        staging_slot,
    })
}

/// Length of the `STAGING` region of the top-level `memory.x` (`LENGTH = 8K` or a number of
/// bytes), the flash slot model updates are staged in.
fn staging_slot(root: &Path) -> Result<u64> {
    let path = root.join("memory.x");
    let text = fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let line = text
        .lines()
        .find(|l| l.trim_start().starts_with("STAGING"))
        .with_context(|| format!("{} has no STAGING region", path.display()))?;
    let len = line.split("LENGTH").nth(1).and_then(|r| r.split('=').nth(1)).map(str::trim).unwrap_or_default();
    let (digits, scale) = match len.strip_suffix('K') {
        Some(d) => (d, 1024),
        None => (len, 1),
    };
    let n: u64 = digits.trim().parse().with_context(|| format!("STAGING length `{len}` in {}", path.display()))?;
    Ok(n * scale)
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
        "  flash            {:>7} B  ({:.1} KiB; target ≤ 48 KiB with the signature verifier: {})",
        f.flash,
        f.flash as f64 / 1024.0,
        verdict(f.flash <= TARGET_FLASH)
    );
    println!("  static RAM       {:>7} B", f.ram_static);
    println!(
        "  staging slot     {:>7} B  flash outside the image (STAGING of memory.x): model updates are staged there, not in RAM",
        r.staging_slot
    );
    println!(
        "  stack peak       {:>7} B serving samples; {} B during a model update; {} B during boot",
        r.stack_serving, r.stack_update, r.stack_boot
    );
    for (what, stack, target) in [
        ("serving", r.stack_serving, TARGET_RAM),
        ("model update", r.stack_update, TARGET_RAM_LOAD),
        ("boot", r.stack_boot, TARGET_RAM_LOAD),
    ] {
        let total = f.ram_static + stack as u64;
        println!(
            "  static + stack   {:>7} B  ({:.1} KiB) {what}; target ≤ {} KiB: {}",
            total,
            total as f64 / 1024.0,
            target / 1024,
            verdict(total <= target)
        );
    }
    println!("  model blob       {:>7} B  (target ≤ 4 KiB: {})", r.blob_bytes, verdict(r.blob_bytes <= TARGET_BLOB));
}

fn parse_kv(line: &str) -> HashMap<String, String> {
    line.split_whitespace().filter_map(|w| w.split_once('=')).map(|(k, v)| (k.to_string(), v.to_string())).collect()
}

fn num(m: &HashMap<String, String>, key: &str) -> Result<f64> {
    m.get(key)
        .with_context(|| format!("bench output lacks `{key}`"))?
        .parse::<f64>()
        .with_context(|| format!("bench `{key}`"))
}

fn bench_pack(
    root: &Path,
    q: &Path,
    capacity: usize,
    sizes: &mut Option<TypeSizes>,
    verify: &mut Option<VerifyBench>,
) -> Result<Vec<StepBench>> {
    crate::step(&format!("bench: instructions per step, capacity {capacity} (QEMU -icount shift=0)"));
    let fx = fixtures::ensure(root)?;
    let d = fixtures::ensure_device(root)?;
    let rows: Vec<&fixtures::BenchFixture> = d.bench.iter().filter(|b| b.capacity == capacity).collect();
    let pack = &d
        .bench_packs
        .iter()
        .find(|(c, _)| *c == capacity)
        .with_context(|| format!("no bench pack for capacity {capacity}"))?
        .1;
    for b in &rows {
        eprintln!("xtask: {} (K = {}, {} memory terms): {}", b.name, b.k, b.memory_terms, b.source);
    }
    let k = capacity;
    crate::signing::bench_signed(root, &fx)?;
    let fw = qemu::firmware_dir(root);
    crate::run(
        crate::firmware_cargo()
            .current_dir(&fw)
            .args(["build", "--release", "--locked", "--bin", "bench"])
            .envs(qemu::build_env(k, &fx, Some(pack))),
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
    let st = run.wait(Duration::from_secs(600))?;
    let text = fs::read_to_string(&uart).unwrap_or_default();
    if !st.success() || !text.lines().any(|l| l.trim() == "done") {
        run.show_log();
        bail!("bench image failed ({st}); output:\n{text}");
    }
    let mut calib = None;
    // (idx, mode) -> [(n, empty_ticks, step_ticks, empty_cycles, step_cycles)]
    let mut runs: HashMap<(usize, String), Vec<[f64; 5]>> = HashMap::new();
    let mut centres: HashMap<usize, usize> = HashMap::new();
    let mut stack_peak = 0;
    let mut verify_line = None;
    for line in text.lines() {
        let kv = parse_kv(line);
        if line.starts_with("calib ") {
            calib = Some((num(&kv, "insns")?, num(&kv, "ticks")?));
        } else if line.starts_with("run ") {
            let idx = num(&kv, "idx")? as usize;
            let mode = kv.get("mode").cloned().unwrap_or_default();
            runs.entry((idx, mode)).or_default().push([
                num(&kv, "n")?,
                num(&kv, "empty_ticks")?,
                num(&kv, "step_ticks")?,
                num(&kv, "empty_cycles")?,
                num(&kv, "step_cycles")?,
            ]);
        } else if line.starts_with("verify ") {
            ensure!(num(&kv, "ok")? == 1.0, "the bench image's signed model did not pass the signature check: {line}");
            verify_line = Some((num(&kv, "bytes")? as u64, num(&kv, "ticks")?, num(&kv, "stack_peak")? as u32));
        } else if line.starts_with("stack ") {
            stack_peak = num(&kv, "peak")? as u32;
        } else if line.starts_with("model ") {
            centres.insert(num(&kv, "idx")? as usize, num(&kv, "centres")? as usize);
        } else if line.starts_with("sizes ") {
            *sizes = Some(TypeSizes {
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
    let (ci, ct) = calib.context("no calibration line")?;
    ensure!(ct > 0.0, "SysTick did not count during calibration (is -icount on?)");
    let ipt = ci / ct;
    // The line carries ticks: instructions through the same calibration as the steps.
    if let Some((bytes, ticks, stack_peak)) = verify_line {
        *verify = Some(VerifyBench { bytes, instructions: ticks * ipt, stack_peak });
    }
    // Per-step cost from two runs: (per-run values, difference estimate, cycles per step).
    // (per-run values, per-step instructions, DWT cycles per step).
    type Cost = (Vec<(u32, f64)>, f64, f64);
    let cost = |r: &[[f64; 5]]| -> Result<Cost> {
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
    };
    let mut out = Vec::new();
    for (idx, b) in rows.iter().enumerate() {
        let got = centres.get(&idx).copied().with_context(|| format!("the bench ran no model {idx} ({})", b.name))?;
        ensure!(got == b.k, "bench model {} has {got} centres, expected {}", b.name, b.k);
        let regular =
            runs.get(&(idx, "regular".to_string())).with_context(|| format!("no regular runs for {}", b.name))?;
        let jitter =
            runs.get(&(idx, "jitter".to_string())).with_context(|| format!("no jitter runs for {}", b.name))?;
        let (per_run, insns_per_step, cycles_per_step) = cost(regular).with_context(|| b.name)?;
        let (_, insns_per_step_jitter, _) = cost(jitter).with_context(|| b.name)?;
        let blob = fs::read(&b.model)?;
        let blob_bytes = blob.len() as u64;
        let lower_bound_ops = crate::bench::device::step_ops_of(&blob)?;
        println!(
            "{:<13} K = {:>2}, {:>2} memory terms: {insns_per_step:>7.0} instructions per step ({:.0} / {:.0} over {} / {} steps; {ipt:.2} per SysTick tick); \
             {insns_per_step_jitter:.0} when every Δt differs; blob {blob_bytes} B",
            b.name, b.k, b.memory_terms, per_run[0].1, per_run[1].1, per_run[0].0, per_run[1].0
        );
        out.push(StepBench {
            name: b.name,
            k: b.k,
            memory_terms: b.memory_terms,
            capacity,
            insns_per_tick: ipt,
            insns_per_step,
            per_run,
            insns_per_step_jitter,
            stack_peak,
            blob_bytes,
            lower_bound_ops,
            cycles_per_step,
            model_source: b.source,
        });
    }
    Ok(out)
}

/// `cargo xtask bench` (device part): step cost of every bench model, the sizes of the device's
/// types and the footprint; writes `target/bench/device.json`.
pub fn run(root: &Path) -> Result<(Vec<StepBench>, SizeReport)> {
    let q = qemu::ensure_qemu()?;
    let mut steps = Vec::new();
    let mut sizes = None;
    let mut sizes64 = None;
    let mut verify = None;
    let mut verify64 = None;
    steps.extend(bench_pack(root, &q, 32, &mut sizes, &mut verify)?);
    steps.extend(bench_pack(root, &q, 64, &mut sizes64, &mut verify64)?);
    let sizes = sizes.context("the bench image reported no type sizes")?;
    let verify = verify.context("the bench image did not time the signature check")?;
    let bins = product_images(root)?;
    let size = measure_size(root, &q, &bins)?;
    println!();
    for s in &steps {
        let target = if s.name == "default" {
            format!("  (target ≤ {TARGET_INSNS_K32:.0}: {})", verdict(s.insns_per_step <= TARGET_INSNS_K32))
        } else {
            String::new()
        };
        println!(
            "{:<13} K = {:>2}, {:>2} memory terms: {:>7.0} instructions per step ({:.0} with a new Δt every step){target}",
            s.name, s.k, s.memory_terms, s.insns_per_step, s.insns_per_step_jitter
        );
    }
    print_sizes(&sizes);
    print_size(&size);
    println!(
        "signature check of a model update ({} B signed model): {:.0} instructions (once per update, not per sample); stack reached {} B",
        verify.bytes, verify.instructions, verify.stack_peak
    );
    let json = to_json(&steps, &sizes, &size, &verify);
    let dir = root.join("target").join("bench");
    fs::create_dir_all(&dir)?;
    let path = dir.join("device.json");
    fixtures::write_atomic(&path, json.as_bytes())?;
    println!("wrote {}", path.display());
    Ok((steps, size))
}

fn print_sizes(t: &TypeSizes) {
    println!("device types (size_of on thumbv7em-none-eabihf, K = {}):", t.k);
    println!("  MemoryState<f32>     {:>6} B  (the memory bank's stream state)", t.memory_state);
    println!("  StreamState<f32>     {:>6} B  (latches + memory state)", t.stream_state);
    println!("  MemoryBank<f32>      {:>6} B  (coefficients, cached factors, state)", t.memory_bank);
    println!("  Compensator<f32, {}> {:>6} B", t.k, t.compensator);
    println!("  ModelParams<f32, 0> {:>6} B  (centre-less parameter slot, on the stack during a load)", t.model_params);
    println!("  FrameReader          {:>6} B  (the link's frame reader)", t.reader);
    println!("  longest staged update {:>5} B  (in the flash slot, not RAM: STAGING_LEN)", t.staging);
}

fn to_json(steps: &[StepBench], t: &TypeSizes, size: &SizeReport, v: &VerifyBench) -> String {
    let mut s = String::from("{\n  \"method\": \"qemu-system-arm mps2-an386 -icount shift=0, SysTick deltas, (step - empty loop) difference between n=200 and n=800 steps; mode regular: the samples on their 60 s clock, jitter: a new dt every step\",\n  \"step\": [\n");
    for (i, b) in steps.iter().enumerate() {
        let _ = write!(
            s,
            "    {{\"name\": {:?}, \"k\": {}, \"memory_terms\": {}, \"capacity\": {}, \"model\": {:?}, \"instructions_per_step\": {:.1}, \"instructions_per_step_new_dt_every_step\": {:.1}, \"per_run\": [{}], \"instructions_per_systick_tick\": {:.4}, \"dwt_cycles_per_step\": {:.1}, \"stack_peak_bytes\": {}, \"blob_bytes\": {}, \"lower_bound_ops\": {}}}{}",
            b.name,
            b.k,
            b.memory_terms,
            b.capacity,
            b.model_source,
            b.insns_per_step,
            b.insns_per_step_jitter,
            b.per_run.iter().map(|(n, v)| format!("{{\"n\": {n}, \"instructions_per_step\": {v:.1}}}")).collect::<Vec<_>>().join(", "),
            b.insns_per_tick,
            b.cycles_per_step,
            b.stack_peak,
            b.blob_bytes,
            b.lower_bound_ops,
            if i + 1 < steps.len() { "," } else { "" }
        );
        s.push('\n');
    }
    let _ = write!(
        s,
        "  ],\n  \"sizes\": {{\"k\": {}, \"memory_state_bytes\": {}, \"stream_state_bytes\": {}, \"memory_bank_bytes\": {}, \"compensator_bytes\": {}, \"model_params_bytes\": {}, \"frame_reader_bytes\": {}, \"staging_bytes\": {}}},\n",
        t.k, t.memory_state, t.stream_state, t.memory_bank, t.compensator, t.model_params, t.reader, t.staging
    );
    let _ = writeln!(
        s,
        "  \"signature_verification\": {{\"what\": \"fbg_firmware_app::authenticate: signature trailer, trusted-key lookup, Ed25519 verification (salty, Cortex-M4 assembly), serial check; once per model update\", \"signed_model_bytes\": {}, \"instructions\": {:.0}, \"stack_peak_bytes\": {}}},",
        v.bytes, v.instructions, v.stack_peak
    );
    let f = &size.footprint;
    let total = f.ram_static + size.stack_update.max(size.stack_boot) as u64;
    let serving = f.ram_static + size.stack_serving as u64;
    let default = steps.iter().find(|b| b.name == "default");
    let dk = default.map(|b| b.k).unwrap_or(0);
    let dins = default.map(|b| b.insns_per_step).unwrap_or(f64::NAN);
    let _ = writeln!(
        s,
        "  \"product\": {{\"k\": {PRODUCT_K}, \"default_model_centres\": {dk}, \"default_model_memory_terms\": {}, \"flash_bytes\": {}, \"static_ram_bytes\": {}, \"stack_peak_boot_bytes\": {}, \"stack_peak_serving_bytes\": {}, \"stack_peak_update_bytes\": {}, \"static_ram_plus_stack_bytes\": {}, \"static_ram_plus_serving_stack_bytes\": {}, \"default_blob_bytes\": {}}},",
        default.map(|b| b.memory_terms).unwrap_or(0), f.flash, f.ram_static, size.stack_boot, size.stack_serving, size.stack_update, total, serving, size.blob_bytes
    );
    let _ = write!(
        s,
        "  \"targets\": {{\"instructions_per_step_default\": {{\"target\": {TARGET_INSNS_K32}, \"k\": {dk}, \"measured\": {dins:.1}, \"met\": {}}}, \"flash_bytes\": {{\"target\": {TARGET_FLASH}, \"measured\": {}, \"met\": {}}}, \"static_ram_plus_stack_bytes\": {{\"target_serving\": {TARGET_RAM}, \"serving_only\": {serving}, \"serving_only_met\": {}, \"target_load_peak\": {TARGET_RAM_LOAD}, \"measured\": {total}, \"met\": {}}}, \"blob_bytes\": {{\"target\": {TARGET_BLOB}, \"measured\": {}, \"met\": {}}}}}\n}}",
        dins <= TARGET_INSNS_K32,
        f.flash,
        f.flash <= TARGET_FLASH,
        serving <= TARGET_RAM,
        total <= TARGET_RAM_LOAD,
        size.blob_bytes,
        size.blob_bytes <= TARGET_BLOB
    );
    s.push('\n');
    s
}
