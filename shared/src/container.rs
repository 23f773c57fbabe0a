//! A model file: a `.fbgm` blob, optionally followed by a signature trailer
//! ([`crate::signature`] has its layout). This layer tells the two apart and splits them: the
//! blob goes to the decoder ([`crate::blob::decode`] reads it through [`strip`]), the signed
//! message and the trailer to the verifier ([`crate::signature::verify`]).
//!
//! The rule ([`open`]): bytes whose own last four bytes are their valid CRC are an unsigned
//! blob; otherwise bytes whose 96th-from-last byte starts `FBGS` and version 2, or whose
//! 88th-from-last byte starts `FBGS`, carry a trailer there (whatever state the blob before it
//! is in, so that a blob damaged after signing is reported as a bad signature, not as
//! unsigned; and whatever its version byte says, so that an unknown version is reported as
//! such); anything else is handed to the blob decoder as it is, which names the damage.

use crate::frame::{computed_crc, stored_crc, CRC_LEN, HEADER_LEN};
use crate::signature::{
    magic_at, SignatureError, Signed, TrailerHead, SIGNATURE_LEN, TRAILER_LEN, TRAILER_V2_LEN, TRAILER_VERSION_ROLLBACK,
};

/// What a model file is, signature-wise ([`open`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Envelope<'a> {
    /// No trailer: the bytes are a blob (or a damaged one, which decoding names).
    Unsigned(&'a [u8]),
    /// A blob with a signature trailer (not verified yet).
    Signed(Signed<'a>),
}

impl<'a> Envelope<'a> {
    /// The blob inside, whether signed or not.
    pub fn blob(&self) -> &'a [u8] {
        match self {
            Envelope::Unsigned(b) => b,
            Envelope::Signed(s) => s.blob,
        }
    }

    /// The trailer's head, when signed.
    pub fn head(&self) -> Option<TrailerHead> {
        match self {
            Envelope::Unsigned(_) => None,
            Envelope::Signed(s) => Some(s.head),
        }
    }
}

/// Tell a signed model from an unsigned one and split it (see the module docs for the rule).
/// A trailer that is there but malformed (unknown version, unknown flag, reserved bits set,
/// a length that is not its version's) is an error; the signature itself is not checked here.
pub fn open(bytes: &[u8]) -> Result<Envelope<'_>, SignatureError> {
    if computed_crc(bytes).is_some_and(|c| Some(c) == stored_crc(bytes)) {
        return Ok(Envelope::Unsigned(bytes));
    }
    // Where a trailer of `len` bytes would start, when a blob could precede it and the magic is there.
    let start =
        |len: usize| bytes.len().checked_sub(len).filter(|&at| at >= HEADER_LEN + CRC_LEN && magic_at(bytes, at));
    let v2 = start(TRAILER_V2_LEN);
    let at = match (v2, start(TRAILER_LEN)) {
        (Some(at), _) if bytes.get(at + 4) == Some(&TRAILER_VERSION_ROLLBACK) => at,
        (_, Some(at)) => at,
        // The magic where only a longer trailer could start: its version names what it is.
        (Some(at), None) => at,
        (None, None) => return Ok(Envelope::Unsigned(bytes)),
    };
    let (blob, trailer) = bytes.split_at_checked(at).unwrap_or((bytes, &[]));
    let head = TrailerHead::parse(trailer)?;
    if trailer.len() != head.len() + SIGNATURE_LEN {
        return Err(SignatureError::Malformed);
    }
    let (message, sig) = bytes.split_at_checked(at + head.len()).unwrap_or((bytes, &[]));
    let signature = *sig.first_chunk::<SIGNATURE_LEN>().ok_or(SignatureError::Malformed)?;
    Ok(Envelope::Signed(Signed { blob, message, head, signature }))
}

/// The blob of a model file, with its trailer (if any) cut off: what the blob decoder reads.
/// A malformed trailer leaves the bytes as they are (decoding then names what is wrong).
pub fn strip(bytes: &[u8]) -> &[u8] {
    match open(bytes) {
        Ok(e) => e.blob(),
        Err(_) => bytes,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing, clippy::panic)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use super::*;
    use crate::frame::computed_crc;
    use crate::signature::*;

    fn fake_blob() -> Vec<u8> {
        let mut b = std::vec![0u8; 40];
        b[..4].copy_from_slice(b"FBGM");
        let crc = computed_crc(&b).unwrap();
        let n = b.len();
        b[n - 4..].copy_from_slice(&crc.to_le_bytes());
        b
    }

    #[test]
    fn head_round_trips_and_unsigned_stays_unsigned() {
        let head = TrailerHead {
            flags: SignFlags::ALLOW_ROLLBACK,
            serial: 0x0102_0304_0506_0708,
            key_id: KeyId([7; 8]),
            replaces: None,
        };
        let bytes = head.to_bytes();
        assert_eq!(&bytes[..4], b"FBGS");
        assert_eq!(bytes[4], TRAILER_VERSION);
        assert_eq!(bytes[5], 1);
        assert_eq!(&bytes[8..16], &0x0102_0304_0506_0708u64.to_le_bytes());
        assert_eq!(TrailerHead::parse(&bytes), Ok(head));

        let blob = fake_blob();
        assert_eq!(open(&blob), Ok(Envelope::Unsigned(&blob[..])));
        let mut signed = blob.clone();
        signed.extend_from_slice(&bytes);
        signed.extend_from_slice(&[9u8; SIGNATURE_LEN]);
        let Envelope::Signed(s) = open(&signed).unwrap() else { panic!("not signed") };
        assert_eq!(s.blob, &blob[..]);
        assert_eq!(s.message.len(), blob.len() + TRAILER_HEAD_LEN);
        assert_eq!(s.head, head);
        assert_eq!(s.signature, [9u8; SIGNATURE_LEN]);
        assert_eq!(strip(&signed), &blob[..]);

        // A flipped payload bit: still a signed model (the signature check will refuse it).
        signed[10] ^= 1;
        assert!(matches!(open(&signed), Ok(Envelope::Signed(_))));
        // Unknown flags, version, reserved bytes.
        let at = blob.len();
        let mut bad = signed.clone();
        bad[at + 5] = 0x82;
        assert_eq!(open(&bad), Err(SignatureError::UnknownFlags { bits: 0x82 }));
        let mut bad = signed.clone();
        bad[at + 4] = 9;
        assert_eq!(open(&bad), Err(SignatureError::UnsupportedTrailer { version: 9 }));
        let mut bad = signed.clone();
        bad[at + 7] = 1;
        assert_eq!(open(&bad), Err(SignatureError::Reserved));
    }

    /// `blob`, a head and a dummy signature.
    fn with_trailer(blob: &[u8], head: &[u8]) -> Vec<u8> {
        let mut v = blob.to_vec();
        v.extend_from_slice(head);
        v.extend_from_slice(&[9u8; SIGNATURE_LEN]);
        v
    }

    #[test]
    fn a_rollback_is_a_version_2_trailer_naming_the_serial_it_replaces() {
        let head =
            TrailerHead { flags: SignFlags::ALLOW_ROLLBACK, serial: 4, key_id: KeyId([3; 8]), replaces: Some(5) };
        let bytes = head.to_bytes();
        assert_eq!(bytes.len(), TRAILER_V2_HEAD_LEN);
        assert_eq!(bytes[4], TRAILER_VERSION_ROLLBACK);
        assert_eq!(&bytes[24..32], &5u64.to_le_bytes());
        assert_eq!(TrailerHead::parse(&bytes), Ok(head));
        assert_eq!(head.rollback_of(), Some(5));
        let blob = fake_blob();
        let signed = with_trailer(&blob, &bytes);
        assert_eq!(signed.len(), blob.len() + TRAILER_V2_LEN);
        let Envelope::Signed(s) = open(&signed).unwrap() else { panic!("not signed") };
        assert_eq!((s.blob, s.head, s.message.len()), (&blob[..], head, blob.len() + TRAILER_V2_HEAD_LEN));
        assert_eq!(strip(&signed), &blob[..]);

        // A version-1 allow-rollback flag grants no rollback.
        let v1 = TrailerHead { replaces: None, ..head };
        assert_eq!((v1.to_bytes().len(), v1.rollback_of()), (TRAILER_HEAD_LEN, None));
        // A replaced serial without the flag is malformed.
        let mut bad = signed.clone();
        bad[blob.len() + 5] = 0;
        assert_eq!(open(&bad), Err(SignatureError::Malformed));
        // A version-1 trailer whose version byte says 2 (8 bytes short of a version-2 one).
        let mut short = blob.clone();
        short.extend_from_slice(&bytes[..TRAILER_HEAD_LEN]);
        short.extend_from_slice(&[9u8; SIGNATURE_LEN]);
        short[blob.len() + 4] = TRAILER_VERSION_ROLLBACK;
        assert_eq!(open(&short), Err(SignatureError::Malformed));
    }

    #[test]
    fn unknown_versions_and_reserved_bytes_are_named() {
        let blob = fake_blob();
        for head in [
            TrailerHead { flags: SignFlags::NONE, serial: 7, key_id: KeyId([1; 8]), replaces: None },
            TrailerHead { flags: SignFlags::ALLOW_ROLLBACK, serial: 7, key_id: KeyId([1; 8]), replaces: Some(8) },
        ] {
            let signed = with_trailer(&blob, &head.to_bytes());
            let at = blob.len();
            for version in [0u8, 3, 0xff] {
                let mut bad = signed.clone();
                bad[at + 4] = version;
                assert_eq!(open(&bad), Err(SignatureError::UnsupportedTrailer { version }), "{head:?}");
                assert_eq!(
                    std::format!("{}", SignatureError::UnsupportedTrailer { version }),
                    std::format!("signature trailer version {version} not supported (this build reads 1 and 2)")
                );
            }
            for i in [6, 7] {
                let mut bad = signed.clone();
                bad[at + i] = 0x10;
                assert_eq!(open(&bad), Err(SignatureError::Reserved));
            }
        }
        assert_eq!(std::format!("{}", SignatureError::Reserved), "signature trailer has a reserved byte set");
    }

    #[test]
    fn key_id_prints_as_hex() {
        assert_eq!(std::format!("{}", KeyId([0xab, 0, 1, 2, 3, 4, 5, 0xff])), "ab000102030405ff");
    }
}
