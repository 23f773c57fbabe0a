//! Helpers of the blob tests: CRCs, offsets into a paper blob, samples.

use crc::{Crc, CRC_32_ISCSI};
use fbg_shared::blob::{self, max_len, CRC_LEN, HEADER_LEN};
use fbg_shared::layout::Dims;
use fbg_shared::{ModelParams, Sample};
use fbg_testkit::Rng;

pub const ISCSI: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

/// Recompute the CRC trailer of a (modified) blob in place.
pub fn fix_crc(b: &mut [u8]) {
    let n = b.len() - CRC_LEN;
    let crc = ISCSI.checksum(&b[..n]);
    b[n..].copy_from_slice(&crc.to_le_bytes());
}

/// A blob with a valid CRC for *any* params (no validation).
pub fn encode_unchecked<const K: usize>(p: &ModelParams<f32, K>) -> Vec<u8> {
    let mut body = vec![0u8; max_len(K)];
    let n = blob::encode_unchecked(p, &mut body).expect("fits");
    body.truncate(n);
    body
}

pub fn min_len(centres: usize) -> usize {
    blob::min_len(&Dims::PAPER, centres)
}

/// Offset of the provenance in a blob (it is the last field of the payload).
pub fn provenance_offset<const K: usize>(blob: &[u8], p: &ModelParams<f32, K>) -> usize {
    let mut buf = [0u8; 128];
    let n = postcard::to_slice(&p.provenance, &mut buf).expect("fits").len();
    // The field context follows the provenance, then the trust spec: λ_ref (8 bytes) and its source (1) per
    // grating, tolerance and lead (4 each), the end of calibration (1 or 9), 3 f32 per output.
    let f = &p.field;
    let field = 9 * p.dims.gratings() + 8 + if f.cal_end_unix_s.is_some() { 9 } else { 1 } + 12 * p.dims.n_outputs();
    // Then the trust spec: a rate limit per envelope input, a quiet time per grating, 2 f32
    // per output, the largest RMS swing and speed and the smallest swing per envelope input.
    let (ne, m) = (p.dims.envelope_len(), p.dims.n_outputs());
    let trust = 4 * (ne + p.dims.gratings() + 2 * m + 3 * ne);
    blob.len() - CRC_LEN - field - trust - n
}

/// Offset of the first f32 of the memory spec: header, output kinds (3 × 2), hyper (1 + 7 × 4),
/// stage 1 (15), guess mean and std (3 + 3), B (30).
pub const MEMORY_OFFSET: usize = HEADER_LEN + 6 + 1 + 7 * 4 + 4 * 51;
/// Offset of Γ: after the memory spec's 6 + 4 + 3 + 2 + 5 f32.
pub const GAMMA_OFFSET: usize = MEMORY_OFFSET + 4 * 20;
/// Offset of the centre-count varint: after Γ (3 × 32 f32) and the z scalers (8 + 8 f32).
pub const CENTRES_OFFSET: usize = GAMMA_OFFSET + 4 * (3 * 32 + 16);

pub fn samples(seed: u64, n: usize) -> Vec<Sample<f32>> {
    let mut r = Rng(seed);
    let mut dl = [0.0f64; 3];
    (0..n)
        .map(|k| {
            for d in dl.iter_mut() {
                *d = (*d + r.uniform(-6.0, 6.0)).clamp(-50.0, 50.0);
            }
            Sample::new([dl[0] as f32, dl[1] as f32, dl[2] as f32], r.f32(0.0, 40.0), k as f32)
        })
        .collect()
}
