//! Firmware build and QEMU tests (`cargo xtask qemu`, part of `cargo xtask test`).
//!
//! 1. host unit tests of the device logic (`fbg-firmware-app`) and clippy of the firmware;
//! 2. fault path: an image that executes UDF must end QEMU with a failure exit code;
//! 3. golden vectors: the `golden` image compensates the fixture samples on the emulated
//!    Cortex-M4F and sends its estimates over UART0 to a file; each is compared with the host's
//!    f64 answer (|Δ| ≤ 1 % of the reference scale per channel, flags identical). The sets:
//!    the trainer's paper model on its golden samples plus edge cases; the synthetic model
//!    with every slot of the memory bank in use on an irregular clock with a gap; random
//!    models of other dims (2 → 2 without ambient, 8 → 4); and the trainer's Model-H of each
//!    other preset of `fixtures::TRAINED_PRESETS` (strain-pair, temperature-1, array-8) on its
//!    own hold-out samples plus edge cases. The scale of every trained model is its hold-out
//!    RMSE from the trainer's `golden_meta.json` (required for the presets' sets), of the
//!    synthetic ones the square root of their residual variance. The test fails when a set is
//!    missing, or the pack the image embeds does not hold exactly these sets in order;
//! 4. link: the product image serves its serial port on a loopback TCP port; `fbg-trainer
//!    stream` (the real CLI) sends the paper hold-out and checks every estimate against the
//!    host's f64 compensator; then garbage (counted, then served), a corrupted and an oversized
//!    model (rejected with their reasons; the old model still answers like the host), and
//!    `fbg-trainer stream --update-first` with a second model (accepted, and its answers match
//!    the host on the new model);
//! 5. signed updates: a model signed by the trainer with the committed QEMU test key is
//!    accepted; unsigned, signed by an unknown key, tampered after signing (one payload bit)
//!    and an older serial replayed are each refused with their reason while the running model
//!    answers bit for bit as before; the device's counters and audit fields say so, also
//!    through `fbg-trainer device status`; so are another model under the running serial (a
//!    swap) and a rollback (the default build accepts none); 1 000 `ModelBegin` frames erase
//!    the staging slot at most once (`Status::staging_erases`). Then the `rollback` image (the
//!    product with rollbacks accepted): a rollback signed to replace serial 5 is refused over
//!    serial 3, accepted over serial 5, refused when replayed over itself and after the device
//!    moved on to serial 9;
//! 6. memory over 14 days: the product image, given a model with memory terms (the default
//!    when it has them, else the default with the full memory bank added), compensates the
//!    whole paper data set — 20 160 samples, 14 days — on an irregular clock with a 5 h gap;
//!    every answer is compared with the host's f64 (≤ 1 % of Model-H's hold-out RMSE, flags
//!    identical), and the largest difference of the last day with that of the first, so that
//!    f32 memory state drifting over a long stream would show.
//!
//! Every QEMU run has a time-out and QEMU is killed on any failure. defmt logs (QEMU's
//! semihosting stdout) are kept in `target/qemu/*.defmt` and decoded with `defmt-print` when it
//! is installed (`cargo install defmt-print --locked`; not installed by the tests because it takes
//! minutes to build on two cores).

use std::fs::{self, File};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context, Result};
use fbg_link::parity::{abs_diff, compare, REL_TOL};
use fbg_link::LinkClient;
use fbg_shared::blob::stored_crc;
use fbg_shared::protocol::{DeviceMsg, Feed, FrameReader, RejectReason, Status, UpdateResult, DEVICE_MAX_FRAME};

use crate::fixtures::{self, DeviceFixtures, Fixtures};
use crate::signing::{self, SignedFixtures};

/// The product's centre capacity.
pub const PRODUCT_K: usize = 32;

/// Build the firmware and run every QEMU test.
pub fn run_all(root: &Path) -> Result<()> {
    crate::step("firmware: QEMU prerequisites and fixtures");
    let qemu = ensure_qemu()?;
    let fx = fixtures::ensure(root)?;
    let dfx = fixtures::ensure_device(root)?;
    let sfx = signing::ensure(root, &fx, &dfx)?;

    crate::step("firmware: host tests of the device logic (fbg-firmware-app)");
    let fw = firmware_dir(root);
    crate::run(
        crate::firmware_cargo()
            .current_dir(&fw)
            .args(["test", "-p", "fbg-firmware-app", "--locked", "--target", &host_triple()?])
            .env("FBG_TEST_MODEL", &fx.model),
    )?;
    check_default_model(root, &fx)?;

    crate::step("firmware: build (thumbv7em-none-eabihf, K = 32) and clippy");
    let bins = build(root, PRODUCT_K, &fx, None)?;
    crate::run(
        crate::firmware_cargo()
            .current_dir(&fw)
            .args(["clippy", "--workspace", "--release", "--locked", "--", "-D", "warnings"])
            .envs(build_env(PRODUCT_K, &fx, None)),
    )?;
    // The device logic's host tests too (every target of the app crate).
    crate::run(
        crate::firmware_cargo()
            .current_dir(&fw)
            .args(["clippy", "-p", "fbg-firmware-app", "--all-targets", "--locked", "--target", &host_triple()?])
            .args(["--", "-D", "warnings"])
            .env("FBG_TEST_MODEL", &fx.model),
    )?;

    let started = Instant::now();
    crate::step("QEMU: fault path (UDF → HardFault → semihosting exit failure)");
    fault_test(root, &qemu, &bins)?;
    crate::step("QEMU: golden vectors");
    golden_test(root, &qemu, &bins, &fx)?;
    crate::step("QEMU: streaming, garbage and model updates over a loopback TCP serial port");
    link_test(root, &qemu, &bins, &fx, &dfx, &sfx)?;
    crate::step(
        "QEMU: signed model updates (accepted; unsigned, unknown key, tampered, rollback, swap refused), staging erases and the audit trail",
    );
    signed_update_test(root, &qemu, &bins, &fx, &sfx)?;
    crate::step("QEMU: a bounded rollback (the `rollback` image): accepted over the serial it names only");
    rollback_test(root, &qemu, &bins, &sfx)?;
    crate::step("QEMU: a memory model over the whole 14-day paper stream (f32 device vs f64 host)");
    long_memory_test(root, &qemu, &bins, &fx)?;
    eprintln!("xtask: QEMU tests passed in {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}

/// The product embeds `firmware/model/default.fbgm`, which must be exactly the trainer's
/// Model-H for the paper preset, seed 7 (`target/fixtures/model.fbgm`, made just now by the
/// current trainer): it can never go stale.
pub fn check_default_model(root: &Path, fx: &Fixtures) -> Result<()> {
    let path = firmware_dir(root).join("model/default.fbgm");
    let committed = fs::read(&path).with_context(|| format!("reading {}", path.display()))?;
    let fresh = fs::read(&fx.model).with_context(|| format!("reading {}", fx.model.display()))?;
    if committed != fresh {
        let why = match fbg_shared::blob::decode::<PRODUCT_K>(&committed) {
            Err(e) => format!("it does not even decode with the current fbg-shared ({e})"),
            Ok(_) => format!(
                "it decodes, but differs from what the trainer produces now ({} vs {} bytes, crc {:#010x} vs {:#010x})",
                committed.len(),
                fresh.len(),
                stored_crc(&committed).unwrap_or(0),
                stored_crc(&fresh).unwrap_or(0)
            ),
        };
        bail!(
            "{} is stale: {why}. It must be the trainer's Model-H for the paper preset, seed 7 \
             ({}). Regenerate it with `cargo xtask fixtures --write-default` and commit it",
            path.display(),
            fx.model.display()
        );
    }
    eprintln!("xtask: firmware/model/default.fbgm is the trainer's current Model-H (paper preset, seed 7)");
    Ok(())
}

/// Paths of the built images.
#[derive(Clone, Debug)]
pub struct Bins {
    /// The product image.
    pub product: PathBuf,
    /// Golden-vector image.
    pub golden: PathBuf,
    /// Fault-path image.
    pub fault: PathBuf,
    /// The product with rollbacks accepted (the bounded-rollback test).
    pub rollback: PathBuf,
}

/// The firmware workspace.
pub fn firmware_dir(root: &Path) -> PathBuf {
    root.join("firmware")
}

/// Environment of a firmware build: capacity `k`, the golden pack, and the bench pack (`bench`;
/// none for builds that do not run the bench: the bench image then embeds an empty pack, as the
/// build script does for a missing fixture, so that it links beside the product whatever the
/// golden pack's size).
pub fn build_env(k: usize, fx: &Fixtures, bench: Option<&Path>) -> Vec<(String, String)> {
    let s = |p: &Path| p.display().to_string();
    vec![
        ("FBG_K".to_string(), k.to_string()),
        ("FBG_GOLDEN_PACK".to_string(), s(&fx.golden_pack)),
        ("FBG_BENCH_PACK".to_string(), bench.map(s).unwrap_or_default()),
        ("FBG_BENCH_SIGNED".to_string(), s(&fixtures::dir(&crate::root()).join("bench_signed.fbgm"))),
    ]
}

/// Build every firmware image with capacity `k` (release profile).
pub fn build(root: &Path, k: usize, fx: &Fixtures, bench: Option<&Path>) -> Result<Bins> {
    let fw = firmware_dir(root);
    crate::run(
        crate::firmware_cargo()
            .current_dir(&fw)
            .args(["build", "--release", "--locked", "--bins"])
            .envs(build_env(k, fx, bench)),
    )?;
    let out = fw.join("target/thumbv7em-none-eabihf/release");
    Ok(Bins {
        product: out.join("fbg-firmware"),
        golden: out.join("golden"),
        fault: out.join("fault"),
        rollback: out.join("rollback"),
    })
}

/// The host's target triple (for the device-logic unit tests).
pub fn host_triple() -> Result<String> {
    let out = Command::new("rustc").arg("-vV").output().context("running `rustc -vV`")?;
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(|l| l.strip_prefix("host: "))
        .map(|s| s.trim().to_string())
        .context("`rustc -vV` printed no host triple")
}

/// `qemu-system-arm`, installed with apt-get when missing and we are root.
pub fn ensure_qemu() -> Result<PathBuf> {
    let found = |p: &str| {
        Command::new(p).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_ok_and(|s| s.success())
    };
    if found("qemu-system-arm") {
        return Ok(PathBuf::from("qemu-system-arm"));
    }
    if !crate::is_root() {
        bail!(
            "qemu-system-arm is not installed. Install it with `sudo apt-get install -y qemu-system-arm` \
             (Debian/Ubuntu) and run `cargo xtask test` again; `cargo xtask test --no-qemu` skips the firmware tests"
        );
    }
    eprintln!("xtask: qemu-system-arm missing, installing it with apt-get");
    crate::run(Command::new("apt-get").arg("update").arg("-qq"))?;
    crate::run(
        Command::new("apt-get")
            .args(["install", "-y", "-qq", "qemu-system-arm"])
            .env("DEBIAN_FRONTEND", "noninteractive"),
    )?;
    ensure!(found("qemu-system-arm"), "apt-get ran but qemu-system-arm is still not on PATH");
    Ok(PathBuf::from("qemu-system-arm"))
}

/// Directory of QEMU logs and outputs.
pub fn out_dir(root: &Path) -> Result<PathBuf> {
    let d = root.join("target").join("qemu");
    fs::create_dir_all(&d)?;
    Ok(d)
}

/// A running QEMU, killed when dropped.
pub struct Qemu {
    child: Child,
    /// The image it runs.
    pub elf: PathBuf,
    /// Its semihosting (defmt) output.
    pub log: PathBuf,
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if let Ok(None) = self.child.try_wait() {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

impl Qemu {
    /// Start `elf` on the mps2-an386 with serial0 on `serial` (a QEMU chardev spec).
    pub fn start(qemu: &Path, elf: &Path, serial: &str, log: &Path, extra: &[&str]) -> Result<Qemu> {
        ensure!(elf.exists(), "{} is not built", elf.display());
        let stdout = File::create(log).with_context(|| format!("creating {}", log.display()))?;
        let stderr = File::create(log.with_extension("stderr"))?;
        let mut cmd = Command::new(qemu);
        cmd.args(["-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-monitor", "none"])
            .args(["-serial", serial])
            .args(["-semihosting-config", "enable=on,target=native"])
            .args(extra)
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(stdout)
            .stderr(stderr);
        eprintln!("xtask: $ {}", crate::describe(&cmd));
        let child = cmd.spawn().with_context(|| format!("starting {}", qemu.display()))?;
        Ok(Qemu { child, elf: elf.to_path_buf(), log: log.to_path_buf() })
    }

    /// Exit status if QEMU has ended.
    pub fn try_exit(&mut self) -> Result<Option<ExitStatus>> {
        Ok(self.child.try_wait()?)
    }

    /// Wait for QEMU to exit by itself, at most `timeout` (then kill it and fail).
    pub fn wait(&mut self, timeout: Duration) -> Result<ExitStatus> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(s) = self.child.try_wait()? {
                return Ok(s);
            }
            if Instant::now() >= deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                self.show_log();
                bail!("QEMU running {} did not exit within {:?}; killed", self.elf.display(), timeout);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Decode the defmt log next to the raw one (when defmt-print is installed) and print it.
    pub fn show_log(&self) {
        match decode_log(&self.elf, &self.log) {
            Some(text) => eprintln!("xtask: device log ({}):\n{text}", self.log.display()),
            None => eprintln!(
                "xtask: raw defmt log in {} (install defmt-print: `cargo install defmt-print --locked`, then \
                 `defmt-print -e {} < {}`)",
                self.log.display(),
                self.elf.display(),
                self.log.display()
            ),
        }
        if let Ok(err) = fs::read_to_string(self.log.with_extension("stderr")) {
            if !err.trim().is_empty() {
                eprintln!("xtask: QEMU stderr:\n{err}");
            }
        }
    }
}

/// The defmt log decoded by `defmt-print`, when it is installed.
pub fn decode_log(elf: &Path, log: &Path) -> Option<String> {
    let input = File::open(log).ok()?;
    let out = Command::new("defmt-print").arg("-e").arg(elf).stdin(input).output().ok()?;
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let _ = fs::write(log.with_extension("log"), &text);
    Some(text)
}

fn fault_test(root: &Path, qemu: &Path, bins: &Bins) -> Result<()> {
    let log = out_dir(root)?.join("fault.defmt");
    let mut q = Qemu::start(qemu, &bins.fault, "null", &log, &[])?;
    let status = q.wait(Duration::from_secs(30))?;
    if status.success() {
        q.show_log();
        bail!("the fault image exited with success; a HardFault must end the run with failure");
    }
    if let Some(text) = decode_log(&q.elf, &q.log) {
        ensure!(text.contains("HardFault"), "the fault image's log does not name the HardFault:\n{text}");
    }
    eprintln!("xtask: fault image ended with {status} as it must");
    Ok(())
}

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

fn golden_test(root: &Path, qemu: &Path, bins: &Bins, fx: &Fixtures) -> Result<()> {
    let dir = out_dir(root)?;
    let uart = dir.join("golden.uart");
    let _ = fs::remove_file(&uart);
    let log = dir.join("golden.defmt");
    let started = Instant::now();
    let mut q = Qemu::start(qemu, &bins.golden, &format!("file:{}", uart.display()), &log, &[])?;
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
    eprintln!("xtask: golden: {} sets, {total} samples compensated by the device in {run_secs:.1} s", sets.len());
    let mut failures = Vec::new();
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
            "xtask: golden, {}: {} samples ({flagged} flagged, flags identical); max |device − host| per output = {} \
             ({} of {}; limit {} %)",
            g.name,
            g.inputs.len(),
            abs.join(", "),
            rel.join(", "),
            g.scale_name,
            100.0 * REL_TOL
        );
        at += g.inputs.len();
    }
    if !failures.is_empty() {
        let n = failures.len();
        failures.truncate(10);
        bail!("{n} golden samples differ beyond tolerance:\n  {}", failures.join("\n  "));
    }
    Ok(())
}

/// A QEMU serving the product image's serial port on a loopback TCP port (QEMU is the
/// server, so that the link client of xtask and `fbg-trainer stream` can take turns), and
/// xtask's link client on it while connected.
pub struct LinkSession {
    /// The emulator (killed on drop).
    pub qemu: Qemu,
    /// The port QEMU listens on.
    pub port: u16,
    link: Option<LinkClient<TcpStream>>,
}

/// A loopback port that was free a moment ago.
fn free_port() -> Result<u16> {
    let l = TcpListener::bind("127.0.0.1:0").context("binding a loopback port")?;
    Ok(l.local_addr()?.port())
}

impl LinkSession {
    /// Start the product image with serial0 on a loopback server port and connect to it.
    pub fn start(root: &Path, qemu: &Path, elf: &Path, name: &str) -> Result<LinkSession> {
        let log = out_dir(root)?.join(format!("{name}.defmt"));
        let mut last = None;
        // The port is picked free, then bound by QEMU: retry in the unlikely case another
        // process took it in between.
        for _ in 0..3 {
            let port = free_port()?;
            // nodelay: the UART writes a byte at a time; with Nagle on QEMU's socket each answer
            // waits for the client's delayed ACK (≈ 40 ms per sample instead of ≈ 1 ms).
            let serial = format!("tcp:127.0.0.1:{port},server=on,wait=on,nodelay=on");
            let q = Qemu::start(qemu, elf, &serial, &log, &[])?;
            let mut s = LinkSession { qemu: q, port, link: None };
            match s.connect() {
                Ok(()) => return Ok(s),
                Err(e) => last = Some(e),
            }
        }
        Err(last.unwrap_or_else(|| anyhow::anyhow!("QEMU did not start")))
    }

    /// Connect xtask's link client (QEMU serves one client at a time).
    pub fn connect(&mut self) -> Result<()> {
        let deadline = Instant::now() + Duration::from_secs(20);
        let stream = loop {
            match TcpStream::connect(("127.0.0.1", self.port)) {
                Ok(s) => break s,
                Err(e) => {
                    if let Some(st) = self.qemu.try_exit()? {
                        self.qemu.show_log();
                        bail!("QEMU exited with {st} before serving its serial port ({e})");
                    }
                    ensure!(Instant::now() < deadline, "QEMU does not serve 127.0.0.1:{} after 20 s: {e}", self.port);
                    std::thread::sleep(Duration::from_millis(20));
                }
            }
        };
        stream.set_read_timeout(Some(Duration::from_secs(15)))?;
        stream.set_nodelay(true)?;
        self.link = Some(LinkClient::new(stream));
        eprintln!("xtask: connected to the device's serial port on 127.0.0.1:{}", self.port);
        Ok(())
    }

    /// Disconnect xtask's client (so that another client can connect).
    pub fn disconnect(&mut self) -> Result<()> {
        if let Some(link) = self.link.take() {
            ensure!(
                link.malformed_from_device() == 0,
                "the device sent {} malformed frames",
                link.malformed_from_device()
            );
        }
        // Give QEMU a moment to notice and listen again.
        std::thread::sleep(Duration::from_millis(50));
        Ok(())
    }

    /// The connected client.
    pub fn link(&mut self) -> Result<&mut LinkClient<TcpStream>> {
        self.link.as_mut().context("not connected to the device")
    }

    /// Fail with the device log when QEMU has exited (a crash shows as an exit).
    pub fn check_alive(&mut self) -> Result<()> {
        if let Some(st) = self.qemu.try_exit()? {
            self.qemu.show_log();
            bail!("the firmware exited with {st} while serving");
        }
        Ok(())
    }

    /// Run `fbg-trainer stream` against the device (xtask's client disconnected meanwhile) and
    /// return its JSON report.
    pub fn trainer_stream(&mut self, fx: &Fixtures, model: &Path, extra: &[&str]) -> Result<serde_json::Value> {
        self.disconnect()?;
        let mut cmd = Command::new(&fx.trainer);
        cmd.args(["stream", "--model"])
            .arg(model)
            .arg("--data")
            .arg(&fx.data)
            .args(["--port", &self.port.to_string(), "--json"])
            .args(extra)
            .stdin(Stdio::null())
            .stderr(Stdio::inherit());
        eprintln!("xtask: $ {}", crate::describe(&cmd));
        let out = cmd.output().with_context(|| format!("starting {}", fx.trainer.display()))?;
        if !out.status.success() {
            let _ = self.check_alive();
            bail!("`fbg-trainer stream` failed with {} (its report is above)", out.status);
        }
        let report: serde_json::Value =
            serde_json::from_slice(&out.stdout).context("`fbg-trainer stream --json` printed no JSON report")?;
        self.connect()?;
        Ok(report)
    }
}

fn expect_rejected(r: UpdateResult, reason: RejectReason, what: &str) -> Result<()> {
    match r {
        UpdateResult::Rejected(rej) if rej.reason == reason => {
            eprintln!("xtask: {what}: rejected as expected: {rej}");
            Ok(())
        }
        other => bail!("{what}: expected a rejection for {reason:?}, got {other:?}"),
    }
}

fn stream_summary(r: &serde_json::Value) -> String {
    let pct = |k: usize| r["max_diff_over_rmse"][k].as_f64().map(|v| format!("{:.4} %", 100.0 * v)).unwrap_or_default();
    format!(
        "{} samples, {} flagged, 0 mismatches; max |device − host| {} / {} / {} of the hold-out RMSE (T, ε, p) in {:.1} s",
        r["samples"],
        r["flagged"],
        pct(0),
        pct(1),
        pct(2),
        r["seconds"].as_f64().unwrap_or(f64::NAN)
    )
}

fn link_test(
    root: &Path,
    qemu: &Path,
    bins: &Bins,
    fx: &Fixtures,
    dfx: &DeviceFixtures,
    sfx: &SignedFixtures,
) -> Result<()> {
    let default = fs::read(firmware_dir(root).join("model/default.fbgm"))?;
    let update = fs::read(&dfx.update_model)?;
    let k64 = fs::read(&dfx.k64_model)?;
    let mut s = LinkSession::start(root, qemu, &bins.product, "link")?;
    let deadline = Instant::now() + Duration::from_secs(240);

    s.link()?.ping(0xC0FFEE).context("ping")?;
    let st0 = s.link()?.status()?;
    ensure!(Some(st0.model_crc) == stored_crc(&default), "active model crc {:#x} is not default.fbgm's", st0.model_crc);
    ensure!(st0.model_capacity as usize == PRODUCT_K, "capacity {}", st0.model_capacity);

    // 1. streaming end to end: the whole paper hold-out through the trainer's CLI.
    let r = s.trainer_stream(fx, &fx.model, &[])?;
    let streamed = r["samples"].as_u64().context("stream report without `samples`")? as u32;
    eprintln!("xtask: link: fbg-trainer stream (default model): {}", stream_summary(&r));

    // 2. garbage on the link.
    let before = s.link()?.status()?;
    let mut garbage = vec![0x01, 0x02, 0xFF, 0x00]; // framing error
    garbage.extend(std::iter::repeat_n(0x5Au8, 1000)); // oversize frame
    garbage.push(0);
    garbage.extend([0x07, 0x13, 0x37, 0x00]); // another framing error
    garbage.extend([0, 0, 0]); // idle fill, not counted
    s.link()?.send_raw(&garbage)?;
    s.link()?.ping(7).context("ping after garbage")?;
    let after = s.link()?.status()?;
    ensure!(
        after.frames_malformed == before.frames_malformed + 3,
        "malformed counter went from {} to {} (expected +3)",
        before.frames_malformed,
        after.frames_malformed
    );
    eprintln!("xtask: link: garbage counted ({} malformed) and the device kept serving", after.frames_malformed);

    // 3. corrupted and unfit updates are rejected; the old model keeps answering like the host.
    let mut corrupt = fs::read(&sfx.update)?;
    let mid = update.len() / 2;
    corrupt[mid] ^= 0x20;
    expect_rejected(s.link()?.update_model(&corrupt)?, RejectReason::BadSignature, "corrupted signed model")?;
    // A 64-centre blob does not even fit the K = 32 staging buffer: refused at ModelBegin.
    expect_rejected(s.link()?.update_model(&k64)?, RejectReason::TooLarge, "64-centre model on a K = 32 build")?;
    let st = s.link()?.status()?;
    ensure!(Some(st.model_crc) == stored_crc(&default), "model changed after rejected updates");
    ensure!(st.last_rejection.is_some(), "no rejection recorded");
    let r = s.trainer_stream(fx, &fx.model, &["--max-samples", "300"])?;
    let after_rejects = r["samples"].as_u64().unwrap_or(0) as u32;
    eprintln!("xtask: link: after the rejected updates the old model still matches the host: {}", stream_summary(&r));

    // 4. a valid (signed) update through the CLI, then its answers checked against the host.
    let r = s.trainer_stream(fx, &sfx.update, &["--update-first", "--max-samples", "2000"])?;
    let after_update = r["samples"].as_u64().unwrap_or(0) as u32;
    eprintln!(
        "xtask: link: fbg-trainer stream --update-first ({}, {} centres): {}",
        dfx.update_model.display(),
        r["centres"],
        stream_summary(&r)
    );

    let fin: Status = s.link()?.status()?;
    ensure!(Some(fin.model_crc) == stored_crc(&update), "the active model is not the update after it was accepted");
    ensure!(fin.model_serial == 1, "the active model's serial is {}, the update's is 1", fin.model_serial);
    ensure!(fin.updates_accepted == 1, "updates_accepted = {}", fin.updates_accepted);
    ensure!(fin.updates_rejected == 2, "updates_rejected = {}", fin.updates_rejected);
    let total = streamed + after_rejects + after_update;
    ensure!(fin.samples == total, "samples = {} (expected {total})", fin.samples);
    ensure!(fin.frames_malformed == 3, "frames_malformed = {}", fin.frames_malformed);
    s.disconnect()?;
    ensure!(Instant::now() < deadline, "link test took too long");
    s.check_alive()?;
    eprintln!("xtask: link: final status {fin:?}");
    Ok(())
}

/// The answers of the running model to `samples` from a fresh stream state, as bit patterns
/// (values, band) and flags, to compare bit for bit.
fn answers(s: &mut LinkSession, samples: &[fbg_shared::Sample<f32>]) -> Result<Vec<([u32; 6], String)>> {
    s.link()?.reset_stream(0xA11, fbg_shared::StreamClock::Calibration)?;
    samples
        .iter()
        .enumerate()
        .map(|(i, x)| {
            let e = s.link()?.compensate(i as u32, x)?;
            let v = e.values.iter().chain(e.band.iter()).map(|f| f.to_bits()).collect::<Vec<_>>();
            Ok(([v[0], v[1], v[2], v[3], v[4], v[5]], format!("{:?}", e.flags)))
        })
        .collect()
}

fn signed_update_test(root: &Path, qemu: &Path, bins: &Bins, fx: &Fixtures, sfx: &SignedFixtures) -> Result<()> {
    let default = fs::read(firmware_dir(root).join("model/default.fbgm"))?;
    let new = fs::read(&sfx.new)?;
    let new_blob = fbg_shared::container::strip(&new).to_vec();
    let test_key: [u8; 32] =
        fs::read(&sfx.test_pub)?.try_into().map_err(|_| anyhow::anyhow!("the test public key is not 32 bytes"))?;
    let test_id = fbg_shared::signature::key_id(&test_key);
    let samples: Vec<_> = fixtures::read_inputs(&fx.golden_inputs)?.into_iter().take(40).collect();
    let mut s = LinkSession::start(root, qemu, &bins.product, "signed")?;
    let st = s.link()?.status()?;
    ensure!(st.model_serial == 0 && st.model_key_id.is_none(), "the embedded model should read as unsigned: {st:?}");
    let embedded = answers(&mut s, &samples)?;

    // Accepted: the default model signed with serial 3 (the same model, so the same answers),
    // then the update model with serial 5.
    let accepted = |s: &mut LinkSession, path: &Path, serial: u64, crc: Option<u32>| -> Result<()> {
        let r = s.link()?.update_model(&fs::read(path)?)?;
        ensure!(matches!(r, UpdateResult::Accepted { .. }), "{}: {r:?}", path.display());
        let st = s.link()?.status()?;
        ensure!(
            (st.model_serial, st.model_key_id, Some(st.model_crc)) == (serial, Some(test_id), crc),
            "after accepting {}: serial {}, key {:?}, crc {:#x}",
            path.display(),
            st.model_serial,
            st.model_key_id,
            st.model_crc
        );
        eprintln!("xtask: signed: {} accepted (serial {serial}, key {test_id})", path.display());
        Ok(())
    };
    accepted(&mut s, &sfx.old, 3, stored_crc(&default))?;
    ensure!(
        answers(&mut s, &samples)? == embedded,
        "the default model signed answers differently from the embedded one"
    );
    accepted(&mut s, &sfx.new, 5, stored_crc(&new_blob))?;
    let running = answers(&mut s, &samples)?;
    ensure!(running != embedded, "the update model answers like the default one; the test would prove nothing");

    // Refused, each with its reason, the running model untouched.
    let mut tampered = new.clone();
    tampered[fbg_shared::blob::HEADER_LEN + 40] ^= 0x04; // one payload bit
    let cases: [(&str, Vec<u8>, RejectReason); 6] = [
        ("unsigned", new_blob.clone(), RejectReason::Unsigned),
        ("unknown key", fs::read(&sfx.stranger)?, RejectReason::UnknownKey),
        ("tampered after signing (one payload bit)", tampered, RejectReason::BadSignature),
        ("older serial replayed (3 < 5)", fs::read(&sfx.old)?, RejectReason::Rollback),
        ("another model under the running serial 5 (a swap)", fs::read(&sfx.swap)?, RejectReason::SerialReused),
        ("a rollback of serial 5, on the default build", fs::read(&sfx.rollback)?, RejectReason::RollbackNotPermitted),
    ];
    for (what, bytes, reason) in &cases {
        expect_rejected(s.link()?.update_model(bytes)?, *reason, what)?;
        let st = s.link()?.status()?;
        ensure!(
            (st.model_serial, Some(st.model_crc)) == (5, stored_crc(&new_blob)),
            "{what}: the active model changed (serial {}, crc {:#x})",
            st.model_serial,
            st.model_crc
        );
        ensure!(
            answers(&mut s, &samples)? == running,
            "{what}: the running model no longer answers bit for bit as before"
        );
    }
    let st = s.link()?.status()?;
    let want =
        fbg_shared::protocol::Refusals { unsigned: 1, bad_signature: 1, unknown_key: 1, rollback: 2, serial_reused: 1 };
    ensure!(st.refused == want, "refusals by reason {:?}, expected {want:?}", st.refused);
    ensure!(
        (st.updates_accepted, st.updates_rejected) == (2, 6),
        "accepted/refused {:?}",
        (st.updates_accepted, st.updates_rejected)
    );
    eprintln!("xtask: signed: every bad update refused with its reason; the running model answered bit for bit as before each time");

    // Issue 28, item 6: begins without data erase nothing (at most the one a written slot needs).
    let before = st.staging_erases;
    let begin = fbg_shared::protocol::HostMsg::ModelBegin {
        total_len: new.len() as u32,
        crc32: fbg_shared::protocol::crc32(&new),
    };
    for i in 0..1000 {
        let r = s.link()?.request(&begin)?;
        ensure!(matches!(r, DeviceMsg::UpdateProgress { received: 0 }), "ModelBegin {i}: {r:?}");
    }
    let erases = s.link()?.status()?.staging_erases - before;
    ensure!(erases <= 1, "1 000 ModelBegin frames erased the staging slot {erases} times");
    eprintln!(
        "xtask: signed: 1 000 ModelBegin frames, {erases} staging erase(s) (slot erases since boot: {})",
        before + erases
    );

    // The audit trail through the CLI.
    s.disconnect()?;
    let out = Command::new(&fx.trainer)
        .args(["device", "status", "--port", &s.port.to_string()])
        .stdin(Stdio::null())
        .output()
        .context("running fbg-trainer device status")?;
    let text = String::from_utf8_lossy(&out.stdout);
    ensure!(out.status.success(), "fbg-trainer device status failed: {}", String::from_utf8_lossy(&out.stderr));
    for needle in [
        format!("serial 5, signed by key {test_id}"),
        "2 accepted, 6 refused (1 unsigned, 1 bad signature, 1 unknown key, 2 rollback, 1 serial reused, 0 other)"
            .to_string(),
        format!("staging slot: {} erases since boot", before + erases),
    ] {
        ensure!(text.contains(&needle), "`fbg-trainer device status` does not say `{needle}`:\n{text}");
    }
    eprint!("xtask: signed: fbg-trainer device status:\n{text}");
    s.connect()?;
    s.disconnect()?;
    s.check_alive()?;
    Ok(())
}

/// Issue 28, item 3, on the `rollback` image (the product with rollbacks accepted): the
/// rollback signed to replace serial 5 is refused over serial 3, accepted over serial 5,
/// refused when replayed over itself (serial 4 now runs) and after the device moved on to
/// serial 9; the swap is refused there too.
fn rollback_test(root: &Path, qemu: &Path, bins: &Bins, sfx: &SignedFixtures) -> Result<()> {
    let default = fs::read(firmware_dir(root).join("model/default.fbgm"))?;
    let new = fs::read(&sfx.new)?;
    let new_crc = stored_crc(fbg_shared::container::strip(&new));
    let rollback = fs::read(&sfx.rollback)?;
    let mut s = LinkSession::start(root, qemu, &bins.rollback, "rollback")?;
    let step = |s: &mut LinkSession, what: &str, path: &Path, want: Option<RejectReason>, after: (u64, Option<u32>)| {
        let r = s.link()?.update_model(&fs::read(path)?)?;
        match want {
            None => ensure!(matches!(r, UpdateResult::Accepted { .. }), "{what}: {r:?}"),
            Some(reason) => expect_rejected(r, reason, what)?,
        }
        let st = s.link()?.status()?;
        ensure!(
            (st.model_serial, Some(st.model_crc)) == after,
            "{what}: running serial {}, crc {:#x}, expected {after:?}",
            st.model_serial,
            st.model_crc
        );
        eprintln!("xtask: rollback: {what}: {}", if want.is_none() { "accepted" } else { "refused" });
        Ok(())
    };
    step(&mut s, "serial 3", &sfx.old, None, (3, stored_crc(&default)))?;
    step(
        &mut s,
        "the rollback over serial 3",
        &sfx.rollback,
        Some(RejectReason::RollbackNotPermitted),
        (3, stored_crc(&default)),
    )?;
    step(&mut s, "serial 5", &sfx.new, None, (5, new_crc))?;
    step(&mut s, "another model under serial 5", &sfx.swap, Some(RejectReason::SerialReused), (5, new_crc))?;
    step(&mut s, "the rollback over serial 5", &sfx.rollback, None, (4, stored_crc(&default)))?;
    step(
        &mut s,
        "the rollback replayed over itself",
        &sfx.rollback,
        Some(RejectReason::RollbackNotPermitted),
        (4, stored_crc(&default)),
    )?;
    step(&mut s, "serial 9", &sfx.later, None, (9, new_crc))?;
    step(
        &mut s,
        "the rollback after the device moved on",
        &sfx.rollback,
        Some(RejectReason::RollbackNotPermitted),
        (9, new_crc),
    )?;
    let st = s.link()?.status()?;
    ensure!(
        (st.updates_accepted, st.updates_rejected, st.refused.rollback, st.refused.serial_reused) == (4, 4, 3, 1),
        "after the rollback test: {st:?}"
    );
    ensure!(rollback.len() == fbg_shared::container::strip(&rollback).len() + fbg_shared::signature::TRAILER_V2_LEN);
    s.disconnect()?;
    s.check_alive()?;
    Ok(())
}

/// Minimum length of the long memory stream: 14 days at 60 s (DESIGN §8).
pub const LONG_STREAM_MIN: usize = 20_160;

/// The inputs of every row of a dataset CSV (`t_s`, `T_amb_C`, `dl1_pm`..`dl3_pm`; an empty or
/// unreadable field is NaN, as the device would receive it), rounded to f32 as the link sends
/// them.
pub fn read_dataset_inputs(path: &Path) -> Result<Vec<fbg_shared::Sample<f32>>> {
    let text = fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    // The record's λ_ref and start time are `#` comment lines before the header.
    let mut lines = text.lines().skip_while(|l| l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').map(str::trim).collect();
    let col = |name: &str| {
        header.iter().position(|h| *h == name).with_context(|| format!("{}: no column `{name}`", path.display()))
    };
    let cols = [col("dl1_pm")?, col("dl2_pm")?, col("dl3_pm")?, col("T_amb_C")?, col("t_s")?];
    let mut out = Vec::new();
    for line in lines.filter(|l| !l.trim().is_empty()) {
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let v = cols.map(|c| f.get(c).and_then(|x| x.parse::<f64>().ok()).unwrap_or(f64::NAN) as f32);
        out.push(fbg_shared::Sample::new([v[0], v[1], v[2]], v[3], v[4]));
    }
    Ok(out)
}

/// `samples` with their time stamps made irregular: each keeps its own t plus the deviation of
/// `fbg_testkit::installation::irregular_clock` from a regular 60 s clock (steps of 60.5, 23 and 131 s, repeated
/// stamps, and a 5 h gap at 3/5 of the stream, after which every stamp is 5 h later).
pub fn with_irregular_clock(samples: &[fbg_shared::Sample<f32>]) -> Vec<fbg_shared::Sample<f32>> {
    let clock = fbg_testkit::installation::irregular_clock(samples.len(), 0.0);
    samples
        .iter()
        .zip(clock.iter())
        .enumerate()
        .map(|(i, (s, &c))| {
            let mut s = *s;
            s.t_s = (s.t_s as f64 + (c - 60.0 * i as f64)) as f32;
            s
        })
        .collect()
}

fn long_memory_test(root: &Path, qemu: &Path, bins: &Bins, fx: &Fixtures) -> Result<()> {
    let default = fs::read(firmware_dir(root).join("model/default.fbgm"))?;
    let has_memory = fixtures::decode(&default)?.has_memory();
    let (model, which) = if has_memory {
        (default.clone(), "the default model (its own memory terms)")
    } else {
        (
            fbg_testkit::installation::with_full_memory(&default)?,
            "the default model with the full memory bank added (it has no memory terms)",
        )
    };
    let terms = fixtures::memory_terms(&model)?;
    let (scale, scale_name) = golden_scale(fx, &default)?;
    let tol: Vec<f64> = scale.iter().map(|s| REL_TOL * s).collect();
    let samples = with_irregular_clock(&read_dataset_inputs(&fx.data)?);
    ensure!(
        samples.len() >= LONG_STREAM_MIN,
        "{} has {} samples; the long memory test needs at least {LONG_STREAM_MIN} (14 days at 60 s)",
        fx.data.display(),
        samples.len()
    );
    let mut host = fixtures::host_compensator(&model)?;
    // The samples are the model's own record: lead on the calibration clock, on both sides.
    host.set_clock(fbg_shared::StreamClock::Calibration);
    let mut s = LinkSession::start(root, qemu, &bins.product, "memory")?;
    if model != default {
        match s.link()?.update_model(&model)? {
            UpdateResult::Accepted { .. } => {}
            other => bail!("the memory model was refused: {other:?}"),
        }
    }
    s.link()?.reset_stream(1, fbg_shared::StreamClock::Calibration)?;
    let started = Instant::now();
    let day = 1440.min(samples.len() / 2);
    let n = samples.len();
    let mut worst = [0.0f64; 3];
    let mut first_day = [0.0f64; 3];
    let mut last_day = [0.0f64; 3];
    let mut flagged = 0usize;
    let mut failures = Vec::new();
    for (i, x) in samples.iter().enumerate() {
        let e = s.link()?.compensate(i as u32, x).with_context(|| format!("sample {i}"))?;
        let want = host.step(&x.cast());
        if !e.flags.is_ok() {
            flagged += 1;
        }
        if let Err(why) = compare(&e, &want, &tol) {
            failures.push(format!("sample {i} (t = {} s): {why}", x.t_s));
        }
        let d = abs_diff(&e.values, &want.values);
        for c in 0..3 {
            worst[c] = worst[c].max(d[c]);
            if i < day {
                first_day[c] = first_day[c].max(d[c]);
            }
            if i >= n - day {
                last_day[c] = last_day[c].max(d[c]);
            }
        }
    }
    let secs = started.elapsed().as_secs_f64();
    let st = s.link()?.status()?;
    s.disconnect()?;
    s.check_alive()?;
    let pct = |v: [f64; 3]| {
        format!("{:.4} / {:.4} / {:.4} %", 100.0 * v[0] / scale[0], 100.0 * v[1] / scale[1], 100.0 * v[2] / scale[2])
    };
    eprintln!(
        "xtask: memory stream: {which}, {terms} memory terms, {} centres; {n} samples (14 days, irregular clock, 5 h gap), \
         {flagged} flagged, flags identical; max |device − host| = {:.3e} °C, {:.3e} µε, {:.3e} kPa = {} of {scale_name} \
         (limit {} %); first day {}, last day {}; {:.1} s ({:.2} ms per sample)",
        fixtures::decode(&model)?.centres.len(),
        worst[0],
        worst[1],
        worst[2],
        pct(worst),
        100.0 * REL_TOL,
        pct(first_day),
        pct(last_day),
        secs,
        1e3 * secs / n as f64
    );
    ensure!(st.samples as usize == n, "the device counted {} samples, {n} were sent", st.samples);
    if !failures.is_empty() {
        let k = failures.len();
        failures.truncate(10);
        bail!("{k} of {n} samples of the memory stream differ beyond tolerance:\n  {}", failures.join("\n  "));
    }
    Ok(())
}
