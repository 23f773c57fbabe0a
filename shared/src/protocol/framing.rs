//! Framing: the CRC envelope around a message's postcard bytes, COBS frames, and the
//! incremental reader that resynchronises after anything malformed.

use serde::{Deserialize, Serialize};

use super::messages::{DeviceMsg, HostMsg, DEVICE_MAX_PAYLOAD, HOST_MAX_PAYLOAD};
// The blob's CRC: one CRC-32/ISCSI in the image for blobs and frames.
use crate::crc32c::crc32c;

/// Receive buffer a device needs for one host frame, delimiter included: anything longer is an
/// oversize frame.
pub const HOST_MAX_FRAME: usize = 256;
/// Receive buffer a host needs for one device frame, delimiter included.
pub const DEVICE_MAX_FRAME: usize = 192;

/// CRC-32/ISCSI of `bytes`: the frame check and the whole-blob check of
/// [`HostMsg::ModelBegin`] (the same flavour as the blob trailer).
pub fn crc32(bytes: &[u8]) -> u32 {
    crc32c(bytes)
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
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The payload scratch or the output buffer is too small for this message.
    BufferTooSmall,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("message does not fit the frame buffer")
    }
}

impl core::error::Error for EncodeError {}

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
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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

impl core::error::Error for Malformed {}

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

/// Incremental frame decoder with an `N`-byte receive buffer (what postcard's
/// `CobsAccumulator` does, written here without its panic paths, plus resynchronisation after
/// oversize frames, the CRC check and the strict payload decode). Never panics, whatever the
/// bytes.
pub struct FrameReader<const N: usize> {
    /// The frame so far, its COBS bytes (decoded in place once its delimiter arrives).
    buf: [u8; N],
    /// Bytes of `buf` in use.
    idx: usize,
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
        FrameReader { buf: [0; N], idx: 0, in_frame: false, discarding: false }
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
        let start = self.idx;
        let Some(z) = input.iter().position(|&b| b == 0) else {
            // The frame goes on: keep its bytes, or, when they do not fit, drop what is
            // buffered and skip the frame up to its delimiter (it counts once).
            return match self.buf.get_mut(start..start + input.len()) {
                Some(dst) => {
                    copy(dst, input);
                    self.idx = start + input.len();
                    self.in_frame = true;
                    (Feed::Pending, &[])
                }
                None => {
                    self.idx = 0;
                    self.in_frame = false;
                    self.discarding = true;
                    (Feed::Malformed(Malformed::Oversize), input.get(N.saturating_sub(start)..).unwrap_or(&[]))
                }
            };
        };
        // The frame ends here (its delimiter included in `take`).
        let (take, rest) = input.split_at_checked(z + 1).unwrap_or((input, &[]));
        self.idx = 0;
        self.in_frame = false;
        let buf: &'de mut [u8; N] = &mut self.buf;
        let Some(frame) = buf.get_mut(..start + take.len()) else {
            return (Feed::Malformed(Malformed::Oversize), rest);
        };
        if let Some(dst) = frame.get_mut(start..) {
            copy(dst, take);
        }
        match cobs_decode_in_place(frame) {
            Some(len) => {
                let frame: &'de [u8] = frame;
                match frame.get(..len).map(postcard::from_bytes::<Envelope<'de>>) {
                    Some(Ok(env)) => (check_envelope(env), rest),
                    _ => (Feed::Malformed(Malformed::Framing), rest),
                }
            }
            None => (Feed::Malformed(Malformed::Framing), rest),
        }
    }
}

/// Copy `src` into `dst` (of the same length; without `copy_from_slice`'s length panic).
fn copy(dst: &mut [u8], src: &[u8]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d = *s;
    }
}

/// COBS-decode `buf` in place up to its first zero (or its end); the decoded length, or
/// `None` when it is not valid COBS (as the `cobs` crate's `decode_in_place` decides it).
fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    let (mut src, mut dst) = (0usize, 0usize);
    while src < end {
        let code = usize::from(*buf.get(src)?);
        if src + code > end && code != 1 {
            return None;
        }
        src += 1;
        for _ in 1..code {
            let b = *buf.get(src)?;
            *buf.get_mut(dst)? = b;
            src += 1;
            dst += 1;
        }
        if code != 0xFF && src < end {
            *buf.get_mut(dst)? = 0;
            dst += 1;
        }
    }
    Some(dst)
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
    let n = cobs_decode_in_place(body).ok_or(Malformed::Framing)?;
    let body: &'de [u8] = body;
    let env = body.get(..n).map(postcard::from_bytes::<Envelope<'de>>).ok_or(Malformed::Framing)?;
    let env = env.map_err(|_| Malformed::Framing)?;
    match check_envelope(env) {
        Feed::Message(m) => Ok(m),
        Feed::Malformed(e) => Err(e),
        Feed::Pending => Err(Malformed::Framing),
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;
    use crate::compensator::Sample;
    use crate::flags::Flags;
    use crate::protocol::{
        BootSource, DeviceEstimate, Refusals, RejectReason, Rejection, SpectrumError, SpectrumRefusal, SpectrumStatus,
        Status, StoreStatus, UpdateResult, MAX_CHUNK, STORE_SECTORS,
    };
    use crate::signature::KeyId;

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
            HostMsg::Sample { seq: 7, sample: Sample::new([12.5, -3.25, f32::NAN], 21.0, 1.0e6) },
            HostMsg::Sample {
                seq: u32::MAX,
                sample: Sample::new([f32::MAX; crate::layout::MAX_GRATINGS], f32::NAN, 1.0)
            },
            HostMsg::Sample { seq: 0, sample: Sample::new([0.5], f32::NAN, 0.0) },
            HostMsg::ModelBegin { total_len: 2900, crc32: 0x1234_5678 },
            HostMsg::ModelChunk { offset: u32::MAX, data: &DATA },
            HostMsg::ModelChunk { offset: 0, data: &[0, 0, 0] },
            HostMsg::ModelCommit,
            HostMsg::GetStatus,
            HostMsg::ResetStream { nonce: 3, clock: crate::StreamClock::StartUnix(1.7e9) },
            HostMsg::SpectrumGrid {
                gratings: 8,
                pixels: u16::MAX,
                uniform: false,
                coefficients: [f32::MAX; crate::spectrum::POLY_COEFFS],
                method: u8::MAX,
                full_scale: f32::INFINITY,
            },
            HostMsg::SpectrumGrating {
                index: u8::MAX,
                channel: u8::MAX,
                lo_nm: f32::MAX,
                hi_nm: f32::MIN,
                ref_hi_nm: 1550.0,
                ref_lo_nm: -1e-5,
            },
            HostMsg::SpectrumBegin { seq: u32::MAX, channel: u8::MAX, t_s: f32::NAN, t_amb_c: f32::NAN },
            HostMsg::SpectrumPixels { first_pixel: u16::MAX, data: &DATA },
        ]
    }

    fn device_msgs() -> Vec<DeviceMsg> {
        let rej = Rejection { reason: RejectReason::WrongDims, detail: u32::MAX };
        std::vec![
            DeviceMsg::Pong { nonce: u32::MAX },
            DeviceMsg::Estimate(DeviceEstimate {
                seq: u32::MAX,
                values: [f32::NAN, -1.0e30, 3.0, 0.0],
                band: [f32::INFINITY, 0.0, 1.0, 0.0],
                outputs: 3,
                flags: Flags::ALL,
            }),
            DeviceMsg::Estimate(DeviceEstimate {
                seq: u32::MAX,
                values: [f32::MAX; crate::layout::MAX_OUTPUTS],
                band: [f32::INFINITY; crate::layout::MAX_OUTPUTS],
                outputs: crate::layout::MAX_OUTPUTS as u8,
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
                model_serial: u64::MAX,
                model_key_id: Some(KeyId([0xFF; 8])),
                refused: Refusals {
                    unsigned: u32::MAX,
                    bad_signature: u32::MAX,
                    unknown_key: u32::MAX,
                    rollback: u32::MAX,
                    serial_reused: u32::MAX,
                },
                last_rejection: Some(rej),
                stack_peak_bytes: u32::MAX,
                stack_boot_bytes: u32::MAX,
                staging_erases: u32::MAX,
                store: StoreStatus {
                    boot_source: BootSource::Slot { slot: u8::MAX, generation: u32::MAX },
                    erases: [u32::MAX; STORE_SECTORS],
                    flash_ops: u32::MAX,
                    rollback_floor: u64::MAX,
                    log_events: u32::MAX,
                    refusals_unlogged: u32::MAX,
                    boot_time_us: u32::MAX,
                },
                spectra: SpectrumStatus {
                    frames: u32::MAX,
                    frames_dropped: u32::MAX,
                    refused: u32::MAX,
                    last_refusal: Some(SpectrumRefusal::new(SpectrumError::Overrun, u16::MAX)),
                },
            }),
            DeviceMsg::SpectrumSet { missing: u8::MAX },
            DeviceMsg::SpectrumAck { received: u16::MAX },
            DeviceMsg::SpectrumRefused(SpectrumRefusal::new(SpectrumError::BadGrating, u16::MAX)),
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
            soup.push(if x.is_multiple_of(29) { 0 } else { (x >> 8) as u8 });
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
