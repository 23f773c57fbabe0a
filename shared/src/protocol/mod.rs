//! The serial link between a host and the interrogator's co-processor.
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
//! COBS framing is postcard's on the way out ([`postcard::to_slice_cobs`]) and [`FrameReader`]'s
//! own, without panic paths, on the way in; `0x00` only ever appears as the frame delimiter,
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
//! | `Ping{nonce}` / `ResetStream{nonce, clock}` | `Pong{nonce}` |
//! | `Sample{seq, sample}` | `Estimate{seq, values, band, flags}` |
//! | `GetStatus` | `Status{..}` |
//! | `ModelBegin{total_len, crc32}` / `ModelChunk{offset, data}` | `UpdateProgress{received}`, or `UpdateResult(Rejected)` |
//! | `ModelCommit` | `UpdateResult(Accepted | Rejected)` |
//! | `SpectrumGrid{..}` / `SpectrumGrating{..}` | `SpectrumSet{missing}` or `SpectrumRefused` |
//! | `SpectrumBegin{seq, channel, t_s, t_amb_c}` / `SpectrumPixels{first_pixel, data}` | `SpectrumAck{received}`, `Estimate` (the frame that completes a reading), or `SpectrumRefused` |
//!
//! A model update stages the blob (`ModelBegin`, in-order `ModelChunk`s of at most
//! [`MAX_CHUNK`] bytes), then `ModelCommit` checks the transfer CRC and decodes the blob with
//! [`crate::blob::decode`] (magic, version, dims, CRC, every parameter) before swapping. Any
//! failure aborts the transfer, keeps the old model and answers with a [`Rejection`] whose
//! [`RejectReason`] codes are stable across versions. A device that requires signed models
//! checks the signature trailer ([`crate::signature`]) first: unsigned, unknown key, bad
//! signature, rollback (a lower serial, or a signed rollback that does not name the running
//! serial) and another model under the running serial are refused before the blob is decoded.
//!
//! # Example
//!
//! A host frames a request; the device's [`FrameReader`] takes the bytes as they come, in any
//! pieces, and yields each message once its frame is complete:
//!
//! ```
//! use fbg_shared::protocol::{encode_host, Feed, FrameReader, HostMsg, HOST_MAX_FRAME};
//!
//! let mut out = [0u8; HOST_MAX_FRAME];
//! let frame = encode_host(&HostMsg::Ping { nonce: 7 }, &mut out)?;
//! assert_eq!(frame.last(), Some(&0)); // the delimiter
//!
//! let mut reader = FrameReader::<HOST_MAX_FRAME>::new();
//! let (first, second) = frame.split_at(3);
//! let (ev, rest) = reader.feed::<HostMsg<'_>>(first);
//! assert!(matches!(ev, Feed::Pending) && rest.is_empty());
//! let (ev, _) = reader.feed::<HostMsg<'_>>(second);
//! assert_eq!(ev, Feed::Message(HostMsg::Ping { nonce: 7 }));
//! # Ok::<(), fbg_shared::protocol::EncodeError>(())
//! ```
//!
//! # Modules
//!
//! - `messages`: what travels ([`HostMsg`], [`DeviceMsg`] and their parts) and its size
//!   limits;
//! - `spectrum`: spectrum frames' limits, refusals and counters ([`SpectrumError`]);
//! - `reject`: the stable [`RejectReason`] codes of a refused model update;
//! - `framing`: CRC envelope, COBS frames, the incremental [`FrameReader`].
//!
//! Everything is re-exported here: `fbg_shared::protocol::X` is the one path to use.

mod framing;
mod messages;
mod reject;
mod spectrum;

pub use framing::{
    crc32, decode_frame, encode_device, encode_host, encode_into, EncodeError, Feed, FrameReader, Malformed,
    DEVICE_MAX_FRAME, HOST_MAX_FRAME,
};
pub use messages::{
    BootSource, DeviceEstimate, DeviceMsg, HostMsg, Refusals, Status, StoreStatus, UpdateResult, DEVICE_MAX_PAYLOAD,
    HOST_MAX_PAYLOAD, MAX_CHUNK, MAX_PIXELS_PER_CHUNK, STORE_SECTORS,
};
pub use reject::{RejectReason, Rejection};
pub use spectrum::{SpectrumError, SpectrumRefusal, SpectrumStatus, MAX_FRAME_PIXELS};
