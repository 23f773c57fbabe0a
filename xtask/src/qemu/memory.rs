//! A memory model over the whole 14-day paper stream on the product image, every answer
//! against the host's f64.

use std::fs;
use std::path::Path;
use std::time::Instant;

use anyhow::{bail, ensure, Context, Result};
use fbg_link::parity::{abs_diff, compare, REL_TOL};
use fbg_shared::protocol::{DeviceMsg, HostMsg, UpdateResult};

use crate::firmware::golden::golden_scale;
use crate::firmware::session::LinkSession;
use crate::firmware::{self, Bins};
use crate::fixtures::{self, Fixtures};

/// Minimum length of the long memory stream: 14 days at 60 s (DESIGN §8).
pub const LONG_STREAM_MIN: usize = 20_160;

/// Samples of the long stream in flight at once.
const AHEAD: usize = 32;

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

pub(super) fn long_memory_test(root: &Path, qemu: &Path, bins: &Bins, fx: &Fixtures) -> Result<()> {
    let default = fs::read(firmware::dir(root).join("model/default.fbgm"))?;
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
    // Pipelined: up to AHEAD samples in flight, their answers read in order. QEMU's serial
    // backend holds what the device's receive register cannot take yet, so none is lost;
    // one request per round trip spent most of the run waiting on the emulator's event loop.
    let link = s.link()?;
    let mut sent = 0usize;
    for (i, x) in samples.iter().enumerate() {
        while sent < n && sent < i + AHEAD {
            let sample = *samples.get(sent).context("a sample to send")?;
            link.send(&HostMsg::Sample { seq: sent as u32, sample })
                .with_context(|| format!("sending sample {sent}"))?;
            sent += 1;
        }
        let e = match link.recv().with_context(|| format!("sample {i}"))? {
            DeviceMsg::Estimate(e) if e.seq == i as u32 => e,
            got => bail!("sample {i}: the device answered {got:?}, not its estimate"),
        };
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
