//! The serial link between a host and the interrogator's co-processor (DESIGN §7).
//!
//! # Wire format
//!
//! Every message travels in one frame:
//!
//! ```text
//! frame    = COBS(envelope) 0x00
//! envelope = postcard(Envelope { payload: bytes, crc: u32 LE fixint })
//! payload  = postcard(HostMsg | DeviceMsg)
//! crc      = CRC-32/ISCSI over payload (the blob's CRC flavour)
//! ```
//!
//! COBS framing is postcard's ([`postcard::to_slice_cobs`],
//! [`postcard::accumulator::CobsAccumulator`]); `0x00` only ever appears as the frame delimiter,
//! so a receiver resynchronises at the next `0x00` after any garbage. The CRC catches bytes
//! damaged in transit that would still decode (a flipped bit in a sample's value), and a payload
//! must decode exactly, without bytes left over. Anything else is a malformed frame: counted
//! and dropped, never fatal ([`FrameReader`]). Empty frames (`0x00 0x00`, idle fill) are
//! ignored, not counted.
//!
//! # Conversation
//!
//! The host sends one [`HostMsg`] and waits for the one [`DeviceMsg`] that answers it; this
//! lock-step is the flow control (a device may be busy for a while validating a model). A
//! malformed frame gets no answer. Answers:
//!
//! | host | device |
//! |---|---|
//! | `Ping{nonce}` / `ResetStream{nonce}` | `Pong{nonce}` |
//! | `Sample{seq, sample}` | `Estimate{seq, values, band, flags}` |
//! | `GetStatus` | `Status{..}` |
//! | `ModelBegin{total_len, crc32}` / `ModelChunk{offset, data}` | `UpdateProgress{received}`, or `UpdateResult(Rejected)` |
//! | `ModelCommit` | `UpdateResult(Accepted | Rejected)` |
//!
//! A model update stages the blob (`ModelBegin`, in-order `ModelChunk`s of at most
//! [`MAX_CHUNK`] bytes), then `ModelCommit` checks the transfer CRC and decodes the blob with
//! [`crate::blob::decode`] (magic, version, dims, CRC, every parameter) before swapping. Any
//! failure aborts the transfer, keeps the old model and answers with a [`Rejection`] whose
//! [`RejectReason`] codes are stable across versions.

use postcard::accumulator::{CobsAccumulator, FeedResult};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

// The blob's CRC engine: one CRC-32/ISCSI table in the image for blobs and frames.
use crate::blob::CRC32 as FRAME_CRC;
use crate::compensator::Sample;
use crate::error::Error;
use crate::flags::Flags;
use crate::layout::N_OUTPUTS;

/// Largest `data` of one [`HostMsg::ModelChunk`] in bytes.
pub const MAX_CHUNK: usize = 192;
/// Largest postcard payload of any [`HostMsg`] (a full chunk: tag, offset, length, data).
pub const HOST_MAX_PAYLOAD: usize = MAX_CHUNK + 16;
/// Largest postcard payload of any [`DeviceMsg`] (a [`Status`] with a rejection).
pub const DEVICE_MAX_PAYLOAD: usize = 64;
/// Receive buffer a device needs for one host frame, delimiter included: anything longer is an
/// oversize frame.
pub const HOST_MAX_FRAME: usize = 256;
/// Receive buffer a host needs for one device frame, delimiter included.
pub const DEVICE_MAX_FRAME: usize = 96;

/// CRC-32/ISCSI of `bytes`: the frame check and the whole-blob check of
/// [`HostMsg::ModelBegin`] (the same flavour as the blob trailer).
pub fn crc32(bytes: &[u8]) -> u32 {
    FRAME_CRC.checksum(bytes)
}

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
        /// The measured sample (Δλ1..3 pm, T_amb °C, t s).
        sample: Sample<f32>,
    },
    /// Start staging a model blob of `total_len` bytes whose CRC-32/ISCSI is `crc32`. Starting
    /// again abandons a transfer in progress.
    ModelBegin {
        /// Blob length in bytes.
        total_len: u32,
        /// [`crc32`] of the whole blob (transfer check, on top of the blob's own trailer).
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
    /// Forget the stream state (direction latches) before a new acquisition; answered by
    /// [`DeviceMsg::Pong`] with the nonce.
    ResetStream {
        /// Echoed back.
        nonce: u32,
    },
}

/// One compensated sample as the device reports it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DeviceEstimate {
    /// The request's sequence number.
    pub seq: u32,
    /// T [°C], ε [µε], p [kPa].
    pub values: [f32; N_OUTPUTS],
    /// Half-width of the 95 % band, same units.
    pub band: [f32; N_OUTPUTS],
    /// Fault flags (any flag also raises the alarm output).
    pub flags: Flags,
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

/// Why an update was refused, with a reason-specific detail number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rejection {
    /// Stable reason code.
    pub reason: RejectReason,
    /// Detail: found version for `UnsupportedVersion`; `found << 16 | expected` for
    /// `WrongDims`; extra bytes for `TrailingBytes`; centres for `TooManyCentres`; the length for
    /// `TooLarge`; the expected offset for `OutOfOrder`; bytes received for `Incomplete`;
    /// 0 otherwise.
    pub detail: u32,
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
    /// CRC trailer of the active model's blob (identifies it).
    pub model_crc: u32,
    /// The most recent refusal, if any.
    pub last_rejection: Option<Rejection>,
    /// Deepest stack use while serving (since boot finished) in bytes, by stack painting (0 when
    /// not measured).
    pub stack_peak_bytes: u32,
    /// Deepest stack use during boot (loading the embedded model) in bytes (0 when not
    /// measured).
    pub stack_boot_bytes: u32,
}

/// Stable reason codes of a refused model update. The numbers never change meaning; new reasons
/// get new numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
#[non_exhaustive]
pub enum RejectReason {
    /// Blob ended early ([`Error::Truncated`]).
    Truncated = 1,
    /// Not `FBGM` ([`Error::BadMagic`]).
    BadMagic = 2,
    /// Unknown format version ([`Error::UnsupportedVersion`]).
    UnsupportedVersion = 3,
    /// A header dimension this build cannot use, e.g. more centres than `K`
    /// ([`Error::WrongDims`]).
    WrongDims = 4,
    /// Blob CRC trailer mismatch ([`Error::BadCrc`]).
    BadCrc = 5,
    /// Payload does not decode ([`Error::BadPayload`]).
    BadPayload = 6,
    /// Bytes after the trailer ([`Error::TrailingBytes`]).
    TrailingBytes = 7,
    /// More centres than the capacity ([`Error::TooManyCentres`]).
    TooManyCentres = 8,
    /// A parameter is non-finite or out of range ([`Error::BadParameter`]).
    BadParameter = 9,
    /// Encoder buffer too small ([`Error::BufferTooSmall`]; not expected from a device).
    BufferTooSmall = 10,
    /// A chunk or commit arrived with no transfer in progress.
    NoUpdateInProgress = 20,
    /// The announced length exceeds the staging buffer of this build (or is shorter than any
    /// blob).
    TooLarge = 21,
    /// A chunk's offset is not the number of bytes received so far.
    OutOfOrder = 22,
    /// A chunk runs past the announced length.
    Overrun = 23,
    /// Commit before all announced bytes arrived.
    Incomplete = 24,
    /// The staged bytes do not match the announced whole-blob CRC.
    TransferCrc = 25,
    /// A reason this build does not know (a newer device, or a future [`Error`] variant).
    Other = 255,
}

impl RejectReason {
    /// Every reason this version defines.
    pub const ALL: [RejectReason; 17] = [
        RejectReason::Truncated,
        RejectReason::BadMagic,
        RejectReason::UnsupportedVersion,
        RejectReason::WrongDims,
        RejectReason::BadCrc,
        RejectReason::BadPayload,
        RejectReason::TrailingBytes,
        RejectReason::TooManyCentres,
        RejectReason::BadParameter,
        RejectReason::BufferTooSmall,
        RejectReason::NoUpdateInProgress,
        RejectReason::TooLarge,
        RejectReason::OutOfOrder,
        RejectReason::Overrun,
        RejectReason::Incomplete,
        RejectReason::TransferCrc,
        RejectReason::Other,
    ];

    /// The stable wire code.
    pub const fn code(self) -> u8 {
        self as u8
    }

    /// The reason for a wire code; unknown codes map to [`RejectReason::Other`].
    pub fn from_code(code: u8) -> RejectReason {
        RejectReason::ALL.iter().copied().find(|r| r.code() == code).unwrap_or(RejectReason::Other)
    }

    /// Short human-readable description.
    pub const fn describe(self) -> &'static str {
        match self {
            RejectReason::Truncated => "model blob truncated",
            RejectReason::BadMagic => "not a model blob (bad magic)",
            RejectReason::UnsupportedVersion => "unsupported blob format version",
            RejectReason::WrongDims => "blob dimensions do not fit this firmware",
            RejectReason::BadCrc => "blob CRC-32 mismatch (corrupted)",
            RejectReason::BadPayload => "blob payload does not decode",
            RejectReason::TrailingBytes => "bytes after the blob CRC",
            RejectReason::TooManyCentres => "more RBF centres than this firmware holds",
            RejectReason::BadParameter => "a model parameter is non-finite or out of range",
            RejectReason::BufferTooSmall => "buffer too small",
            RejectReason::NoUpdateInProgress => "no model transfer in progress",
            RejectReason::TooLarge => "announced blob length does not fit the staging buffer",
            RejectReason::OutOfOrder => "chunk offset out of order",
            RejectReason::Overrun => "chunk runs past the announced length",
            RejectReason::Incomplete => "commit before the whole blob arrived",
            RejectReason::TransferCrc => "staged bytes do not match the announced CRC",
            RejectReason::Other => "unknown reason",
        }
    }
}

impl core::fmt::Display for RejectReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.describe())
    }
}

impl core::fmt::Display for Rejection {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{} (code {}, detail {})", self.reason, self.reason.code(), self.detail)
    }
}

impl Serialize for RejectReason {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(self.code())
    }
}

impl<'de> Deserialize<'de> for RejectReason {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        u8::deserialize(d).map(RejectReason::from_code)
    }
}

impl Rejection {
    /// A rejection without detail.
    pub const fn new(reason: RejectReason) -> Self {
        Rejection { reason, detail: 0 }
    }
}

impl From<Error> for Rejection {
    /// Map a blob error to its stable code and detail.
    fn from(e: Error) -> Self {
        let (reason, detail) = match e {
            Error::Truncated { .. } => (RejectReason::Truncated, 0),
            Error::BadMagic => (RejectReason::BadMagic, 0),
            Error::UnsupportedVersion { found, .. } => (RejectReason::UnsupportedVersion, found as u32),
            Error::WrongDims { found, expected, .. } => {
                (RejectReason::WrongDims, (found as u32) << 16 | expected as u32)
            }
            Error::BadCrc => (RejectReason::BadCrc, 0),
            Error::BadPayload => (RejectReason::BadPayload, 0),
            Error::TrailingBytes { extra } => (RejectReason::TrailingBytes, sat_u32(extra)),
            Error::TooManyCentres { found, .. } => (RejectReason::TooManyCentres, sat_u32(found)),
            Error::BadParameter { .. } => (RejectReason::BadParameter, 0),
            Error::BufferTooSmall => (RejectReason::BufferTooSmall, 0),
            #[allow(unreachable_patterns)] // `Error` is non_exhaustive
            _ => (RejectReason::Other, 0),
        };
        Rejection { reason, detail }
    }
}

fn sat_u32(v: usize) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

/// The CRC-protected envelope around a message's postcard bytes.
#[derive(Serialize, Deserialize)]
struct Envelope<'a> {
    #[serde(borrow)]
    payload: &'a [u8],
    #[serde(with = "postcard::fixint::le")]
    crc: u32,
}

/// Why a message could not be framed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncodeError {
    /// The payload scratch or the output buffer is too small for this message.
    BufferTooSmall,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("message does not fit the frame buffer")
    }
}

/// Frame `msg` into `out` (COBS, delimiter included) using `scratch` for its postcard payload.
/// Returns the frame bytes.
pub fn encode_into<'o, M: Serialize>(
    msg: &M,
    scratch: &mut [u8],
    out: &'o mut [u8],
) -> Result<&'o mut [u8], EncodeError> {
    let payload: &[u8] = postcard::to_slice(msg, scratch).map_err(|_| EncodeError::BufferTooSmall)?;
    let env = Envelope { payload, crc: crc32(payload) };
    postcard::to_slice_cobs(&env, out).map_err(|_| EncodeError::BufferTooSmall)
}

/// Frame a [`HostMsg`] into `out` (at least [`HOST_MAX_FRAME`] bytes fits any message).
pub fn encode_host<'o>(msg: &HostMsg<'_>, out: &'o mut [u8]) -> Result<&'o mut [u8], EncodeError> {
    let mut scratch = [0u8; HOST_MAX_PAYLOAD];
    encode_into(msg, &mut scratch, out)
}

/// Frame a [`DeviceMsg`] into `out` (at least [`DEVICE_MAX_FRAME`] bytes fits any message).
pub fn encode_device<'o>(msg: &DeviceMsg, out: &'o mut [u8]) -> Result<&'o mut [u8], EncodeError> {
    let mut scratch = [0u8; DEVICE_MAX_PAYLOAD];
    encode_into(msg, &mut scratch, out)
}

/// Why a received frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Malformed {
    /// Longer than the receive buffer; skipped up to its delimiter.
    Oversize,
    /// Not valid COBS or not an envelope.
    Framing,
    /// Envelope CRC mismatch.
    Crc,
    /// The payload is not a message of the expected type.
    Payload,
    /// The payload decoded with bytes left over.
    TrailingBytes,
}

impl core::fmt::Display for Malformed {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Malformed::Oversize => "oversize frame",
            Malformed::Framing => "bad COBS framing",
            Malformed::Crc => "frame CRC mismatch",
            Malformed::Payload => "undecodable message",
            Malformed::TrailingBytes => "bytes after the message",
        })
    }
}

/// What one call of [`FrameReader::feed`] produced.
#[derive(Debug, PartialEq)]
pub enum Feed<T> {
    /// Nothing complete yet (bytes buffered, skipped or discarded); feed the remainder.
    Pending,
    /// A valid message.
    Message(T),
    /// A frame was dropped.
    Malformed(Malformed),
}

/// Incremental frame decoder with an `N`-byte receive buffer (postcard's
/// [`CobsAccumulator`] plus resynchronisation after oversize frames, the CRC check and the
/// strict payload decode). Never panics, whatever the bytes.
pub struct FrameReader<const N: usize> {
    acc: CobsAccumulator<N>,
    /// Bytes of an unfinished frame are buffered.
    in_frame: bool,
    /// Skipping the rest of an oversize frame up to its delimiter.
    discarding: bool,
}

impl<const N: usize> Default for FrameReader<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> FrameReader<N> {
    /// An empty reader.
    pub const fn new() -> Self {
        FrameReader { acc: CobsAccumulator::new(), in_frame: false, discarding: false }
    }

    /// Drop any partial frame (e.g. after a link reset).
    pub fn clear(&mut self) {
        *self = Self::new();
    }

    /// Consume a prefix of `input`; return what it completed and the unconsumed rest. Call
    /// again with the rest until it is empty. A returned message borrows from the reader.
    pub fn feed<'de, 'a, T: Deserialize<'de>>(&'de mut self, input: &'a [u8]) -> (Feed<T>, &'a [u8]) {
        let Some(&first) = input.first() else {
            return (Feed::Pending, input);
        };
        if self.discarding {
            return match input.iter().position(|&b| b == 0) {
                Some(z) => {
                    self.discarding = false;
                    (Feed::Pending, input.get(z + 1..).unwrap_or(&[]))
                }
                None => (Feed::Pending, &[]),
            };
        }
        if !self.in_frame && first == 0 {
            // Empty frame: idle fill or a resynchronisation delimiter, not an error.
            return (Feed::Pending, input.get(1..).unwrap_or(&[]));
        }
        let zero = input.iter().position(|&b| b == 0);
        match self.acc.feed_ref::<Envelope<'de>>(input) {
            FeedResult::Consumed => {
                self.in_frame = true;
                (Feed::Pending, &[])
            }
            FeedResult::OverFull(rest) => {
                self.in_frame = false;
                let consumed = input.len() - rest.len();
                // If the delimiter was not among the consumed bytes, the frame goes on in
                // `rest`: skip it up to its delimiter so that it counts once.
                self.discarding = !matches!(zero, Some(z) if z < consumed);
                (Feed::Malformed(Malformed::Oversize), rest)
            }
            FeedResult::DeserError(rest) => {
                self.in_frame = false;
                (Feed::Malformed(Malformed::Framing), rest)
            }
            FeedResult::Success { data, remaining } => {
                self.in_frame = false;
                (check_envelope(data), remaining)
            }
        }
    }
}

fn check_envelope<'de, T: Deserialize<'de>>(env: Envelope<'de>) -> Feed<T> {
    if crc32(env.payload) != env.crc {
        return Feed::Malformed(Malformed::Crc);
    }
    match postcard::take_from_bytes::<T>(env.payload) {
        Ok((msg, [])) => Feed::Message(msg),
        Ok(_) => Feed::Malformed(Malformed::TrailingBytes),
        Err(_) => Feed::Malformed(Malformed::Payload),
    }
}

/// Decode one complete frame (delimiter optional) in place, for tests and tools that already
/// split the byte stream.
pub fn decode_frame<'de, T: Deserialize<'de>>(frame: &'de mut [u8]) -> Result<T, Malformed> {
    let len = frame.iter().position(|&b| b == 0).unwrap_or(frame.len());
    let body = frame.get_mut(..len).ok_or(Malformed::Framing)?;
    let env = postcard::from_bytes_cobs::<Envelope<'de>>(body).map_err(|_| Malformed::Framing)?;
    match check_envelope(env) {
        Feed::Message(m) => Ok(m),
        Feed::Malformed(e) => Err(e),
        Feed::Pending => Err(Malformed::Framing),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used, clippy::indexing_slicing, clippy::panic)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;

    fn frame_host(msg: &HostMsg<'_>) -> Vec<u8> {
        let mut out = [0u8; HOST_MAX_FRAME];
        encode_host(msg, &mut out).map(|f| f.to_vec()).expect("fits")
    }

    fn frame_device(msg: &DeviceMsg) -> Vec<u8> {
        let mut out = [0u8; DEVICE_MAX_FRAME];
        encode_device(msg, &mut out).map(|f| f.to_vec()).expect("fits")
    }

    /// Feed `bytes` in pieces of `piece` bytes and collect everything the reader produced.
    fn read_all<const N: usize>(bytes: &[u8], piece: usize) -> Vec<Result<DeviceMsg, Malformed>> {
        let mut r = FrameReader::<N>::new();
        let mut out = Vec::new();
        for chunk in bytes.chunks(piece.max(1)) {
            let mut w = chunk;
            while !w.is_empty() {
                let (ev, rest) = r.feed::<DeviceMsg>(w);
                match ev {
                    Feed::Pending => {}
                    Feed::Message(m) => out.push(Ok(m)),
                    Feed::Malformed(e) => out.push(Err(e)),
                }
                w = rest;
            }
        }
        out
    }

    fn host_msgs() -> Vec<HostMsg<'static>> {
        static DATA: [u8; MAX_CHUNK] = [0xA5; MAX_CHUNK];
        std::vec![
            HostMsg::Ping { nonce: 0xDEAD_BEEF },
            HostMsg::Sample { seq: 7, sample: Sample { dl_pm: [12.5, -3.25, f32::NAN], t_amb_c: 21.0, t_s: 1.0e6 } },
            HostMsg::ModelBegin { total_len: 2900, crc32: 0x1234_5678 },
            HostMsg::ModelChunk { offset: u32::MAX, data: &DATA },
            HostMsg::ModelChunk { offset: 0, data: &[0, 0, 0] },
            HostMsg::ModelCommit,
            HostMsg::GetStatus,
            HostMsg::ResetStream { nonce: 3 },
        ]
    }

    fn device_msgs() -> Vec<DeviceMsg> {
        let rej = Rejection { reason: RejectReason::WrongDims, detail: u32::MAX };
        std::vec![
            DeviceMsg::Pong { nonce: u32::MAX },
            DeviceMsg::Estimate(DeviceEstimate {
                seq: u32::MAX,
                values: [f32::NAN, -1.0e30, 3.0],
                band: [f32::INFINITY, 0.0, 1.0],
                flags: Flags::ALL,
            }),
            DeviceMsg::Status(Status {
                frames_ok: u32::MAX,
                frames_malformed: u32::MAX,
                samples: u32::MAX,
                updates_accepted: u32::MAX,
                updates_rejected: u32::MAX,
                model_centres: u16::MAX,
                model_capacity: u16::MAX,
                model_crc: u32::MAX,
                last_rejection: Some(rej),
                stack_peak_bytes: u32::MAX,
                stack_boot_bytes: u32::MAX,
            }),
            DeviceMsg::UpdateProgress { received: u32::MAX },
            DeviceMsg::UpdateResult(UpdateResult::Accepted { centres: 64, crc: u32::MAX }),
            DeviceMsg::UpdateResult(UpdateResult::Rejected(rej)),
        ]
    }

    /// NaN-aware equality through the debug form (NaN != NaN otherwise).
    fn same<T: core::fmt::Debug>(a: &T, b: &T) -> bool {
        std::format!("{a:?}") == std::format!("{b:?}")
    }

    #[test]
    fn host_messages_round_trip_within_the_limits() {
        for msg in host_msgs() {
            let mut f = frame_host(&msg);
            assert!(f.len() <= HOST_MAX_FRAME, "{msg:?} is {} bytes", f.len());
            assert_eq!(f.iter().filter(|&&b| b == 0).count(), 1, "only the delimiter is zero");
            assert_eq!(f.last(), Some(&0));
            let back: HostMsg<'_> = decode_frame(&mut f).expect("decodes");
            assert!(same(&back, &msg), "{back:?} != {msg:?}");
        }
    }

    #[test]
    fn device_messages_round_trip_within_the_limits() {
        for msg in device_msgs() {
            let mut scratch = [0u8; 256];
            let payload = postcard::to_slice(&msg, &mut scratch).expect("fits").len();
            assert!(payload <= DEVICE_MAX_PAYLOAD, "{msg:?}: payload {payload}");
            let f = frame_device(&msg);
            assert!(f.len() <= DEVICE_MAX_FRAME, "{msg:?} is {} bytes", f.len());
            let got = read_all::<DEVICE_MAX_FRAME>(&f, 1);
            assert_eq!(got.len(), 1);
            assert!(same(&got[0], &Ok(msg)));
        }
    }

    #[test]
    fn the_biggest_host_frame_fits_the_device_buffer() {
        static DATA: [u8; MAX_CHUNK] = [0xFF; MAX_CHUNK];
        let msg = HostMsg::ModelChunk { offset: u32::MAX, data: &DATA };
        let mut scratch = [0u8; 512];
        assert!(postcard::to_slice(&msg, &mut scratch).expect("fits").len() <= HOST_MAX_PAYLOAD);
        let f = frame_host(&msg);
        assert!(f.len() <= HOST_MAX_FRAME);
        let mut r = FrameReader::<HOST_MAX_FRAME>::new();
        let (ev, rest) = r.feed::<HostMsg<'_>>(&f);
        assert!(rest.is_empty());
        assert_eq!(ev, Feed::Message(msg));
    }

    #[test]
    fn a_stream_of_frames_decodes_in_any_piece_size() {
        let msgs = device_msgs();
        let mut stream = std::vec![0u8, 0]; // idle fill before the first frame
        for m in &msgs {
            stream.extend(frame_device(m));
            stream.push(0); // an empty frame between messages is ignored
        }
        for piece in [1, 2, 3, 7, 64, 1000] {
            let got = read_all::<DEVICE_MAX_FRAME>(&stream, piece);
            assert_eq!(got.len(), msgs.len(), "piece {piece}");
            for (g, m) in got.iter().zip(msgs.iter()) {
                assert!(same(g, &Ok(*m)), "piece {piece}: {g:?}");
            }
        }
    }

    #[test]
    fn malformed_frames_are_reported_and_the_next_frame_decodes() {
        let good = frame_device(&DeviceMsg::Pong { nonce: 9 });
        let mut flipped = good.clone();
        // Damage a payload byte but keep valid COBS: flip a bit in a non-zero, non-code byte.
        let last = flipped.len() - 2;
        flipped[last] ^= 0x01;
        if flipped[last] == 0 {
            flipped[last] = 0x02;
        }
        let wrong_type = frame_host(&HostMsg::ModelCommit); // a host message is no DeviceMsg
        let mut with_trailing = {
            let mut scratch = [0u8; 64];
            let n = postcard::to_slice(&DeviceMsg::Pong { nonce: 9 }, &mut scratch).unwrap().len();
            scratch[n] = 0x55;
            let payload = &scratch[..n + 1];
            let env = Envelope { payload, crc: crc32(payload) };
            let mut out = [0u8; 64];
            postcard::to_slice_cobs(&env, &mut out).unwrap().to_vec()
        };
        let cases: [(&str, Vec<u8>, Malformed); 5] = [
            ("garbage", std::vec![0x01, 0x02, 0xFF, 0x00], Malformed::Framing),
            ("bad cobs", std::vec![0x05, 0x11, 0x00], Malformed::Framing),
            ("crc", flipped, Malformed::Crc),
            ("wrong type", wrong_type, Malformed::Payload),
            ("trailing", core::mem::take(&mut with_trailing), Malformed::TrailingBytes),
        ];
        for (name, bad, why) in cases {
            let mut stream = bad.clone();
            stream.extend(&good);
            let got = read_all::<DEVICE_MAX_FRAME>(&stream, 5);
            assert_eq!(got.len(), 2, "{name}: {got:?}");
            assert_eq!(got[0], Err(why), "{name}");
            assert_eq!(got[1], Ok(DeviceMsg::Pong { nonce: 9 }), "{name}");
        }
    }

    #[test]
    fn an_oversize_frame_counts_once_and_resynchronises() {
        let good = frame_device(&DeviceMsg::Pong { nonce: 1 });
        for len in [DEVICE_MAX_FRAME, DEVICE_MAX_FRAME + 1, 3 * DEVICE_MAX_FRAME + 5] {
            let mut stream = std::vec![0x11u8; len];
            stream.push(0);
            stream.extend(&good);
            for piece in [1, 10, 4096] {
                let got = read_all::<DEVICE_MAX_FRAME>(&stream, piece);
                assert_eq!(
                    got,
                    std::vec![Err(Malformed::Oversize), Ok(DeviceMsg::Pong { nonce: 1 })],
                    "len {len} piece {piece}"
                );
            }
        }
    }

    #[test]
    fn arbitrary_bytes_never_panic() {
        // A cheap deterministic byte soup, with zeros sprinkled in, followed by a good frame.
        let mut x: u32 = 0x1234_5678;
        let mut soup = Vec::new();
        for _ in 0..20_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            soup.push(if x % 29 == 0 { 0 } else { (x >> 8) as u8 });
        }
        soup.push(0);
        soup.extend(frame_device(&DeviceMsg::Pong { nonce: 5 }));
        let got = read_all::<DEVICE_MAX_FRAME>(&soup, 13);
        assert_eq!(got.last(), Some(&Ok(DeviceMsg::Pong { nonce: 5 })));
        let mut r = FrameReader::<HOST_MAX_FRAME>::new();
        let mut w = &soup[..];
        while !w.is_empty() {
            w = r.feed::<HostMsg<'_>>(w).1;
        }
    }

    #[test]
    fn reject_codes_are_stable_and_round_trip() {
        let codes: Vec<u8> = RejectReason::ALL.iter().map(|r| r.code()).collect();
        assert_eq!(codes, [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 20, 21, 22, 23, 24, 25, 255]);
        for r in RejectReason::ALL {
            assert_eq!(RejectReason::from_code(r.code()), r);
            let mut buf = [0u8; 4];
            let b = postcard::to_slice(&r, &mut buf).unwrap();
            assert_eq!(b, &[r.code()]);
            assert_eq!(postcard::from_bytes::<RejectReason>(b).unwrap(), r);
        }
        assert_eq!(RejectReason::from_code(99), RejectReason::Other);
        let e = Rejection::from(Error::WrongDims { field: "centres", found: 64, expected: 32 });
        assert_eq!(e, Rejection { reason: RejectReason::WrongDims, detail: 64 << 16 | 32 });
        assert_eq!(Rejection::from(Error::BadCrc).reason, RejectReason::BadCrc);
        assert_eq!(Rejection::from(Error::BadParameter { field: "hyper.sigma" }).reason, RejectReason::BadParameter);
    }

    #[test]
    fn encode_refuses_small_buffers() {
        let mut out = [0u8; 8];
        assert_eq!(
            encode_device(&DeviceMsg::Status(Status::default()), &mut out).err(),
            Some(EncodeError::BufferTooSmall)
        );
        let mut scratch = [0u8; 2];
        let mut out = [0u8; 64];
        assert!(encode_into(&HostMsg::GetStatus, &mut scratch, &mut out).is_ok());
        assert!(encode_into(&HostMsg::Ping { nonce: u32::MAX }, &mut scratch, &mut out).is_err());
    }
}
