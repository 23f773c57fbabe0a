//! The `.fbgm` model blob (DESIGN §6).
//!
//! ```text
//! offset  size  field
//! 0       4     magic "FBGM"
//! 4       2     format version, u16 LE (this build writes FORMAT_VERSION)
//! 6       2     inputs       (5: Δλ1..3, T_amb, t)
//! 8       2     outputs      (3: T, ε, p)
//! 10      2     poly terms   (10)
//! 12      2     centres      (K of this model)
//! 14      n     postcard payload: ModelParams<f32, K>
//! 14+n    4     CRC-32/ISCSI (postcard crc flavour) over bytes 0..14+n, u32 LE
//! ```
//!
//! Decoding checks magic, version, dims, CRC and every parameter, and returns a typed
//! [`Error`]; it never panics and never allocates, whatever the bytes.

use crc::{Crc, CRC_32_ISCSI};

use crate::error::Error;
use crate::layout::{N_INPUTS, N_OUTPUTS, N_POLY};
use crate::model::ModelParams;

/// File magic.
pub const MAGIC: [u8; 4] = *b"FBGM";
/// Format version this build writes and reads.
pub const FORMAT_VERSION: u16 = 1;
/// Header length in bytes (magic, version, four dims).
pub const HEADER_LEN: usize = 14;
/// CRC trailer length in bytes.
pub const CRC_LEN: usize = 4;

static CRC32: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

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
    /// RBF centres.
    pub centres: u16,
}

impl Header {
    /// Parse and check the header of `bytes` without touching the payload.
    pub fn parse(bytes: &[u8]) -> Result<Header, Error> {
        let head = bytes.get(..HEADER_LEN).ok_or(Error::Truncated { part: "header" })?;
        let (magic, rest) = head.split_at(4);
        if magic != MAGIC {
            return Err(Error::BadMagic);
        }
        let mut w = [0u16; 5];
        for (o, ch) in w.iter_mut().zip(rest.chunks_exact(2)) {
            let mut b = [0u8; 2];
            b.copy_from_slice(ch);
            *o = u16::from_le_bytes(b);
        }
        let [version, inputs, outputs, poly_terms, centres] = w;
        if version != FORMAT_VERSION {
            return Err(Error::UnsupportedVersion { found: version });
        }
        let check = |field, found: u16, expected: usize| {
            if found as usize == expected {
                Ok(())
            } else {
                Err(Error::WrongDims { field, found, expected: expected as u16 })
            }
        };
        check("inputs", inputs, N_INPUTS)?;
        check("outputs", outputs, N_OUTPUTS)?;
        check("poly_terms", poly_terms, N_POLY)?;
        Ok(Header { version, inputs, outputs, poly_terms, centres })
    }

    fn to_bytes(self) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let (magic, rest) = out.split_at_mut(4);
        magic.copy_from_slice(&MAGIC);
        let w = [self.version, self.inputs, self.outputs, self.poly_terms, self.centres];
        for (ch, v) in rest.chunks_exact_mut(2).zip(w.iter()) {
            ch.copy_from_slice(&v.to_le_bytes());
        }
        out
    }
}

/// Encode `params` into `buf`; returns the blob length. Invalid params are refused, so a
/// blob that encodes always decodes.
pub fn encode<const K: usize>(params: &ModelParams<f32, K>, buf: &mut [u8]) -> Result<usize, Error> {
    params.validate()?;
    let centres = u16::try_from(params.centres.len())
        .map_err(|_| Error::TooManyCentres { found: params.centres.len(), capacity: u16::MAX as usize })?;
    let header = Header {
        version: FORMAT_VERSION,
        inputs: N_INPUTS as u16,
        outputs: N_OUTPUTS as u16,
        poly_terms: N_POLY as u16,
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
    let used = postcard::to_slice_crc32(params, body, digest).map_err(|_| Error::BufferTooSmall)?;
    Ok(HEADER_LEN + used.len())
}

/// Decode and fully validate a blob into a model of capacity `K`.
///
/// Order of checks: header (magic, version, dims), capacity, CRC, payload, leftover bytes,
/// centre count against the header, parameter ranges.
pub fn decode<const K: usize>(bytes: &[u8]) -> Result<ModelParams<f32, K>, Error> {
    let header = Header::parse(bytes)?;
    if header.centres as usize > K {
        return Err(Error::WrongDims { field: "centres", found: header.centres, expected: K as u16 });
    }
    let body = bytes.get(HEADER_LEN..).ok_or(Error::Truncated { part: "header" })?;
    if body.len() < CRC_LEN {
        return Err(Error::Truncated { part: "crc" });
    }
    // Check the CRC over everything but the trailer first, so that a corrupted blob is named as
    // such rather than as whatever its damaged payload happens to look like.
    let (signed, trailer) = bytes.split_at(bytes.len() - CRC_LEN);
    let mut t = [0u8; CRC_LEN];
    t.copy_from_slice(trailer);
    if CRC32.checksum(signed) != u32::from_le_bytes(t) {
        return Err(crc_or_truncation(bytes, header));
    }
    let mut digest = CRC32.digest();
    digest.update(bytes.get(..HEADER_LEN).ok_or(Error::Truncated { part: "header" })?);
    let (params, rest): (ModelParams<f32, K>, &[u8]) =
        postcard::take_from_bytes_crc32(body, digest).map_err(|e| match e {
            postcard::Error::DeserializeUnexpectedEnd => Error::Truncated { part: "payload" },
            postcard::Error::DeserializeBadCrc => Error::BadCrc,
            _ => Error::BadPayload,
        })?;
    if !rest.is_empty() {
        return Err(Error::TrailingBytes { extra: rest.len() });
    }
    if params.centres.len() != header.centres as usize {
        return Err(Error::WrongDims {
            field: "centres",
            found: header.centres,
            expected: params.centres.len() as u16,
        });
    }
    params.validate()?;
    Ok(params)
}

/// A CRC mismatch over the whole input is either corruption or a blob cut short; tell which
/// by checking whether a shorter prefix carries a valid trailer is not possible in general, so
/// report truncation only when the input is too short for the smallest model with this
/// header's centres.
fn crc_or_truncation(bytes: &[u8], header: Header) -> Error {
    if bytes.len() < min_len(header.centres as usize) {
        Error::Truncated { part: "payload" }
    } else {
        Error::BadCrc
    }
}

/// Smallest possible blob length for a model with `centres` centres: every f32 is 4 bytes in
/// postcard, varints and strings at least 1.
pub const fn min_len(centres: usize) -> usize {
    use crate::layout::{N_ENVELOPE, N_STAGE1, VAR_RANK, Z_DIMS};
    let hyper = 1 + 7 * 4;
    let fixed = N_OUTPUTS * N_STAGE1 + 2 * N_OUTPUTS + N_OUTPUTS * N_POLY + 2 * Z_DIMS + VAR_RANK + 1
        + N_OUTPUTS + 2 * N_ENVELOPE;
    let per_centre = Z_DIMS + N_OUTPUTS + VAR_RANK;
    let provenance = 1 + 1 + 1 + 1 + 1;
    HEADER_LEN + hyper + 4 * fixed + 1 + 4 * per_centre * centres + provenance + CRC_LEN
}

/// Upper bound of the blob length for `centres` centres (for sizing buffers).
pub const fn max_len(centres: usize) -> usize {
    // Varints of the seed (10), date and count (5 each), string lengths and bodies (24 + 16 + 2),
    // centre count (3) on top of the fixed floats.
    min_len(centres) + 10 + 5 + 5 + 24 + 16 + 2 + 3
}
