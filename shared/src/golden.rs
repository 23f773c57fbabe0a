//! Golden vectors: the byte layout of the samples a device is tested with, and of the packs
//! (models with their samples) that the test images embed.
//!
//! A sample is [`SAMPLE_BYTES`] bytes, five little-endian f32: Δλ1, Δλ2, Δλ3 \[pm\], T_amb [°C],
//! t \[s\] (the trainer's `golden_inputs.bin` is a run of them). A pack is a run of records, each
//! a u32 LE blob length, the blob, a u32 LE sample count and the samples. The host side (files,
//! the expected answers) is `fbg-link`'s `golden` module; the device reads packs with
//! [`records`].
//!
//! ```
//! use fbg_shared::golden::{records, sample_bytes, samples};
//! use fbg_shared::Sample;
//!
//! let s = Sample::new([1.5, -2.0, 0.25], 21.0, 60.0);
//! let bytes = sample_bytes(&s);
//! assert_eq!(samples(&bytes).next(), Some(s));
//!
//! // A pack of one record: a 3-byte "blob" and one sample.
//! let mut pack = [0u8; 4 + 3 + 4 + fbg_shared::golden::SAMPLE_BYTES];
//! pack[0] = 3;
//! pack[7] = 1;
//! pack[11..].copy_from_slice(&bytes);
//! let rec = records(&pack).next().flatten().expect("one well-formed record");
//! assert_eq!((rec.blob.len(), rec.len()), (3, 1));
//! assert_eq!(rec.iter().next(), Some(s));
//! ```

use crate::compensator::Sample;
use crate::layout::MAX_GRATINGS;

/// Bytes of one sample: the grating count (u32), `MAX_GRATINGS` shifts, T_amb and t (f32),
/// little-endian.
pub const SAMPLE_BYTES: usize = 4 + 4 * (MAX_GRATINGS + 2);

/// The bytes of one sample.
pub fn sample_bytes(s: &Sample<f32>) -> [u8; SAMPLE_BYTES] {
    let mut out = [0u8; SAMPLE_BYTES];
    let (count, rest) = out.split_at_mut(4);
    count.copy_from_slice(&u32::from(s.gratings).to_le_bytes());
    let values = s.dl_pm.iter().copied().chain([s.t_amb_c, s.t_s]);
    for (o, v) in rest.chunks_exact_mut(4).zip(values) {
        o.copy_from_slice(&v.to_le_bytes());
    }
    out
}

/// The sample in `bytes` (a count beyond [`MAX_GRATINGS`] is read as `MAX_GRATINGS`).
pub fn sample_from_bytes(bytes: &[u8; SAMPLE_BYTES]) -> Sample<f32> {
    let mut f = [0f32; MAX_GRATINGS + 2];
    let (count, rest) = bytes.split_at(4);
    for (o, b) in f.iter_mut().zip(rest.chunks_exact(4)) {
        let mut w = [0u8; 4];
        w.copy_from_slice(b);
        *o = f32::from_le_bytes(w);
    }
    let mut c = [0u8; 4];
    c.copy_from_slice(count);
    let gratings = u32::from_le_bytes(c).min(MAX_GRATINGS as u32) as u8;
    let mut dl_pm = [0f32; MAX_GRATINGS];
    for (o, &v) in dl_pm.iter_mut().zip(f.iter()) {
        *o = v;
    }
    let [.., t_amb_c, t_s] = f;
    Sample { dl_pm, gratings, t_amb_c, t_s }
}

/// The samples of `bytes` in order (an incomplete last sample is not one).
pub fn samples(bytes: &[u8]) -> impl Iterator<Item = Sample<f32>> + '_ {
    bytes.chunks_exact(SAMPLE_BYTES).filter_map(|c| c.try_into().ok()).map(sample_from_bytes)
}

/// One record of a pack: a model blob and its samples.
#[derive(Clone, Copy, Debug)]
pub struct Record<'a> {
    /// The model blob.
    pub blob: &'a [u8],
    /// The samples, [`SAMPLE_BYTES`] each.
    pub samples: &'a [u8],
}

impl Record<'_> {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len() / SAMPLE_BYTES
    }

    /// Whether the record has no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The samples in order.
    pub fn iter(&self) -> impl Iterator<Item = Sample<f32>> + '_ {
        samples(self.samples)
    }
}

fn u32_at(bytes: &[u8]) -> Option<(usize, &[u8])> {
    let (head, rest) = bytes.split_at_checked(4)?;
    let mut w = [0u8; 4];
    w.copy_from_slice(head);
    Some((u32::from_le_bytes(w) as usize, rest))
}

/// The records of `pack`, in order; `None` (and nothing after it) for a malformed pack: a
/// length beyond its end.
pub fn records(pack: &[u8]) -> impl Iterator<Item = Option<Record<'_>>> {
    let mut rest = pack;
    core::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let rec = (|| {
            let (n, r) = u32_at(rest)?;
            let (blob, r) = r.split_at_checked(n)?;
            let (m, r) = u32_at(r)?;
            let (samples, r) = r.split_at_checked(m.checked_mul(SAMPLE_BYTES)?)?;
            rest = r;
            Some(Record { blob, samples })
        })();
        if rec.is_none() {
            rest = &[];
        }
        Some(rec)
    })
}

/// The record header that precedes a blob of `blob_len` bytes with `n_samples` samples:
/// the blob length (first four bytes) and the sample count (last four), to be written around
/// the blob (lengths beyond `u32::MAX` saturate, and the pack is then malformed).
pub fn record_lengths(blob_len: usize, n_samples: usize) -> ([u8; 4], [u8; 4]) {
    let le = |v: usize| u32::try_from(v).unwrap_or(u32::MAX).to_le_bytes();
    (le(blob_len), le(n_samples))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cut_pack_ends_with_none() {
        let s = Sample::new([1.0, 2.0, 3.0], 4.0, f32::NAN);
        let (n, m) = record_lengths(2, 2);
        let mut pack = [0u8; 4 + 2 + 4 + 2 * SAMPLE_BYTES];
        pack[..4].copy_from_slice(&n);
        pack[6..10].copy_from_slice(&m);
        pack[10..10 + SAMPLE_BYTES].copy_from_slice(&sample_bytes(&s));
        pack[10 + SAMPLE_BYTES..].copy_from_slice(&sample_bytes(&s));
        let rec = records(&pack).next().unwrap().unwrap();
        assert_eq!(rec.len(), 2);
        assert!(rec.iter().all(|x| x.t_s.is_nan() && x.dl_pm == s.dl_pm));
        let mut it = records(&pack[..pack.len() - 1]);
        assert!(it.next().unwrap().is_none());
        assert!(it.next().is_none());
        assert_eq!(samples(&pack[10..9 + SAMPLE_BYTES]).count(), 0);
    }
}
