//! The messages of the link and their size limits.

use serde::{Deserialize, Serialize};

use super::reject::{RejectReason, Rejection};
use super::spectrum::{SpectrumRefusal, SpectrumStatus};
use crate::clock::StreamClock;
use crate::compensator::{Estimate, Sample};
use crate::flags::Flags;
use crate::layout::{head, MAX_OUTPUTS};
use crate::signature::KeyId;

/// Largest `data` of one [`HostMsg::ModelChunk`] in bytes.
pub const MAX_CHUNK: usize = 192;
/// Most pixels in one [`HostMsg::SpectrumPixels`] (its data: little-endian u16, at most
/// [`MAX_CHUNK`] bytes).
pub const MAX_PIXELS_PER_CHUNK: usize = MAX_CHUNK / 2;
/// Largest postcard payload of any [`HostMsg`] (a full chunk: tag, offset, length, data).
pub const HOST_MAX_PAYLOAD: usize = MAX_CHUNK + 16;
/// Largest postcard payload of any [`DeviceMsg`] (a [`Status`] with a rejection, a signed
/// model's serial and key id, the model store's figures and the spectrum counters).
pub const DEVICE_MAX_PAYLOAD: usize = 184;

/// A message from the host to the device.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMsg<'a> {
    /// Liveness check; answered by [`DeviceMsg::Pong`] with the same nonce.
    Ping {
        /// Echoed back.
        nonce: u32,
    },
    /// One sample to compensate; answered by [`DeviceMsg::Estimate`] with the same `seq`.
    Sample {
        /// Host sequence number, echoed back.
        seq: u32,
        /// The measured sample (Δλ_1..N pm of the model's N gratings, T_amb °C, t s).
        sample: Sample<f32>,
    },
    /// Start staging a model blob of `total_len` bytes whose CRC-32/ISCSI is `crc32`. Starting
    /// again abandons a transfer in progress.
    ModelBegin {
        /// Blob length in bytes.
        total_len: u32,
        /// [`super::crc32`] of the whole blob (transfer check, on top of the blob's own trailer).
        crc32: u32,
    },
    /// The next piece of the blob; `offset` must equal the bytes received so far.
    ModelChunk {
        /// Position of `data` in the blob.
        offset: u32,
        /// At most [`MAX_CHUNK`] bytes.
        #[serde(borrow)]
        data: &'a [u8],
    },
    /// Check and decode the staged blob and swap it in when valid.
    ModelCommit,
    /// Ask for the counters; answered by [`DeviceMsg::Status`].
    GetStatus,
    /// Forget the stream state (direction latches, memory operators) before a new
    /// acquisition and say how its `t_s` relates to the end of calibration (the band's lead
    /// time: [`StreamClock`]; a device boots with [`StreamClock::Unknown`]); answered by
    /// [`DeviceMsg::Pong`] with the nonce.
    ResetStream {
        /// Echoed back.
        nonce: u32,
        /// The new stream's clock.
        clock: StreamClock,
    },
    /// Set the spectrum detector up (forgetting any earlier set-up and frame): the grid, the
    /// frames' pixel count, the method and the full scale; the gratings follow
    /// ([`HostMsg::SpectrumGrating`]). Held in RAM: a reset forgets it (the host sets it up
    /// again, as it resets the stream). Answered by [`DeviceMsg::SpectrumSet`] or
    /// [`DeviceMsg::SpectrumRefused`].
    SpectrumGrid {
        /// The model's gratings N, one [`HostMsg::SpectrumGrating`] each (1 to 8).
        gratings: u8,
        /// Pixels per frame.
        pixels: u16,
        /// `true`: λ(p) = c₀ + c₁·p (`crate::spectrum::Grid::Uniform`); `false`: the
        /// polynomial Σₖ cₖ·pᵏ \[nm\].
        uniform: bool,
        /// c₀ … c₅ \[nm/pixelᵏ\].
        coefficients: [f32; crate::spectrum::POLY_COEFFS],
        /// [`crate::spectrum::Method::code`] (4: cross-correlation, the default).
        method: u8,
        /// The detector's full scale in counts (65 535 for a 16-bit frame; a sample at or
        /// above it is saturated); +∞ for never.
        full_scale: f32,
    },
    /// One grating of the set-up: where its peak is looked for and its λ_ref.
    SpectrumGrating {
        /// Its position among the model's gratings (0-based).
        index: u8,
        /// The spectrometer channel its peak is in.
        channel: u8,
        /// Search window, lower bound \[nm\].
        lo_nm: f32,
        /// Search window, upper bound \[nm\].
        hi_nm: f32,
        /// λ_ref \[nm\] as two f32 ([`crate::spectrum::ShiftRef::from_nm`] of the model's
        /// λ_ref): the high part.
        ref_hi_nm: f32,
        /// λ_ref's low part \[nm\].
        ref_lo_nm: f32,
    },
    /// A channel's frame starts; its pixels follow ([`HostMsg::SpectrumPixels`]). Once every
    /// grating has a peak from frames of the same `t_s`, the frame that completes them is
    /// answered by [`DeviceMsg::Estimate`] with `seq` (the sample of those shifts, with
    /// `t_amb_c` and `t_s`); each other message of the frame by [`DeviceMsg::SpectrumAck`].
    /// Begun again, a frame in progress is dropped.
    SpectrumBegin {
        /// Echoed in the estimate.
        seq: u32,
        /// The spectrometer channel.
        channel: u8,
        /// Time on the calibration clock \[s\] (the frames of one reading share it).
        t_s: f32,
        /// Ambient reference temperature \[°C\] (NaN without one).
        t_amb_c: f32,
    },
    /// The next pixels of the frame: `first_pixel` must be the number received so far.
    SpectrumPixels {
        /// Index of the first pixel in `data`.
        first_pixel: u16,
        /// Little-endian u16 counts, at most [`MAX_PIXELS_PER_CHUNK`] of them.
        #[serde(borrow)]
        data: &'a [u8],
    },
}

/// One compensated sample as the device reports it: on the link, the sequence number, the
/// model's M values, M band half-widths and the flags.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeviceEstimate {
    /// The request's sequence number.
    pub seq: u32,
    /// One value per output of the model, in its output order and units (0 beyond M).
    pub values: [f32; MAX_OUTPUTS],
    /// Half-width of the 95 % band, same units (0 beyond M).
    pub band: [f32; MAX_OUTPUTS],
    /// M, the model's number of outputs.
    pub outputs: u8,
    /// Fault flags (any flag also raises the alarm output).
    pub flags: Flags,
}

impl DeviceEstimate {
    /// The device's answer `e` to sample `seq`.
    pub fn new(seq: u32, e: &Estimate<f32>) -> Self {
        DeviceEstimate { seq, values: e.values, band: e.band95, outputs: e.outputs, flags: e.flags }
    }
    /// The M values.
    pub fn values(&self) -> &[f32] {
        head(&self.values, usize::from(self.outputs))
    }
    /// The M band half-widths.
    pub fn bands(&self) -> &[f32] {
        head(&self.band, usize::from(self.outputs))
    }
}

impl Serialize for DeviceEstimate {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.seq, self.values(), self.bands(), self.flags).serialize(s)
    }
}

impl<'de> Deserialize<'de> for DeviceEstimate {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        type Wire = (u32, heapless::Vec<f32, MAX_OUTPUTS>, heapless::Vec<f32, MAX_OUTPUTS>, Flags);
        let (seq, v, b, flags): Wire = Deserialize::deserialize(d)?;
        let mut e =
            DeviceEstimate { seq, values: [0.0; MAX_OUTPUTS], band: [0.0; MAX_OUTPUTS], outputs: v.len() as u8, flags };
        for (o, &x) in e.values.iter_mut().zip(v.iter()) {
            *o = x;
        }
        for (o, &x) in e.band.iter_mut().zip(b.iter()) {
            *o = x;
        }
        Ok(e)
    }
}

/// A message from the device to the host.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum DeviceMsg {
    /// Answer to [`HostMsg::Ping`] and [`HostMsg::ResetStream`].
    Pong {
        /// The request's nonce.
        nonce: u32,
    },
    /// Answer to [`HostMsg::Sample`].
    Estimate(DeviceEstimate),
    /// Answer to [`HostMsg::GetStatus`].
    Status(Status),
    /// A transfer step was accepted; `received` bytes are staged.
    UpdateProgress {
        /// Bytes staged so far.
        received: u32,
    },
    /// End of a model update: the new model is active, or the old one still is and why.
    UpdateResult(UpdateResult),
    /// Answer to [`HostMsg::SpectrumGrid`] and [`HostMsg::SpectrumGrating`]: the set-up was
    /// taken; `missing` gratings are still to come (0: frames are accepted).
    SpectrumSet {
        /// Gratings not set up yet.
        missing: u8,
    },
    /// Answer to a [`HostMsg::SpectrumBegin`] or [`HostMsg::SpectrumPixels`] that did not
    /// complete a reading: `received` pixels of the frame have arrived.
    SpectrumAck {
        /// Pixels of the frame so far.
        received: u16,
    },
    /// A spectrum message was refused.
    SpectrumRefused(SpectrumRefusal),
}

/// Outcome of a model update.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum UpdateResult {
    /// The new model passed every check and now answers samples.
    Accepted {
        /// Its RBF centres.
        centres: u16,
        /// Its blob CRC trailer.
        crc: u32,
    },
    /// The update was refused; the previous model keeps answering.
    Rejected(Rejection),
}

/// Device counters and the active model.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Status {
    /// Frames that decoded into a valid message.
    pub frames_ok: u32,
    /// Frames dropped: bad COBS, oversize, CRC mismatch, undecodable or trailing bytes.
    pub frames_malformed: u32,
    /// Samples compensated.
    pub samples: u32,
    /// Model updates swapped in.
    pub updates_accepted: u32,
    /// Model updates refused (the old model kept).
    pub updates_rejected: u32,
    /// RBF centres of the active model.
    pub model_centres: u16,
    /// Centre capacity `K` of this firmware build.
    pub model_capacity: u16,
    /// CRC trailer of the active model's blob: its digest (the signature covers it).
    pub model_crc: u32,
    /// Serial of the active model's signature trailer (0 for an unsigned model: the embedded
    /// default, trusted as part of the firmware image). Updates with a lower serial are
    /// refused unless signed as a rollback of exactly this serial (and the build accepts
    /// rollbacks); the same serial is accepted only on the same model.
    pub model_serial: u64,
    /// Key id of the active model's signer (`None` for an unsigned model).
    pub model_key_id: Option<KeyId>,
    /// Refused updates counted by the reason of the signature check (a part of
    /// `updates_rejected`; the rest are transfer and integrity errors).
    pub refused: Refusals,
    /// The most recent refusal, if any.
    pub last_rejection: Option<Rejection>,
    /// Deepest stack use while serving (since boot finished) in bytes, by stack painting (0 when
    /// not measured).
    pub stack_peak_bytes: u32,
    /// Deepest stack use during boot (loading the embedded model) in bytes (0 when not
    /// measured).
    pub stack_boot_bytes: u32,
    /// Erase operations on the staging flash slot since boot (a `ModelBegin` erases only a
    /// slot that is not blank, so repeated begins without data erase nothing).
    pub staging_erases: u32,
    /// The persistent model store: where the running model was booted from, the rollback
    /// floor, the event log and the wear of every sector.
    pub store: StoreStatus,
    /// Spectrum frames: received, dropped, refused.
    pub spectra: SpectrumStatus,
}

/// Sectors of the device's model store: slot A, slot B, log sector 0, log sector 1.
pub const STORE_SECTORS: usize = 4;

/// Where the running model came from at boot.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BootSource {
    /// The model embedded in the firmware image (no complete, verified slot at or above the
    /// rollback floor, or a device that never accepted an update).
    #[default]
    Embedded,
    /// A slot of the model store.
    Slot {
        /// 0 for slot A, 1 for slot B.
        slot: u8,
        /// The slot's generation: one more than the newest slot's when it was written.
        generation: u32,
    },
}

/// The persistent model store's part of [`Status`] (all zero on a device without one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StoreStatus {
    /// Where the running model was loaded from at boot (an update accepted since then runs
    /// now, and boots next time).
    pub boot_source: BootSource,
    /// Erase operations per sector since the store was first formatted, in the order of
    /// [`STORE_SECTORS`] (each sector keeps its own count beside its data).
    pub erases: [u32; STORE_SECTORS],
    /// Erase and program operations on the store since boot.
    pub flash_ops: u32,
    /// The rollback floor: the serial of the last update the log records as accepted (0 when
    /// none). Boot takes no slot below it; an update below it is refused unless it is a
    /// permitted rollback.
    pub rollback_floor: u64,
    /// Events written to the log since the store was formatted (accepted and refused
    /// updates).
    pub log_events: u32,
    /// Refused updates since boot that were counted but not written to the log (beyond the
    /// log's budget of refusals per accepted update, so that the link cannot wear the flash).
    pub refusals_unlogged: u32,
    /// Time from reset to the first frame served, µs (0 when not measured).
    pub boot_time_us: u32,
}

/// Model updates refused by the signature check, by reason (the audit trail's counters).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Refusals {
    /// [`RejectReason::Unsigned`].
    pub unsigned: u32,
    /// [`RejectReason::BadSignature`].
    pub bad_signature: u32,
    /// [`RejectReason::UnknownKey`].
    pub unknown_key: u32,
    /// [`RejectReason::Rollback`] and [`RejectReason::RollbackNotPermitted`].
    pub rollback: u32,
    /// [`RejectReason::SerialReused`].
    pub serial_reused: u32,
}

impl Refusals {
    /// Count one refusal for `reason` (reasons other than the signature check's are not
    /// counted here).
    pub fn count(&mut self, reason: RejectReason) {
        let c = match reason {
            RejectReason::Unsigned => &mut self.unsigned,
            RejectReason::BadSignature => &mut self.bad_signature,
            RejectReason::UnknownKey => &mut self.unknown_key,
            RejectReason::Rollback | RejectReason::RollbackNotPermitted => &mut self.rollback,
            RejectReason::SerialReused => &mut self.serial_reused,
            _ => return,
        };
        *c = c.wrapping_add(1);
    }
}
