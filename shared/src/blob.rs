//! The `.fbgm` model blob: the one file a trained model travels in, from the trainer to a
//! device.
//!
//! ```text
//! offset  size  field
//! 0       4     magic "FBGM"
//! 4       2     format version, u16 LE (this build writes FORMAT_VERSION)
//! 6       2     inputs       (5: Δλ1..3, T_amb, t)
//! 8       2     outputs      (3: T, ε, p)
//! 10      2     poly terms   (10)
//! 12      2     memory terms (32: slots of the memory vector m, used or not)
//! 14      2     centres      (K of this model)
//! 16      n     postcard payload: ModelParams<f32, K>
//! 16+n    4     CRC-32/ISCSI (postcard crc flavour) over bytes 0..16+n, u32 LE
//! ```
//!
//! The blob must be exactly `20 + n` bytes long: nothing may follow the CRC, except the
//! signature trailer of a signed model ([`crate::signature`]), which decoding skips (it does
//! not verify it: that is the device's policy, [`crate::signature::verify`]).
//!
//! Version history: 1 had no memory terms (no memory field in the header, no memory spec or
//! Γ in the payload); version 2 adds them. A version-1 blob is refused with
//! [`Error::UnsupportedVersion`] naming both versions: retrain, or re-export with this
//! trainer.
//!
//! Decoding checks magic, version, CRC, dims and every parameter, and returns a typed
//! [`Error`]; it never panics and never allocates, whatever the bytes.

use crc::{Crc, CRC_32_ISCSI};

use crate::error::Error;
use crate::layout::{
    N_AMBIENT_TAUS, N_ENVELOPE, N_GRATING_TAUS, N_INPUTS, N_MEMORY, N_OUTPUTS, N_PLAYS, N_POLY, N_STAGE1, VAR_RANK,
    Z_DIMS,
};
use crate::model::ModelParams;

/// File magic.
pub const MAGIC: [u8; 4] = *b"FBGM";
/// Format version this build writes and reads.
pub const FORMAT_VERSION: u16 = 2;
/// Header length in bytes (magic, version, five dims).
pub const HEADER_LEN: usize = 16;
/// CRC trailer length in bytes.
pub const CRC_LEN: usize = 4;

/// CRC-32/ISCSI engine (also the link protocol's frame CRC: one table in the image).
pub(crate) static CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

/// The fixed-size header of a blob.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Format version.
    pub version: u16,
    /// Raw inputs per sample.
    pub inputs: u16,
    /// Outputs.
    pub outputs: u16,
    /// Polynomial terms.
    pub poly_terms: u16,
    /// Memory-term slots.
    pub memory_terms: u16,
    /// RBF centres.
    pub centres: u16,
}

impl Header {
    /// Parse and check the header of `bytes` (magic, version, the three fixed dims) without
    /// touching the payload or the CRC. Input that does not start like `FBGM` is
    /// [`Error::BadMagic`] even when it is shorter than a header.
    pub fn parse(bytes: &[u8]) -> Result<Header, Error> {
        let header = Header::read(bytes)?;
        header.check_version()?;
        header.check_dims()?;
        Ok(header)
    }

    /// Magic and the five fields, unchecked.
    fn read(bytes: &[u8]) -> Result<Header, Error> {
        if bytes.iter().zip(MAGIC.iter()).any(|(b, m)| b != m) {
            return Err(Error::BadMagic);
        }
        let head = bytes.get(..HEADER_LEN).ok_or(Error::Truncated { part: "header" })?;
        let mut w = [0u16; 6];
        for (o, ch) in w.iter_mut().zip(head.get(MAGIC.len()..).unwrap_or(&[]).chunks_exact(2)) {
            let mut b = [0u8; 2];
            b.copy_from_slice(ch);
            *o = u16::from_le_bytes(b);
        }
        let [version, inputs, outputs, poly_terms, memory_terms, centres] = w;
        Ok(Header { version, inputs, outputs, poly_terms, memory_terms, centres })
    }

    /// The version decides how the rest is read, so it is checked before anything else.
    fn check_version(&self) -> Result<(), Error> {
        if self.version == FORMAT_VERSION {
            Ok(())
        } else {
            Err(Error::UnsupportedVersion { found: self.version, supported: FORMAT_VERSION })
        }
    }

    fn check_dims(&self) -> Result<(), Error> {
        let check = |field, found: u16, expected: usize| {
            if usize::from(found) == expected {
                Ok(())
            } else {
                Err(Error::WrongDims { field, found, expected: saturate_u16(expected) })
            }
        };
        check("inputs", self.inputs, N_INPUTS)?;
        check("outputs", self.outputs, N_OUTPUTS)?;
        check("poly_terms", self.poly_terms, N_POLY)?;
        check("memory_terms", self.memory_terms, N_MEMORY)
    }

    fn check_capacity<const K: usize>(&self) -> Result<(), Error> {
        if usize::from(self.centres) > K {
            Err(Error::WrongDims { field: "centres", found: self.centres, expected: saturate_u16(K) })
        } else {
            Ok(())
        }
    }

    fn to_bytes(self) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let (magic, rest) = out.split_at_mut(MAGIC.len());
        magic.copy_from_slice(&MAGIC);
        let w = [self.version, self.inputs, self.outputs, self.poly_terms, self.memory_terms, self.centres];
        for (ch, v) in rest.chunks_exact_mut(2).zip(w.iter()) {
            ch.copy_from_slice(&v.to_le_bytes());
        }
        out
    }
}

/// The CRC trailer `bytes` carries: its last four bytes, little-endian, which identify a
/// model (a device reports the active model by it). Unchecked; `None` when `bytes` is shorter
/// than a trailer.
///
/// ```
/// use fbg_shared::blob::{computed_crc, stored_crc};
/// let mut blob = [0u8; 20];
/// blob[16..].copy_from_slice(&0x1234_5678u32.to_le_bytes());
/// assert_eq!(stored_crc(&blob), Some(0x1234_5678));
/// assert_ne!(computed_crc(&blob), stored_crc(&blob)); // not a valid blob
/// assert_eq!(computed_crc(&blob[..19]), None); // shorter than a header and a trailer
/// assert_eq!(stored_crc(&blob[..3]), None);
/// ```
pub fn stored_crc(bytes: &[u8]) -> Option<u32> {
    let tail = bytes.get(bytes.len().checked_sub(CRC_LEN)?..)?;
    let mut t = [0u8; CRC_LEN];
    if tail.len() != t.len() {
        return None;
    }
    t.copy_from_slice(tail);
    Some(u32::from_le_bytes(t))
}

/// The CRC-32/ISCSI of everything in `bytes` but the trailer: what [`stored_crc`] is for an
/// intact blob. `None` when `bytes` is shorter than a header and a trailer.
pub fn computed_crc(bytes: &[u8]) -> Option<u32> {
    let at = bytes.len().checked_sub(CRC_LEN).filter(|&at| at >= HEADER_LEN)?;
    bytes.get(..at).map(|body| CRC32.checksum(body))
}

fn saturate_u16(v: usize) -> u16 {
    u16::try_from(v).unwrap_or(u16::MAX)
}

/// Encode `params` into `buf`; returns the blob length. Invalid params are refused, so a
/// blob that encodes always decodes. A buffer of [`max_len`]`(K)` bytes always suffices.
pub fn encode<const K: usize>(params: &ModelParams<f32, K>, buf: &mut [u8]) -> Result<usize, Error> {
    params.validate()?;
    let centres = u16::try_from(params.centres.len())
        .map_err(|_| Error::TooManyCentres { found: params.centres.len(), capacity: u16::MAX as usize })?;
    let header = Header {
        version: FORMAT_VERSION,
        inputs: N_INPUTS as u16,
        outputs: N_OUTPUTS as u16,
        poly_terms: N_POLY as u16,
        memory_terms: N_MEMORY as u16,
        centres,
    }
    .to_bytes();
    if buf.len() < HEADER_LEN + CRC_LEN {
        return Err(Error::BufferTooSmall);
    }
    let (head, body) = buf.split_at_mut(HEADER_LEN);
    head.copy_from_slice(&header);
    let mut digest = CRC32.digest();
    digest.update(&header);
    // The only failure of a heapless, fixed-shape value is running out of buffer.
    let used = postcard::to_slice_crc32(params, body, digest).map_err(|_| Error::BufferTooSmall)?;
    Ok(HEADER_LEN + used.len())
}

/// Decode and fully validate a blob into a model of capacity `K`.
///
/// Order of checks:
/// 1. magic and format version (they decide how everything else is read);
/// 2. length and CRC over everything but the 4-byte trailer: a mismatch is reported as
///    [`Error::BadCrc`], as [`Error::Truncated`] when the input is shorter than any blob with
///    the header's centre count, or as [`Error::TrailingBytes`] when a complete blob with a
///    valid CRC is followed by extra bytes;
/// 3. the fixed dims, then the centre count against the capacity `K` (both now known to be
///    what the writer wrote, so a mismatch is a real one, not corruption);
/// 4. the payload, which must end exactly at the CRC trailer;
/// 5. the payload's centre count against the header's, then every parameter range.
pub fn decode<const K: usize>(bytes: &[u8]) -> Result<ModelParams<f32, K>, Error> {
    let mut out = ModelParams::default();
    decode_into(bytes, &mut out)?;
    Ok(out)
}

/// [`decode`] into caller-provided storage, without a model-sized temporary: the payload is
/// parsed field by field straight into `out` (the largest temporary is one centre), so a device
/// can decode an update into a static staging slot with a small stack. On error `out` holds a
/// partial model and must not be used; on success it is fully validated.
pub fn decode_into<const K: usize>(bytes: &[u8], out: &mut ModelParams<f32, K>) -> Result<(), Error> {
    // A signed model is a blob followed by its signature trailer: the blob is what is decoded.
    let bytes = crate::signature::strip(bytes);
    let header = Header::read(bytes)?;
    header.check_version()?;
    let (head, body) = bytes.split_at_checked(HEADER_LEN).ok_or(Error::Truncated { part: "header" })?;
    // Guarded subtraction: `body` may be shorter than the trailer.
    let payload_len = body.len().checked_sub(CRC_LEN).ok_or(Error::Truncated { part: "payload" })?;
    let (payload, trailer) = body.split_at_checked(payload_len).ok_or(Error::Truncated { part: "payload" })?;
    let crc_ok = crc_of(head, payload) == le_u32(trailer);
    if crc_ok {
        header.check_dims()?;
        header.check_capacity::<K>()?;
    }
    // One parse site: the signed payload when the CRC holds, otherwise everything after the
    // header, to tell a truncated or padded blob from a corrupted one. Parsing unauthenticated
    // bytes is no extra exposure: anyone can write a valid CRC, so the parser is hardened
    // against arbitrary payloads anyway.
    let parsed = parse_into(if crc_ok { payload } else { body }, out);
    if !crc_ok {
        return Err(diagnose_crc_mismatch(bytes.len(), header, head, body, parsed.as_ref().map(|r| *r)));
    }
    // With a valid CRC these bytes are what the writer wrote: a payload that does not decode
    // (including one that claims more bytes than it has) is malformed, not truncated.
    let rest = parsed.map_err(|_| Error::BadPayload)?;
    if !rest.is_empty() {
        return Err(Error::TrailingBytes { extra: rest.len() });
    }
    if out.centres.len() != usize::from(header.centres) {
        return Err(Error::WrongDims {
            field: "centres",
            found: header.centres,
            expected: saturate_u16(out.centres.len()),
        });
    }
    out.validate()
}

/// Parse a postcard payload of `ModelParams<f32, K>` into `out`, one field at a time in
/// declaration order (the encoding `encode` writes with serde), returning the unread rest.
/// The round-trip and golden tests pin this to the serde layout.
fn parse_into<'a, const K: usize>(bytes: &'a [u8], out: &mut ModelParams<f32, K>) -> Result<&'a [u8], postcard::Error> {
    fn take<'a, T: serde::Deserialize<'a>>(b: &mut &'a [u8]) -> Result<T, postcard::Error> {
        let (v, rest) = postcard::take_from_bytes::<T>(b)?;
        *b = rest;
        Ok(v)
    }
    let mut b = bytes;
    out.hyper = take(&mut b)?;
    out.stage1 = take(&mut b)?;
    out.guess_mean = take(&mut b)?;
    out.guess_std = take(&mut b)?;
    out.poly = take(&mut b)?;
    out.memory = take(&mut b)?;
    // Row by row: postcard writes an array as its elements, and a whole-Γ temporary would
    // double the parser's stack frame on the device.
    for row in out.gamma.iter_mut() {
        *row = take(&mut b)?;
    }
    out.z_mean = take(&mut b)?;
    out.z_std = take(&mut b)?;
    // heapless::Vec is a postcard sequence: a varint length, then the elements.
    let n: u32 = take(&mut b)?;
    out.centres.clear();
    for _ in 0..n {
        let c = take(&mut b)?;
        out.centres.push(c).map_err(|_| postcard::Error::DeserializeBadEncoding)?;
    }
    out.var_inv_g = take(&mut b)?;
    out.var_inv_g_tail = take(&mut b)?;
    out.resid_var = take(&mut b)?;
    out.resid_var_growth = take(&mut b)?;
    out.t_cal_end_s = take(&mut b)?;
    out.band_k = take(&mut b)?;
    out.envelope_lo = take(&mut b)?;
    out.envelope_hi = take(&mut b)?;
    out.fitted = take(&mut b)?;
    out.provenance = take(&mut b)?;
    Ok(b)
}

fn crc_of(head: &[u8], payload: &[u8]) -> u32 {
    let mut digest = CRC32.digest();
    digest.update(head);
    digest.update(payload);
    digest.finalize()
}

/// Little-endian u32 of the first four bytes (0 when shorter; callers pass four).
fn le_u32(b: &[u8]) -> u32 {
    let mut t = [0u8; CRC_LEN];
    for (o, &v) in t.iter_mut().zip(b.iter()) {
        *o = v;
    }
    u32::from_le_bytes(t)
}

/// Name a CRC mismatch over the whole input. `parsed` is the remainder after parsing a
/// payload from everything after the header (trailer included).
///
/// - The payload parses and the 4 bytes after it are its valid CRC, with more bytes after
///   them: a complete blob with something appended ([`Error::TrailingBytes`]).
/// - The input is shorter than the smallest blob with the header's centre count and the
///   payload or its CRC runs out: a cut blob ([`Error::Truncated`]). A payload byte flip can
///   also make the parse run out, so longer inputs are never called truncated.
/// - Anything else is corruption ([`Error::BadCrc`]).
fn diagnose_crc_mismatch(
    len: usize,
    header: Header,
    head: &[u8],
    body: &[u8],
    parsed: Result<&[u8], &postcard::Error>,
) -> Error {
    let short = len < min_len(usize::from(header.centres));
    match parsed {
        Ok(rest) => {
            let used = body.len().saturating_sub(rest.len());
            match (body.get(..used), rest.get(..CRC_LEN)) {
                (Some(payload), Some(trailer)) if rest.len() > CRC_LEN && crc_of(head, payload) == le_u32(trailer) => {
                    Error::TrailingBytes { extra: rest.len().saturating_sub(CRC_LEN) }
                }
                (_, None) if short => Error::Truncated { part: "crc" },
                _ => Error::BadCrc,
            }
        }
        Err(_) if short => Error::Truncated { part: "payload" },
        Err(_) => Error::BadCrc,
    }
}

/// Bytes of postcard's varint encoding of `v` (canonical, as the encoder writes it).
const fn varint_len(mut v: usize) -> usize {
    let mut n = 1;
    while v >= 0x80 {
        v >>= 7;
        n += 1;
    }
    n
}

/// Exact length of the shortest blob with `centres` centres: every f32 is 4 bytes in
/// postcard; the feature-set tag, seed, date, sample count and both string lengths take one
/// byte each with empty strings; the centre count is a varint. Saturates instead of
/// overflowing for absurd `centres`.
pub const fn min_len(centres: usize) -> usize {
    let hyper = 1 + 7 * 4;
    let fixed_f32 = N_OUTPUTS * N_STAGE1
        + 2 * N_OUTPUTS
        + N_OUTPUTS * N_POLY
        + (N_GRATING_TAUS + N_AMBIENT_TAUS + N_PLAYS + 2 + N_STAGE1)
        + N_OUTPUTS * N_MEMORY
        + 2 * Z_DIMS
        + VAR_RANK
        + 1
        + N_OUTPUTS
        + N_OUTPUTS
        + 1
        + N_OUTPUTS
        + 2 * N_ENVELOPE;
    let per_centre = 4 * (Z_DIMS + N_OUTPUTS + VAR_RANK);
    // `fitted`: one byte per output; provenance: five one-byte minimums.
    let provenance = N_OUTPUTS + 5;
    let fixed = HEADER_LEN + hyper + 4 * fixed_f32 + provenance + CRC_LEN;
    fixed.saturating_add(varint_len(centres)).saturating_add(per_centre.saturating_mul(centres))
}

/// Exact length of the longest blob [`encode`] writes for `centres` centres (for sizing
/// buffers): [`min_len`] plus a 10-byte seed varint (+9), 5-byte date and sample-count
/// varints (+4 each) and full provenance strings (24 + 16 bytes; their length varints stay
/// one byte).
pub const fn max_len(centres: usize) -> usize {
    min_len(centres).saturating_add(9 + 4 + 4 + 24 + 16)
}
