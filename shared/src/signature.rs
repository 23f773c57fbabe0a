//! The signature trailer of a signed model blob: the one definition of the host ↔ device
//! contract that says who made a model and which release it is.
//!
//! A signed model is the unsigned `.fbgm` blob, byte for byte, followed by a trailer
//! (little-endian) of one of two versions:
//!
//! ```text
//! offset  size  field
//! 0       4     magic "FBGS"
//! 4       1     trailer version: 1 (88 bytes) or 2 (96 bytes)
//! 5       1     flags (SignFlags: bit 0 = allow rollback; other bits must be 0)
//! 6       2     reserved, 0
//! 8       8     serial, u64 LE (model release number, monotonic per key id)
//! 16      8     key id: the first 8 bytes of SHA-256 of the signer's Ed25519 public key
//! 24      8     version 2 only: replaces, u64 LE (the one serial this rollback may replace)
//! 24|32   64    Ed25519 signature (RFC 8032, pure Ed25519) of the signed message
//! ```
//!
//! The **signed message** is everything before the signature: the whole blob (header, version,
//! payload and its CRC) followed by the trailer's head (24 bytes in version 1, 32 in version
//! 2). It is contiguous in the file, so a device verifies the staged bytes in place, and
//! serial, flags, key id and the replaced serial are covered as well as the model.
//!
//! **Versions.** A signer writes version 1 for every model except a rollback, so that devices
//! built before version 2 still take ordinary updates; a rollback (the allow-rollback flag) is
//! written as version 2 and must name the serial it replaces: a device accepts it only while
//! that serial is running (and only when built to accept rollbacks at all), so it cannot be
//! replayed once the device has moved on. A version-2 trailer without the flag is malformed. A
//! version-1 trailer is accepted without rollback: its allow-rollback flag (written by older
//! signers, with no bound) grants nothing, and the model is judged like any other update
//! (serial above the running one). Any other version is refused as unsupported.
//!
//! Unsigned blobs stay valid and byte-identical: the trailer only ever follows a blob.
//! Telling the two apart and splitting a signed file is the container's ([`crate::container`]).
//!
//! The verifier ([`verify`], feature `verify`) is `salty`'s Ed25519 (no heap, `no_std`; on a
//! Cortex-M4F its field arithmetic is the `UMAAL` assembly of Haase's Curve25519 code, on other
//! targets the portable TweetNaCl arithmetic), plus the RFC 8032 range check of `S` that
//! `salty` leaves out (a non-canonical `S` is refused). README-firmware.md, "Signed model
//! updates", says why `salty` and not `ed25519-compact`.

/// Trailer magic.
pub const TRAILER_MAGIC: [u8; 4] = *b"FBGS";
/// Trailer version of an ordinary signed model (no rollback).
pub const TRAILER_VERSION: u8 = 1;
/// Trailer version of a rollback: version 1's fields and the serial it replaces.
pub const TRAILER_VERSION_ROLLBACK: u8 = 2;
/// Bytes of a version-1 trailer.
pub const TRAILER_LEN: usize = 88;
/// Bytes of a version-1 trailer the signature covers (everything before the signature).
pub const TRAILER_HEAD_LEN: usize = 24;
/// Bytes of a version-2 (rollback) trailer.
pub const TRAILER_V2_LEN: usize = 96;
/// Bytes of a version-2 trailer the signature covers.
pub const TRAILER_V2_HEAD_LEN: usize = 32;
/// Bytes of an Ed25519 signature.
pub const SIGNATURE_LEN: usize = 64;
/// Bytes of an Ed25519 public key.
pub const PUBLIC_KEY_LEN: usize = 32;
/// Bytes of a key id.
pub const KEY_ID_LEN: usize = 8;

const _: () = assert!(TRAILER_HEAD_LEN + SIGNATURE_LEN == TRAILER_LEN);
const _: () = assert!(TRAILER_V2_HEAD_LEN + SIGNATURE_LEN == TRAILER_V2_LEN);

/// Which key signed: the first 8 bytes of SHA-256 of its 32-byte Ed25519 public key
/// ([`key_id`], feature `key-id`). An id names a key; it proves nothing by itself (the
/// signature does).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct KeyId(pub [u8; KEY_ID_LEN]);

impl core::fmt::Display for KeyId {
    /// Lower-case hex, 16 digits.
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        for b in self.0 {
            write!(f, "{b:02x}")?;
        }
        Ok(())
    }
}

/// The id of an Ed25519 public key: the first 8 bytes of its SHA-256.
#[cfg(feature = "key-id")]
pub fn key_id(public_key: &[u8; PUBLIC_KEY_LEN]) -> KeyId {
    use sha2::Digest;
    let digest = sha2::Sha256::digest(public_key);
    let mut id = [0u8; KEY_ID_LEN];
    for (o, b) in id.iter_mut().zip(digest.iter()) {
        *o = *b;
    }
    KeyId(id)
}

/// The flags a signer sets in the trailer (covered by the signature).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SignFlags(u8);

impl SignFlags {
    /// No flag.
    pub const NONE: SignFlags = SignFlags(0);
    /// The signer allows this model to replace one with a higher serial (a deliberate
    /// downgrade); a device accepts it only when its build allows rollback too.
    pub const ALLOW_ROLLBACK: SignFlags = SignFlags(1);
    /// Every bit this version defines.
    pub const KNOWN: u8 = 1;

    /// The flags of `bits`, or `None` when a bit this version does not define is set.
    pub const fn from_bits(bits: u8) -> Option<SignFlags> {
        if bits & !Self::KNOWN == 0 {
            Some(SignFlags(bits))
        } else {
            None
        }
    }

    /// The raw bits.
    pub const fn bits(self) -> u8 {
        self.0
    }

    /// Whether every flag of `other` is set.
    pub const fn contains(self, other: SignFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// `self` with the flags of `other` set too.
    pub const fn with(self, other: SignFlags) -> SignFlags {
        SignFlags(self.0 | other.0)
    }
}

/// What a signer states about a model: serial, flags, key and, for a rollback, the serial it
/// replaces (the signed part of the trailer).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TrailerHead {
    /// Flags.
    pub flags: SignFlags,
    /// Model release number (monotonic per key id on the signing host).
    pub serial: u64,
    /// The signer's key id.
    pub key_id: KeyId,
    /// The one running serial this model may replace although its own serial is lower: set
    /// (version-2 trailer) exactly when the allow-rollback flag is; `None` in version 1.
    pub replaces: Option<u64>,
}

/// The signed bytes of a trailer's head ([`TrailerHead::to_bytes`]): 24 bytes in version 1,
/// 32 in version 2; dereferences to the slice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct HeadBytes {
    buf: [u8; TRAILER_V2_HEAD_LEN],
    len: usize,
}

impl core::ops::Deref for HeadBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }
}

impl TrailerHead {
    /// The trailer version these fields are written as: 2 when a replaced serial is named.
    pub const fn version(&self) -> u8 {
        if self.replaces.is_some() {
            TRAILER_VERSION_ROLLBACK
        } else {
            TRAILER_VERSION
        }
    }

    /// Bytes of the head ([`TRAILER_HEAD_LEN`] or [`TRAILER_V2_HEAD_LEN`]).
    pub const fn len(&self) -> usize {
        if self.replaces.is_some() {
            TRAILER_V2_HEAD_LEN
        } else {
            TRAILER_HEAD_LEN
        }
    }

    /// Whether the head is empty (never: it always has its magic).
    pub const fn is_empty(&self) -> bool {
        false
    }

    /// The bytes of the trailer before the signature (magic, version, flags, reserved,
    /// serial, key id, and in version 2 the replaced serial). The signed message is the blob
    /// followed by these bytes.
    pub fn to_bytes(&self) -> HeadBytes {
        let mut buf = [0u8; TRAILER_V2_HEAD_LEN];
        let replaces = self.replaces.unwrap_or(0).to_le_bytes();
        let fields: [&[u8]; 7] = [
            &TRAILER_MAGIC,
            &[self.version()],
            &[self.flags.bits()],
            &[0, 0],
            &self.serial.to_le_bytes(),
            &self.key_id.0,
            if self.replaces.is_some() { &replaces } else { &[] },
        ];
        let mut at = buf.iter_mut();
        for b in fields.iter().flat_map(|f| f.iter()) {
            if let Some(o) = at.next() {
                *o = *b;
            }
        }
        HeadBytes { buf, len: self.len() }
    }

    /// Parse the signed part of a trailer (`bytes` from the trailer's magic on): version 1 or
    /// 2, known flags, reserved bytes zero, and the replaced serial exactly with the
    /// allow-rollback flag in version 2.
    pub fn parse(bytes: &[u8]) -> Result<TrailerHead, SignatureError> {
        if !magic_at(bytes, 0) {
            return Err(SignatureError::Unsigned);
        }
        let byte = |i: usize| bytes.get(i).copied().unwrap_or(0);
        let version = byte(4);
        let len = match version {
            TRAILER_VERSION => TRAILER_HEAD_LEN,
            TRAILER_VERSION_ROLLBACK => TRAILER_V2_HEAD_LEN,
            _ => return Err(SignatureError::UnsupportedTrailer { version }),
        };
        let head = bytes.get(..len).ok_or(SignatureError::Malformed)?;
        let flags = SignFlags::from_bits(byte(5)).ok_or(SignatureError::UnknownFlags { bits: byte(5) })?;
        if byte(6) != 0 || byte(7) != 0 {
            return Err(SignatureError::Reserved);
        }
        let eight = |at: usize| head.get(at..).and_then(<[u8]>::first_chunk::<8>).copied().unwrap_or_default();
        let replaces = (version == TRAILER_VERSION_ROLLBACK).then(|| u64::from_le_bytes(eight(24)));
        if replaces.is_some() && !flags.contains(SignFlags::ALLOW_ROLLBACK) {
            return Err(SignatureError::Malformed);
        }
        Ok(TrailerHead { flags, serial: u64::from_le_bytes(eight(8)), key_id: KeyId(eight(16)), replaces })
    }

    /// The bounded rollback this head grants: the serial it may replace, when the
    /// allow-rollback flag is set and a replaced serial is named (version 2). A version-1
    /// allow-rollback flag grants nothing.
    pub fn rollback_of(&self) -> Option<u64> {
        self.replaces.filter(|_| self.flags.contains(SignFlags::ALLOW_ROLLBACK))
    }
}

/// A signed model, split: the blob, the signed message, the trailer's fields and signature.
/// Nothing is verified yet ([`verify`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Signed<'a> {
    /// The `.fbgm` blob before the trailer (as [`crate::blob::decode`] reads it).
    pub blob: &'a [u8],
    /// The signed message: the blob and the trailer's head.
    pub message: &'a [u8],
    /// Serial, flags, key id.
    pub head: TrailerHead,
    /// The Ed25519 signature over `message`.
    pub signature: [u8; SIGNATURE_LEN],
}

/// Whether [`TRAILER_MAGIC`] starts at `at` (byte compares: no `memcmp` in the image).
pub(crate) fn magic_at(bytes: &[u8], at: usize) -> bool {
    matches!(bytes.get(at..), Some([b'F', b'B', b'G', b'S', ..]))
}

const _: () = assert!(matches!(TRAILER_MAGIC, [b'F', b'B', b'G', b'S']));

/// A public key a device (or an inspector) trusts, with its id.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TrustedKey {
    /// [`key_id`] of `public`.
    pub id: KeyId,
    /// The 32-byte Ed25519 public key.
    pub public: [u8; PUBLIC_KEY_LEN],
}

/// Why a signed model is not accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[non_exhaustive]
pub enum SignatureError {
    /// No signature trailer.
    Unsigned,
    /// A trailer of a version this build does not read.
    UnsupportedTrailer {
        /// The version found.
        version: u8,
    },
    /// A flag this version does not define is set.
    UnknownFlags {
        /// The flag byte.
        bits: u8,
    },
    /// The reserved trailer bytes are not zero.
    Reserved,
    /// The key id names no trusted key.
    UnknownKey {
        /// The trailer's key id.
        key_id: KeyId,
    },
    /// The signature does not verify with the key the trailer names (the blob, the serial or
    /// the flags were changed after signing, or the key's public part is not the one that
    /// signed), or the public key itself is not a valid Ed25519 key.
    BadSignature,
    /// The trailer's length is not its version's, or a version-2 trailer names a replaced
    /// serial without the allow-rollback flag.
    Malformed,
    /// The serial is lower than the running model's and no rollback applies (none signed, or a
    /// version-1 allow-rollback flag, which grants nothing).
    Rollback {
        /// The update's serial.
        serial: u64,
        /// The running model's serial.
        running: u64,
    },
    /// A rollback signed to replace serial `replaces`, while another serial runs (a replay
    /// after the device moved on, or before it got there), or on a build that accepts no
    /// rollback (`enabled` false).
    RollbackNotPermitted {
        /// The update's serial.
        serial: u64,
        /// The serial the rollback may replace.
        replaces: u64,
        /// The running model's serial.
        running: u64,
        /// Whether this build accepts rollbacks at all.
        enabled: bool,
    },
    /// The serial of the running model, on another model (blob CRC differs): two models signed
    /// with one serial cannot be swapped for each other.
    SerialReused {
        /// The serial.
        serial: u64,
    },
}

impl core::fmt::Display for SignatureError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SignatureError::Unsigned => f.write_str("the model is not signed"),
            SignatureError::UnsupportedTrailer { version } => {
                write!(
                    f,
                    "signature trailer version {version} not supported (this build reads {TRAILER_VERSION} and {TRAILER_VERSION_ROLLBACK})"
                )
            }
            SignatureError::UnknownFlags { bits } => write!(f, "signature trailer has unknown flags {bits:#04x}"),
            SignatureError::Reserved => f.write_str("signature trailer has a reserved byte set"),
            SignatureError::UnknownKey { key_id } => write!(f, "signed by key {key_id}, which is not trusted"),
            SignatureError::BadSignature => f.write_str("the signature does not verify (changed after signing?)"),
            SignatureError::Rollback { serial, running } => {
                write!(f, "serial {serial} is lower than the running model's {running} (rollback not allowed)")
            }
            SignatureError::Malformed => f.write_str(
                "signature trailer is malformed (length not its version's, or a replaced serial without the rollback flag)",
            ),
            SignatureError::RollbackNotPermitted { serial, replaces, running, enabled: true } => write!(
                f,
                "rollback to serial {serial} may replace serial {replaces} only, but serial {running} is running"
            ),
            SignatureError::RollbackNotPermitted { serial, enabled: false, .. } => {
                write!(f, "serial {serial} is a rollback, which this firmware build does not accept")
            }
            SignatureError::SerialReused { serial } => {
                write!(f, "serial {serial} is the running model's, on another model (a serial names one model)")
            }
        }
    }
}

impl core::error::Error for SignatureError {}

/// The trusted key named by `id`.
pub fn find_key(keys: &[TrustedKey], id: KeyId) -> Option<&TrustedKey> {
    keys.iter().find(|k| k.id == id)
}

/// Check the Ed25519 signature of `signed` with `public` (RFC 8032 verification: `salty`, and
/// `S` below the group order).
#[cfg(feature = "verify")]
pub fn verify_with(signed: &Signed<'_>, public: &[u8; PUBLIC_KEY_LEN]) -> Result<(), SignatureError> {
    verify_message(signed.message, &signed.signature, public)
}

/// Check an Ed25519 signature of `message` with `public` (the primitive under
/// [`verify_with`], exposed for the RFC 8032 test vectors).
#[cfg(feature = "verify")]
#[inline(never)]
pub fn verify_message(
    message: &[u8],
    signature: &[u8; SIGNATURE_LEN],
    public: &[u8; PUBLIC_KEY_LEN],
) -> Result<(), SignatureError> {
    // RFC 8032 section 5.1.7: S must be below the group order L, else a signature could be
    // turned into another valid one (S + L); salty's `verify` does not check it itself.
    if !s_is_canonical(signature) {
        return Err(SignatureError::BadSignature);
    }
    let key = salty::PublicKey::try_from(public).map_err(|_| SignatureError::BadSignature)?;
    let sig = salty::Signature::from(signature);
    key.verify(message, &sig).map_err(|_| SignatureError::BadSignature)
}

/// The group order L = 2^252 + 27742317777372353535851937790883648493, little-endian.
#[cfg(feature = "verify")]
const GROUP_ORDER: [u8; 32] = [
    0xed, 0xd3, 0xf5, 0x5c, 0x1a, 0x63, 0x12, 0x58, 0xd6, 0x9c, 0xf7, 0xa2, 0xde, 0xf9, 0xde, 0x14, 0, 0, 0, 0, 0, 0,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0x10,
];

/// Whether the `S` half of `signature` (little-endian, bytes 32..64) is below L.
#[cfg(feature = "verify")]
fn s_is_canonical(signature: &[u8; SIGNATURE_LEN]) -> bool {
    // Compare from the most significant byte down.
    for (s, l) in signature.iter().skip(32).rev().zip(GROUP_ORDER.iter().rev()) {
        if s != l {
            return s < l;
        }
    }
    false
}

/// Check `signed` against `keys`: its key id must name one of them ([`SignatureError::UnknownKey`])
/// and the signature must verify with that key ([`SignatureError::BadSignature`]).
#[cfg(feature = "verify")]
pub fn verify(signed: &Signed<'_>, keys: &[TrustedKey]) -> Result<(), SignatureError> {
    let key = find_key(keys, signed.head.key_id).ok_or(SignatureError::UnknownKey { key_id: signed.head.key_id })?;
    verify_with(signed, &key.public)
}
