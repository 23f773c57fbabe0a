//! The link test: streaming through `fbg-trainer stream`, garbage on the line, rejected and
//! accepted model updates, on the product image over a loopback TCP serial port.

use std::fs;
use std::path::Path;
use std::time::{Duration, Instant};

use anyhow::{ensure, Context, Result};
use fbg_shared::blob::stored_crc;
use fbg_shared::protocol::{RejectReason, Status};

use super::expect_rejected;
use crate::firmware::session::LinkSession;
use crate::firmware::{self, Bins};
use crate::fixtures::{DeviceFixtures, Fixtures};
use crate::signing::SignedFixtures;
use crate::targets::PRODUCT_K;

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

pub(super) fn link_test(
    root: &Path,
    qemu: &Path,
    bins: &Bins,
    fx: &Fixtures,
    dfx: &DeviceFixtures,
    sfx: &SignedFixtures,
) -> Result<()> {
    let default = fs::read(firmware::dir(root).join("model/default.fbgm"))?;
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
