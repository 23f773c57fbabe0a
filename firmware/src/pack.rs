//! The packs of models and samples the test images embed (`FBG_GOLDEN_PACK`,
//! `FBG_BENCH_PACK`; written by `xtask/src/fixtures.rs`, `pack_bytes`): per record a u32 LE
//! blob length, the blob, a u32 LE sample count and the samples as raw LE f32 × 5 (Δλ1..3 [pm],
//! T_amb [°C], t [s]).

use fbg_shared::Sample;

/// Bytes of one sample in a pack.
pub const SAMPLE_BYTES: usize = 20;

/// One record of a pack: a model blob and its samples (raw, see [`sample`]).
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
        self.samples.chunks_exact(SAMPLE_BYTES).map(sample)
    }
}

fn u32_at(bytes: &[u8]) -> Option<(usize, &[u8])> {
    let (head, rest) = bytes.split_at_checked(4)?;
    let mut w = [0u8; 4];
    w.copy_from_slice(head);
    Some((u32::from_le_bytes(w) as usize, rest))
}

/// The records of `pack`, in order; `None` for a malformed pack (a length beyond its end).
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

/// A sample from its [`SAMPLE_BYTES`] raw bytes (zeros for a short slice).
pub fn sample(rec: &[u8]) -> Sample<f32> {
    let mut f = [0f32; 5];
    for (o, b) in f.iter_mut().zip(rec.chunks_exact(4)) {
        let mut w = [0u8; 4];
        w.copy_from_slice(b);
        *o = f32::from_le_bytes(w);
    }
    let [d1, d2, d3, t_amb_c, t_s] = f;
    Sample { dl_pm: [d1, d2, d3], t_amb_c, t_s }
}
