//! The frame of a `.fbgm` blob: a fixed header, the payload, and a CRC-32/ISCSI trailer over
//! both. What the blob codec ([`crate::blob`]) and the model-file container
//! ([`crate::container`]) both need to know, below either.

use crate::crc32c::crc32c;

/// Header length in bytes (magic, version, six dims).
pub const HEADER_LEN: usize = 18;
/// CRC trailer length in bytes.
pub const CRC_LEN: usize = 4;

/// The CRC trailer `bytes` carries: its last four bytes, little-endian, which identify a
/// model (a device reports the active model by it). Unchecked; `None` when `bytes` is shorter
/// than a trailer.
///
/// ```
/// use fbg_shared::blob::{computed_crc, stored_crc};
/// let mut blob = [0u8; 22];
/// blob[18..].copy_from_slice(&0x1234_5678u32.to_le_bytes());
/// assert_eq!(stored_crc(&blob), Some(0x1234_5678));
/// assert_ne!(computed_crc(&blob), stored_crc(&blob)); // not a valid blob
/// assert_eq!(computed_crc(&blob[..21]), None); // shorter than a header and a trailer
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
    bytes.get(..at).map(crc32c)
}
