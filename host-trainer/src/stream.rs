//! `fbg-trainer stream`: drive a running device (QEMU's serial port on a TCP socket, or a board
//! behind a serial-to-TCP bridge) over the link protocol and check every answer.
//!
//! The hold-out samples of a dataset go to the device as it would receive them (every field
//! rounded to f32), in order, from a reset stream state; each estimate is compared with
//! `fbg_shared::Compensator<f64>` on the same model fed the same samples: per channel
//! |device − host| ≤ 1 % of the model's hold-out RMSE (DESIGN §8) for the value and the 95 %
//! band, NaN against NaN, ∞ against ∞, and identical flags.
//!
//! The device must run the model given: with `--update-first` it is sent over the link first
//! (and must be accepted); otherwise the device's active model CRC must be the blob's.

use std::io::ErrorKind;
use std::net::{TcpStream, ToSocketAddrs};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use fbg_link::parity::{abs_diff, compare};
use fbg_link::{LinkClient, LinkError};
use fbg_shared::protocol::{Status, UpdateResult};
use fbg_shared::Compensator;

use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::score::{channels, evaluate_holdout, units};
use crate::export::read_blob;
use crate::fit::HOST_CAP;

/// Device vs host tolerance as a fraction of Model-H's hold-out RMSE.
pub use fbg_link::parity::REL_TOL;

/// What to stream where.
#[derive(Clone, Debug)]
pub struct StreamOptions {
    /// The model blob the device runs (or is sent, with `update_first`).
    pub model: PathBuf,
    /// Dataset whose hold-out samples are streamed.
    pub data: PathBuf,
    /// Device address.
    pub host: String,
    /// Device TCP port.
    pub port: u16,
    /// Send the model to the device before streaming.
    pub update_first: bool,
    /// Stream at most this many hold-out samples (all when `None`).
    pub max_samples: Option<usize>,
    /// A progress bar on stderr (shown on a terminal only).
    pub progress: bool,
    /// How long to wait for the device to accept the connection, and for each answer whole
    /// (request sent to the answer's last byte): the stream makes progress when every sample,
    /// model-transfer step and status request is answered within it; the whole stream may last
    /// longer.
    pub timeout: Duration,
}

/// The outcome of a stream.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StreamReport {
    /// The device address.
    pub device: String,
    /// The model's blob CRC (what the device reported as active).
    pub model_crc: u32,
    /// RBF centres of the model.
    pub centres: usize,
    /// Whether the model was sent first (and accepted).
    pub updated: bool,
    /// Samples streamed and checked.
    pub samples: usize,
    /// Samples with any value or band beyond tolerance.
    pub value_mismatches: usize,
    /// Samples whose flags differ from the host's.
    pub flag_mismatches: usize,
    /// Samples the device flagged (any flag).
    pub flagged: usize,
    /// The model's outputs (`T`, `strain`, …): every per-channel list below follows it.
    pub channels: Vec<String>,
    /// Their units.
    pub units: Vec<String>,
    /// max |device − host| of the values per channel (finite pairs).
    pub max_abs_diff: Vec<f64>,
    /// The same for the 95 % band half-widths.
    pub max_band_diff: Vec<f64>,
    /// The model's hold-out RMSE per channel (from evaluate).
    pub holdout_rmse: Vec<f64>,
    /// `max_abs_diff / holdout_rmse` (the limit is [`REL_TOL`]).
    pub max_diff_over_rmse: Vec<f64>,
    /// The tolerance used per channel.
    pub tolerance: Vec<f64>,
    /// The first few mismatches, described.
    pub first_mismatches: Vec<String>,
    /// Wall time of the stream \[s\].
    pub seconds: f64,
    /// The device's status after the stream (counters, active model and its signature, refused
    /// updates by reason).
    pub device_status: Option<Status>,
}

/// The device's status as the audit trail reads: the active model (digest, serial, signer),
/// the updates accepted and refused, by reason (lifetime counts from the device's event log,
/// plus this boot's refusals the log did not take), the link's counters, and the model store:
/// where the model booted from, the rollback floor, the log and the wear of every sector.
pub fn status_text(st: &Status) -> String {
    let store = &st.store;
    let booted = match store.boot_source {
        fbg_shared::protocol::BootSource::Embedded => "the embedded default".to_string(),
        fbg_shared::protocol::BootSource::Slot { slot, generation } => {
            format!("slot {} (generation {generation})", if slot == 0 { 'A' } else { 'B' })
        }
    };
    let [a, b, l0, l1] = store.erases;
    let boot_time = match store.boot_time_us {
        0 => "not measured".to_string(),
        us => format!("{:.3} ms", f64::from(us) / 1000.0),
    };
    let store_text = format!(
        concat!(
            "model store: booted from {}; rollback floor: serial {}; event log: {} events, {} refusals not logged since boot; ",
            "erases per sector: slot A {}, slot B {}, log {} / {}; {} flash operations since boot; boot to first frame {}\n",
        ),
        booted, store.rollback_floor, store.log_events, store.refusals_unlogged, a, b, l0, l1, store.flash_ops, boot_time
    );
    let signer = match st.model_key_id {
        Some(id) => format!("serial {}, signed by key {id}", st.model_serial),
        None => "unsigned (the embedded default, trusted as part of the firmware image)".to_string(),
    };
    let r = &st.refused;
    let last = st.last_rejection.map(|r| format!("; last refusal: {r}")).unwrap_or_default();
    format!(
        concat!(
            "active model: crc {:#010x} (digest), {} centres (capacity {}), {}\n",
            "model updates: {} accepted, {} refused ({} unsigned, {} bad signature, {} unknown key, {} rollback, {} serial reused, {} other){}\n",
            "link: {} frames, {} malformed, {} samples compensated; stack peak {} B since boot (serving and updates), {} B during boot\n",
            "staging slot: {} erases since boot\n",
            "{}",
            "{}",
        ),
        st.model_crc,
        st.model_centres,
        st.model_capacity,
        signer,
        st.updates_accepted,
        st.updates_rejected,
        r.unsigned,
        r.bad_signature,
        r.unknown_key,
        r.rollback,
        r.serial_reused,
        st.updates_rejected.saturating_sub(
            r.unsigned.saturating_add(r.bad_signature).saturating_add(r.unknown_key).saturating_add(r.rollback).saturating_add(r.serial_reused)
        ),
        last,
        st.frames_ok,
        st.frames_malformed,
        st.samples,
        st.stack_peak_bytes,
        st.stack_boot_bytes,
        st.staging_erases,
        store_text,
        spectra_text(&st.spectra)
    )
}

/// The spectrum counters' line (empty when the device never saw a spectrum message).
fn spectra_text(sp: &fbg_shared::protocol::SpectrumStatus) -> String {
    if sp.frames == 0 && sp.refused == 0 && sp.frames_dropped == 0 {
        return String::new();
    }
    let last =
        sp.last_refusal.map(|r| format!("; last refusal: {:?} (detail {})", r.reason, r.detail)).unwrap_or_default();
    format!(
        "\nspectrum frames: {} whole, {} dropped, {} messages refused{last}",
        sp.frames, sp.frames_dropped, sp.refused
    )
}

/// Connect to the device at `host:port` and read its status, the connection and the whole
/// answer within `timeout` together.
pub fn device_status(host: &str, port: u16, timeout: Duration) -> Result<Status, TrainerError> {
    let addr = format!("{host}:{port}");
    let t0 = Instant::now();
    let stream = connect(&addr, timeout)?;
    let left = timeout.saturating_sub(t0.elapsed()).max(Duration::from_millis(1));
    let mut link = link_with_deadline(stream, left)?;
    link.status().map_err(|e| match e {
        // The answer's deadline is what the connection left of `timeout`: name the user's.
        LinkError::TimedOut { received, .. } => link_err("status", LinkError::TimedOut { timeout, received }),
        e => link_err("status", e),
    })
}

/// A client whose every answer (request sent to the answer's last byte) is due within
/// `timeout`; writes are bounded by it too.
fn link_with_deadline(stream: TcpStream, timeout: Duration) -> Result<LinkClient<TcpStream>, TrainerError> {
    stream.set_nodelay(true).map_err(|e| TrainerError::device(chain(&e)))?;
    stream.set_write_timeout(Some(timeout)).map_err(|e| TrainerError::device(chain(&e)))?;
    LinkClient::with_answer_timeout(stream, timeout).map_err(|e| TrainerError::device(chain(&e)))
}

/// An error and its causes, `: `-separated (as the command line prints an error).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        s.push_str(&format!(": {c}"));
        cause = c.source();
    }
    s
}

impl StreamReport {
    /// True when every estimate matched.
    pub fn ok(&self) -> bool {
        self.value_mismatches == 0 && self.flag_mismatches == 0
    }

    /// A human summary.
    pub fn text(&self) -> String {
        let mut s = format!(
            "{} samples streamed to {} (model crc {:#010x}, {} centres{}) in {:.1} s: {} value/band mismatches, {} flag mismatches, {} flagged\n",
            self.samples,
            self.device,
            self.model_crc,
            self.centres,
            if self.updated { ", sent first" } else { "" },
            self.seconds,
            self.value_mismatches,
            self.flag_mismatches,
            self.flagged
        );
        for c in 0..self.channels.len() {
            s.push_str(&format!(
                "  {:>6} [{}]: max |device − host| {:.3e} ({:.4} % of the hold-out RMSE {:.4}; limit {} %), band {:.3e}\n",
                self.channels[c],
                self.units[c],
                self.max_abs_diff[c],
                100.0 * self.max_diff_over_rmse[c],
                self.holdout_rmse[c],
                100.0 * REL_TOL,
                self.max_band_diff[c]
            ));
        }
        for m in &self.first_mismatches {
            s.push_str(&format!("  mismatch: {m}\n"));
        }
        if let Some(st) = &self.device_status {
            s.push_str(&status_text(st));
        }
        s
    }
}

fn connect(addr: &str, timeout: Duration) -> Result<TcpStream, TrainerError> {
    let deadline = Instant::now() + timeout;
    let sockets: Vec<_> =
        addr.to_socket_addrs().map_err(|e| TrainerError::device(format!("resolving {addr}: {}", chain(&e))))?.collect();
    loop {
        let mut last = None;
        for a in &sockets {
            let left = deadline.saturating_duration_since(Instant::now());
            match TcpStream::connect_timeout(a, left.clamp(Duration::from_millis(1), Duration::from_secs(1))) {
                Ok(s) => return Ok(s),
                Err(e) => last = Some(e),
            }
        }
        if Instant::now() >= deadline {
            let e = last.map(|e| e.to_string()).unwrap_or_else(|| "no address".into());
            return Err(TrainerError::device(format!(
                "cannot connect to the device at {addr} within {timeout:?}: {e}"
            )));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn link_err(what: &str, e: LinkError) -> TrainerError {
    TrainerError::device(match &e {
        LinkError::Io(io) if matches!(io.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
            format!("{what}: the device did not answer in time ({e})")
        }
        LinkError::TimedOut { .. } => format!("{what}: timed out: {e} (--timeout)"),
        _ => format!("{what}: {e}"),
    })
}

/// Stream the hold-out of `opts.data` to the device and check every answer.
pub fn run(opts: &StreamOptions) -> Result<StreamReport, TrainerError> {
    let bytes = std::fs::read(&opts.model).map_err(|e| TrainerError::Model {
        path: opts.model.display().to_string(),
        message: format!("cannot read: {}", chain(&e)),
    })?;
    let model = read_blob(&opts.model)?;
    // A signed model's digest is its blob's CRC, before the signature trailer.
    let crc = fbg_shared::blob::stored_crc(fbg_shared::container::strip(&bytes)).unwrap_or(0);
    let data = Dataset::read_csv(&opts.data)?;
    data.inputs_for(&model.dims, &opts.data.display().to_string(), "stream")?;
    let m = model.dims.n_outputs();
    let hold = data.holdout_indices();
    if hold.is_empty() {
        return Err(TrainerError::device(format!("{}: no hold-out rows to stream", opts.data.display())));
    }
    let (eval, _) = evaluate_holdout(&model, &data)?;
    let holdout_rmse: Vec<f64> = eval.channels.iter().map(|c| c.rmse).collect();
    // An unfitted channel has no RMSE: its values are NaN on both sides, compared as such.
    let tolerance: Vec<f64> = holdout_rmse.iter().map(|&r| if r.is_finite() { REL_TOL * r } else { 0.0 }).collect();
    let idx: Vec<usize> = match opts.max_samples {
        Some(n) => hold.into_iter().take(n).collect(),
        None => hold,
    };

    let device = format!("{}:{}", opts.host, opts.port);
    let stream = connect(&device, opts.timeout)?;
    let mut link = link_with_deadline(stream, opts.timeout)?;
    link.ping(0x5EED).map_err(|e| link_err("ping", e))?;
    if opts.update_first {
        match link.update_model(&bytes).map_err(|e| link_err("model update", e))? {
            UpdateResult::Accepted { crc: got, .. } if got == crc => {}
            UpdateResult::Accepted { crc: got, .. } => {
                return Err(TrainerError::device(format!(
                    "the device accepted the model but reports crc {got:#010x}, not the blob's {crc:#010x}"
                )))
            }
            UpdateResult::Rejected(r) => {
                return Err(TrainerError::device(format!("the device refused {}: {r}", opts.model.display())))
            }
        }
    }
    let st = link.status().map_err(|e| link_err("status", e))?;
    if st.model_crc != crc {
        return Err(TrainerError::device(format!(
            "the device runs the model with crc {:#010x}, not {} ({crc:#010x}); pass --update-first to send it",
            st.model_crc,
            opts.model.display()
        )));
    }
    // Both sides start from a fresh stream state.
    // The hold-out of the model's own record: the band's lead on that record's clock.
    let clock = data.calibration_clock(&model);
    link.reset_stream(0x5EED + 1, clock).map_err(|e| link_err("reset", e))?;
    let mut reference = Compensator::<f64, HOST_CAP>::new(&model)
        .map_err(|e| TrainerError::Model { path: opts.model.display().to_string(), message: e.to_string() })?;
    reference.set_clock(clock);

    let t0 = Instant::now();
    let mut report = StreamReport {
        device,
        model_crc: crc,
        centres: model.centres.len(),
        updated: opts.update_first,
        samples: 0,
        value_mismatches: 0,
        flag_mismatches: 0,
        flagged: 0,
        channels: channels(&model.dims),
        units: units(&model.dims),
        max_abs_diff: vec![0.0; m],
        max_band_diff: vec![0.0; m],
        holdout_rmse: holdout_rmse.clone(),
        max_diff_over_rmse: vec![0.0; m],
        tolerance: tolerance.clone(),
        first_mismatches: Vec::new(),
        seconds: 0.0,
        device_status: None,
    };
    let bar = crate::progress::bar(opts.progress, idx.len() as u64, "stream");
    for (n, &i) in idx.iter().enumerate() {
        bar.inc(1);
        let x = data.sample(i).cast::<f32>();
        let seq = n as u32;
        let got = link.compensate(seq, &x).map_err(|e| link_err(&format!("sample {n} (data row {})", i + 2), e))?;
        let want = reference.step(&x.cast());
        report.samples += 1;
        if !got.flags.is_ok() {
            report.flagged += 1;
        }
        let (dv, db) = (abs_diff(&got.values, &want.values), abs_diff(&got.band, &want.band95));
        for c in 0..m {
            report.max_abs_diff[c] = report.max_abs_diff[c].max(dv[c]);
            report.max_band_diff[c] = report.max_band_diff[c].max(db[c]);
        }
        if let Err(why) = compare(&got, &want, &tolerance) {
            if got.flags != want.flags {
                report.flag_mismatches += 1;
            } else {
                report.value_mismatches += 1;
            }
            if report.first_mismatches.len() < 10 {
                report.first_mismatches.push(format!("sample {n} (data row {}): {why}", i + 2));
            }
        }
    }
    bar.finish_and_clear();
    report.seconds = t0.elapsed().as_secs_f64();
    report.max_diff_over_rmse = (0..m).map(|c| report.max_abs_diff[c] / holdout_rmse[c]).collect();
    report.device_status = Some(link.status().map_err(|e| link_err("status", e))?);
    if link.malformed_from_device() != 0 {
        return Err(TrainerError::device(format!("the device sent {} malformed frames", link.malformed_from_device())));
    }
    Ok(report)
}
