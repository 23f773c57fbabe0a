//! Why a model update was refused: the stable reason codes, the [`Rejection`] sent back, and
//! their mapping from blob and signature errors.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::error::Error;
use crate::signature::SignatureError;

/// Stable reason codes of a refused model update. The numbers never change meaning; new reasons
/// get new numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
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
    /// The model's gratings or measurands exceed this build's capacity
    /// ([`Error::OverCapacity`]; detail: the model's count in the high 16 bits, the capacity in
    /// the low 16).
    OverCapacity = 11,
    /// A chunk or commit arrived with no transfer in progress.
    NoUpdateInProgress = 20,
    /// The announced length exceeds what this build stages (its staging slot, or the blob
    /// limit; or it is shorter than any blob).
    TooLarge = 21,
    /// A chunk's offset is not the number of bytes received so far.
    OutOfOrder = 22,
    /// A chunk runs past the announced length.
    Overrun = 23,
    /// Commit before all announced bytes arrived.
    Incomplete = 24,
    /// The staged bytes do not match the announced whole-blob CRC.
    TransferCrc = 25,
    /// The device could not erase or program its staging flash slot (detail: the slot offset
    /// of the failed operation); the running model is untouched.
    Storage = 26,
    /// The staging slot would need an erase, but it was erased as often as allowed since the
    /// last accepted update (detail: the budget); an accepted update or a restart renews it.
    EraseLimit = 27,
    /// The model carries no signature trailer ([`SignatureError::Unsigned`]); this build accepts
    /// signed models only.
    Unsigned = 30,
    /// The signature does not verify with the key it names, or the trailer is malformed
    /// ([`SignatureError::BadSignature`] and the trailer errors; detail: the trailer version for
    /// an unknown one, the flag byte for unknown flags).
    BadSignature = 31,
    /// The key id names no key this build trusts ([`SignatureError::UnknownKey`]; detail: the
    /// key id's first four bytes, big-endian, as it prints).
    UnknownKey = 32,
    /// The serial is lower than the running model's and no rollback was signed for it
    /// ([`SignatureError::Rollback`]; detail: the update's serial, saturated to u32).
    Rollback = 33,
    /// A rollback signed to replace another serial than the running one (a replay), or sent to
    /// a build that accepts no rollback ([`SignatureError::RollbackNotPermitted`]; detail: the
    /// serial it may replace, saturated to u32).
    RollbackNotPermitted = 34,
    /// The running model's serial on another model ([`SignatureError::SerialReused`]; detail:
    /// the serial, saturated to u32).
    SerialReused = 35,
    /// A reason this build does not know (a newer device, or a future [`Error`] variant).
    Other = 255,
}

impl RejectReason {
    /// Every reason this version defines.
    pub const ALL: [RejectReason; 26] = [
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
        RejectReason::OverCapacity,
        RejectReason::NoUpdateInProgress,
        RejectReason::TooLarge,
        RejectReason::OutOfOrder,
        RejectReason::Overrun,
        RejectReason::Incomplete,
        RejectReason::TransferCrc,
        RejectReason::Storage,
        RejectReason::EraseLimit,
        RejectReason::Unsigned,
        RejectReason::BadSignature,
        RejectReason::UnknownKey,
        RejectReason::Rollback,
        RejectReason::RollbackNotPermitted,
        RejectReason::SerialReused,
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
            RejectReason::OverCapacity => "more gratings or measurands than this firmware holds",
            RejectReason::NoUpdateInProgress => "no model transfer in progress",
            RejectReason::TooLarge => "announced blob length does not fit the staging slot",
            RejectReason::OutOfOrder => "chunk offset out of order",
            RejectReason::Overrun => "chunk runs past the announced length",
            RejectReason::Incomplete => "commit before the whole blob arrived",
            RejectReason::TransferCrc => "staged bytes do not match the announced CRC",
            RejectReason::Storage => "the staging flash could not be erased or programmed",
            RejectReason::EraseLimit => {
                "staging flash erased as often as allowed without an accepted update (restart to renew)"
            }
            RejectReason::Unsigned => "model not signed (this firmware accepts signed models only)",
            RejectReason::BadSignature => "signature does not verify (or malformed signature trailer)",
            RejectReason::UnknownKey => "signed by a key this firmware does not trust",
            RejectReason::Rollback => "serial lower than the running model's (rollback not allowed)",
            RejectReason::RollbackNotPermitted => {
                "rollback not permitted (signed to replace another serial, or this firmware accepts no rollback)"
            }
            RejectReason::SerialReused => "serial of the running model on another model",
            RejectReason::Other => "unknown reason",
        }
    }
}

impl core::fmt::Display for RejectReason {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.describe())
    }
}

/// Why an update was refused, with a reason-specific detail number.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Rejection {
    /// Stable reason code.
    pub reason: RejectReason,
    /// Detail: found version for `UnsupportedVersion`; `found << 16 | expected` for
    /// `WrongDims`; extra bytes for `TrailingBytes`; centres for `TooManyCentres`; the length for
    /// `TooLarge`; the expected offset for `OutOfOrder`; bytes received for `Incomplete`;
    /// 0 otherwise.
    pub detail: u32,
}

impl Rejection {
    /// A rejection without detail.
    pub const fn new(reason: RejectReason) -> Self {
        Rejection { reason, detail: 0 }
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
            Error::OverCapacity { found, capacity, .. } => {
                (RejectReason::OverCapacity, (found as u32) << 16 | capacity as u32)
            }
            #[allow(unreachable_patterns)] // `Error` is non_exhaustive
            _ => (RejectReason::Other, 0),
        };
        Rejection { reason, detail }
    }
}

impl From<SignatureError> for Rejection {
    /// Map a signature check's failure to its stable code and detail.
    fn from(e: SignatureError) -> Self {
        let (reason, detail) = match e {
            SignatureError::Unsigned => (RejectReason::Unsigned, 0),
            SignatureError::UnsupportedTrailer { version } => (RejectReason::BadSignature, u32::from(version)),
            SignatureError::UnknownFlags { bits } => (RejectReason::BadSignature, u32::from(bits)),
            SignatureError::Reserved | SignatureError::Malformed | SignatureError::BadSignature => {
                (RejectReason::BadSignature, 0)
            }
            SignatureError::UnknownKey { key_id } => {
                let [a, b, c, d, ..] = key_id.0;
                (RejectReason::UnknownKey, u32::from_be_bytes([a, b, c, d]))
            }
            SignatureError::Rollback { serial, .. } => {
                (RejectReason::Rollback, u32::try_from(serial).unwrap_or(u32::MAX))
            }
            SignatureError::RollbackNotPermitted { replaces, .. } => {
                (RejectReason::RollbackNotPermitted, u32::try_from(replaces).unwrap_or(u32::MAX))
            }
            SignatureError::SerialReused { serial } => {
                (RejectReason::SerialReused, u32::try_from(serial).unwrap_or(u32::MAX))
            }
            #[allow(unreachable_patterns)] // `SignatureError` is non_exhaustive
            _ => (RejectReason::Other, 0),
        };
        Rejection { reason, detail }
    }
}

fn sat_u32(v: usize) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;

    #[test]
    fn reject_codes_are_stable_and_round_trip() {
        let codes: Vec<u8> = RejectReason::ALL.iter().map(|r| r.code()).collect();
        assert_eq!(
            codes,
            [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 20, 21, 22, 23, 24, 25, 26, 27, 30, 31, 32, 33, 34, 35, 255]
        );
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
        let e = Rejection::from(Error::OverCapacity { field: "gratings", found: 9, capacity: 8 });
        assert_eq!(e, Rejection { reason: RejectReason::OverCapacity, detail: 9 << 16 | 8 });
        assert_eq!(Rejection::from(Error::BadParameter { field: "hyper.sigma" }).reason, RejectReason::BadParameter);
        let id = crate::signature::KeyId([0xde, 0xad, 0xbe, 0xef, 1, 2, 3, 4]);
        assert_eq!(
            Rejection::from(SignatureError::UnknownKey { key_id: id }),
            Rejection { reason: RejectReason::UnknownKey, detail: 0xdead_beef }
        );
        assert_eq!(
            Rejection::from(SignatureError::Rollback { serial: 3, running: 9 }),
            Rejection { reason: RejectReason::Rollback, detail: 3 }
        );
        assert_eq!(
            Rejection::from(SignatureError::RollbackNotPermitted { serial: 4, replaces: 5, running: 9, enabled: true }),
            Rejection { reason: RejectReason::RollbackNotPermitted, detail: 5 }
        );
        assert_eq!(
            Rejection::from(SignatureError::SerialReused { serial: 5 }),
            Rejection { reason: RejectReason::SerialReused, detail: 5 }
        );
        assert_eq!(Rejection::from(SignatureError::Unsigned).reason, RejectReason::Unsigned);
        assert_eq!(Rejection::from(SignatureError::BadSignature).reason, RejectReason::BadSignature);
    }
}
