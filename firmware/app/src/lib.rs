//! Hardware-independent application logic of the FBG firmware: frame handling, message
//! dispatch, model updates, counters and the alarm output.
//!
//! It talks to the board only through `embedded-io` (`Read`/`Write` for the serial link) and
//! `embedded-hal` (`OutputPin` for the alarm), so the very code that runs on the Cortex-M4F is
//! unit-tested on the host with in-memory streams and a recording pin (`cargo test` in
//! `firmware/` for the host target; `cargo xtask test` does it).
//!
//! Memory: the device borrows its two big buffers, the active [`Compensator`] and the blob
//! staging area, from the caller (the firmware puts them in statics), so nothing large is moved
//! or copied on the serving path. Loading a model ([`load_into`], and a committed update) needs
//! a decoded `ModelParams` and the folded compensator on the stack for the duration of the load.
//!
//! No heap, no panicking paths.

#![no_std]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use core::convert::Infallible;
use core::mem::MaybeUninit;

use embedded_hal::digital::{OutputPin, PinState};
use embedded_io::{Read, Write};
use fbg_shared::blob;
use fbg_shared::protocol::{
    crc32, encode_device, DeviceEstimate, DeviceMsg, Feed, FrameReader, HostMsg, Malformed,
    RejectReason, Rejection, Status, UpdateResult, DEVICE_MAX_FRAME, HOST_MAX_FRAME,
};
use fbg_shared::{Compensator, ModelParams, Sample};

/// Log through defmt when the `defmt` feature is on; nothing otherwise.
macro_rules! log {
    ($level:ident, $($arg:tt)*) => {
        #[cfg(feature = "defmt")]
        defmt::$level!($($arg)*);
    };
}

/// Identity of a loaded model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ModelInfo {
    /// RBF centres in use.
    pub centres: u16,
    /// The blob's CRC trailer.
    pub crc: u32,
}

/// The CRC trailer of a blob (its last four bytes, little-endian); 0 for a too-short input.
pub fn blob_crc(bytes: &[u8]) -> u32 {
    let tail = bytes.len().checked_sub(blob::CRC_LEN).and_then(|at| bytes.get(at..));
    let mut t = [0u8; blob::CRC_LEN];
    match tail {
        Some(tail) if tail.len() == t.len() => {
            t.copy_from_slice(tail);
            u32::from_le_bytes(t)
        }
        _ => 0,
    }
}

/// Decode and fully validate `bytes` ([`blob::decode`]), fold it into a compensator in `slot`
/// and return it with its identity. Nothing is written to `slot` on failure.
///
/// Never inlined: the decode temporaries then live only during the call, not in the caller's
/// frame for the rest of its life (the firmware's `main` serves forever).
#[inline(never)]
pub fn load_into<'s, const K: usize>(
    slot: &'s mut MaybeUninit<Compensator<f32, K>>,
    bytes: &[u8],
) -> Result<(&'s mut Compensator<f32, K>, ModelInfo), Rejection> {
    let decoded = blob::decode::<K>(bytes);
    let params = match &decoded {
        Ok(p) => p,
        Err(e) => return Err(Rejection::from(*e)),
    };
    let comp = fold_into_uninit(slot, params)?;
    let info = ModelInfo { centres: centres_u16(comp.n_centres()), crc: blob_crc(bytes) };
    Ok((comp, info))
}

/// Replace `comp` by the model in `bytes` when, and only when, it is entirely valid.
#[inline(never)]
fn swap_model<const K: usize>(
    comp: &mut Compensator<f32, K>,
    bytes: &[u8],
) -> Result<ModelInfo, Rejection> {
    let decoded = blob::decode::<K>(bytes);
    let params = match &decoded {
        Ok(p) => p,
        Err(e) => return Err(Rejection::from(*e)),
    };
    fold_into(comp, params)?;
    Ok(ModelInfo { centres: centres_u16(comp.n_centres()), crc: blob_crc(bytes) })
}

// Decoding and folding are separate calls (folding never inlined) so that their temporaries
// occupy the stack one after the other, and the decoded parameters are borrowed, not moved.

#[inline(never)]
fn fold_into<const K: usize>(
    dst: &mut Compensator<f32, K>,
    params: &ModelParams<f32, K>,
) -> Result<(), Rejection> {
    *dst = Compensator::new(params)?;
    Ok(())
}

#[inline(never)]
fn fold_into_uninit<'s, const K: usize>(
    dst: &'s mut MaybeUninit<Compensator<f32, K>>,
    params: &ModelParams<f32, K>,
) -> Result<&'s mut Compensator<f32, K>, Rejection> {
    Ok(dst.write(Compensator::new(params)?))
}

fn centres_u16(n: usize) -> u16 {
    u16::try_from(n).unwrap_or(u16::MAX)
}

/// A model transfer in progress.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Transfer {
    Idle,
    Receiving { total: usize, crc: u32, received: usize },
}

/// Everything but the frame reader (split so that a decoded message, which borrows the
/// reader's buffer, can be handled while the rest is mutated).
struct Core<'a, P, const K: usize> {
    comp: &'a mut Compensator<f32, K>,
    staging: &'a mut [u8],
    transfer: Transfer,
    model: ModelInfo,
    status: Status,
    alarm: P,
    stack_probe: Option<fn() -> u32>,
}

/// The device: answers host frames with the active model.
///
/// `K` is the centre capacity of this build; `P` the alarm output (on while the latest
/// estimate carries any flag).
pub struct Device<'a, P, const K: usize> {
    reader: FrameReader<HOST_MAX_FRAME>,
    core: Core<'a, P, K>,
}

impl<'a, P: OutputPin, const K: usize> Device<'a, P, K> {
    /// A device serving `comp` (identified by `model`), staging updates in `staging` (at least
    /// `blob::max_len(K)` bytes to accept any model this build can hold), driving `alarm`.
    pub fn new(
        comp: &'a mut Compensator<f32, K>,
        model: ModelInfo,
        staging: &'a mut [u8],
        mut alarm: P,
    ) -> Self {
        // Start with the alarm off; an output that cannot be driven is not fatal.
        let _ = alarm.set_low();
        let status = Status { model_capacity: centres_u16(K), ..Status::default() };
        Device {
            reader: FrameReader::new(),
            core: Core {
                comp,
                staging,
                transfer: Transfer::Idle,
                model,
                status,
                alarm,
                stack_probe: None,
            },
        }
    }

    /// Report the deepest stack use through `probe` in [`Status::stack_peak_bytes`], and the
    /// peak measured during boot in [`Status::stack_boot_bytes`].
    pub fn set_stack_probe(&mut self, probe: fn() -> u32, boot_peak: u32) {
        self.core.stack_probe = Some(probe);
        self.core.status.stack_boot_bytes = boot_peak;
    }

    /// The current counters and active model.
    pub fn status(&self) -> Status {
        self.core.status()
    }

    /// The active model's identity.
    pub fn model(&self) -> ModelInfo {
        self.core.model
    }

    /// The alarm output.
    pub fn alarm(&self) -> &P {
        &self.core.alarm
    }

    /// Answer one decoded message.
    pub fn handle(&mut self, msg: &HostMsg<'_>) -> DeviceMsg {
        self.core.handle(msg)
    }

    /// Consume received bytes: decode complete frames, answer each valid message on `tx`,
    /// count and drop malformed frames. Partial frames are kept for the next call.
    pub fn feed<W: Write>(&mut self, bytes: &[u8], tx: &mut W) -> Result<(), W::Error> {
        let mut window = bytes;
        while !window.is_empty() {
            let (ev, rest) = self.reader.feed::<HostMsg<'_>>(window);
            window = rest;
            match ev {
                Feed::Pending => {}
                Feed::Malformed(why) => self.core.malformed(why),
                Feed::Message(msg) => {
                    self.core.status.frames_ok = self.core.status.frames_ok.wrapping_add(1);
                    let reply = self.core.handle(&msg);
                    send(tx, &reply)?;
                }
            }
        }
        Ok(())
    }

    /// Serve the link forever: read what arrives, answer it. Returns only on a link error.
    pub fn serve<U: Read + Write>(&mut self, link: &mut U) -> Result<Infallible, U::Error> {
        let mut buf = [0u8; 64];
        loop {
            let n = link.read(&mut buf)?;
            let got = buf.get(..n).unwrap_or(&[]);
            self.feed(got, link)?;
        }
    }
}

impl<P: OutputPin, const K: usize> Core<'_, P, K> {
    fn status(&self) -> Status {
        Status {
            model_centres: self.model.centres,
            model_crc: self.model.crc,
            stack_peak_bytes: self.stack_probe.map_or(0, |p| p()),
            ..self.status
        }
    }

    fn malformed(&mut self, why: Malformed) {
        self.status.frames_malformed = self.status.frames_malformed.wrapping_add(1);
        let _ = why;
        log!(warn, "dropped a malformed frame ({=str})", malformed_name(why));
    }

    fn handle(&mut self, msg: &HostMsg<'_>) -> DeviceMsg {
        match *msg {
            HostMsg::Ping { nonce } => DeviceMsg::Pong { nonce },
            HostMsg::ResetStream { nonce } => {
                self.comp.reset();
                DeviceMsg::Pong { nonce }
            }
            HostMsg::Sample { seq, ref sample } => DeviceMsg::Estimate(self.step(seq, sample)),
            HostMsg::GetStatus => DeviceMsg::Status(self.status()),
            HostMsg::ModelBegin { total_len, crc32 } => self.begin(total_len, crc32),
            HostMsg::ModelChunk { offset, data } => self.chunk(offset, data),
            HostMsg::ModelCommit => self.commit(),
        }
    }

    fn step(&mut self, seq: u32, sample: &Sample<f32>) -> DeviceEstimate {
        let e = self.comp.step(sample);
        self.status.samples = self.status.samples.wrapping_add(1);
        let _ = self.alarm.set_state(PinState::from(!e.flags.is_ok()));
        DeviceEstimate { seq, values: e.values, band: e.band95, flags: e.flags }
    }

    fn begin(&mut self, total_len: u32, crc: u32) -> DeviceMsg {
        let total = total_len as usize;
        if total > self.staging.len() {
            return self.reject(Rejection { reason: RejectReason::TooLarge, detail: total_len });
        }
        if total < blob::HEADER_LEN + blob::CRC_LEN {
            return self.reject(Rejection { reason: RejectReason::Truncated, detail: total_len });
        }
        log!(info, "model transfer: {=u32} bytes", total_len);
        self.transfer = Transfer::Receiving { total, crc, received: 0 };
        DeviceMsg::UpdateProgress { received: 0 }
    }

    fn chunk(&mut self, offset: u32, data: &[u8]) -> DeviceMsg {
        let Transfer::Receiving { total, crc, received } = self.transfer else {
            return self.reject(Rejection::new(RejectReason::NoUpdateInProgress));
        };
        if offset as usize != received {
            let detail = u32::try_from(received).unwrap_or(u32::MAX);
            return self.reject(Rejection { reason: RejectReason::OutOfOrder, detail });
        }
        let end = received.saturating_add(data.len());
        let Some(dst) = self.staging.get_mut(received..end).filter(|_| end <= total) else {
            return self.reject(Rejection { reason: RejectReason::Overrun, detail: offset });
        };
        dst.copy_from_slice(data);
        self.transfer = Transfer::Receiving { total, crc, received: end };
        DeviceMsg::UpdateProgress { received: u32::try_from(end).unwrap_or(u32::MAX) }
    }

    fn commit(&mut self) -> DeviceMsg {
        let Transfer::Receiving { total, crc, received } = self.transfer else {
            return self.reject(Rejection::new(RejectReason::NoUpdateInProgress));
        };
        self.transfer = Transfer::Idle;
        if received != total {
            let detail = u32::try_from(received).unwrap_or(u32::MAX);
            return self.reject(Rejection { reason: RejectReason::Incomplete, detail });
        }
        let Some(staged) = self.staging.get(..total) else {
            return self.reject(Rejection::new(RejectReason::TooLarge));
        };
        if crc32(staged) != crc {
            return self.reject(Rejection::new(RejectReason::TransferCrc));
        }
        match swap_model(self.comp, staged) {
            Ok(info) => {
                self.model = info;
                self.status.updates_accepted = self.status.updates_accepted.wrapping_add(1);
                let _ = self.alarm.set_low();
                log!(info, "model update accepted: {=u16} centres, crc {=u32:#010x}", info.centres, info.crc);
                DeviceMsg::UpdateResult(UpdateResult::Accepted { centres: info.centres, crc: info.crc })
            }
            Err(r) => self.reject(r),
        }
    }

    fn reject(&mut self, r: Rejection) -> DeviceMsg {
        self.transfer = Transfer::Idle;
        self.status.updates_rejected = self.status.updates_rejected.wrapping_add(1);
        self.status.last_rejection = Some(r);
        log!(
            warn,
            "model update rejected: {=str} (code {=u8}, detail {=u32}); keeping the active model",
            r.reason.describe(),
            r.reason.code(),
            r.detail
        );
        DeviceMsg::UpdateResult(UpdateResult::Rejected(r))
    }
}

#[cfg(feature = "defmt")]
fn malformed_name(m: Malformed) -> &'static str {
    match m {
        Malformed::Oversize => "oversize",
        Malformed::Framing => "framing",
        Malformed::Crc => "crc",
        Malformed::Payload => "payload",
        Malformed::TrailingBytes => "trailing bytes",
    }
}

/// Frame and write one answer. Every device message fits [`DEVICE_MAX_FRAME`] (tested in
/// `fbg_shared::protocol`); a writer that accepts no more bytes ends the frame early rather
/// than spinning (the host then sees a malformed frame).
fn send<W: Write>(tx: &mut W, msg: &DeviceMsg) -> Result<(), W::Error> {
    let mut buf = [0u8; DEVICE_MAX_FRAME];
    let Ok(frame) = encode_device(msg, &mut buf) else {
        return Ok(());
    };
    let mut rest: &[u8] = frame;
    while !rest.is_empty() {
        let n = tx.write(rest)?;
        if n == 0 {
            break;
        }
        rest = rest.get(n..).unwrap_or(&[]);
    }
    tx.flush()
}

#[cfg(test)]
mod tests;
