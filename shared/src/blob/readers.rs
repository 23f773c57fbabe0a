//! Reading a blob's payload: postcard's fields one at a time, and the readers over the parts
//! [`super::decode_split`] leaves in the blob's bytes (the centres; Γ for a device's parameter
//! slot), so that neither is ever materialised.

use crate::error::Error;
use crate::layout::Dims;
use crate::model::Centre;

/// The RBF centres of a blob decoded by [`super::decode_split`], read one at a time from the
/// blob's own bytes (each read parses one centre: no centre array is ever materialised).
#[derive(Clone, Debug)]
pub struct CentreReader<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) left: usize,
    pub(super) nz: usize,
    pub(super) m: usize,
    /// The first centre's [`Centre::check`] error, if any (checked while parsing).
    pub(super) checked: Result<(), Error>,
}

impl CentreReader<'_> {
    /// Centres not read yet.
    pub fn remaining(&self) -> usize {
        self.left
    }
}

impl Iterator for CentreReader<'_> {
    type Item = Centre<f32>;

    fn next(&mut self) -> Option<Centre<f32>> {
        if self.left == 0 {
            return None;
        }
        let mut c = Centre::<f32>::default();
        let rest = parse_centre(self.bytes, &mut c, self.nz, self.m).ok()?;
        self.bytes = rest;
        self.left -= 1;
        Some(c)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left, Some(self.left))
    }
}

impl ExactSizeIterator for CentreReader<'_> {}

/// Γ of a blob decoded by [`super::decode_split`] into a slot without Γ (`M` = 0), read from the
/// blob's own bytes: `m` rows of the model's memory terms, output-major.
#[derive(Clone, Copy, Debug)]
pub struct GammaReader<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) m: usize,
    pub(super) n: usize,
}

impl GammaReader<'_> {
    /// Γ's entry for output `o` and memory term `k`; 0 beyond the model's outputs and terms,
    /// and for a slot that holds Γ itself (`M` > 0).
    pub fn get(&self, o: usize, k: usize) -> f32 {
        if o >= self.m || k >= self.n {
            return 0.0;
        }
        let at = (o * self.n + k) * 4;
        match self.bytes.get(at..at + 4).and_then(|b| <[u8; 4]>::try_from(b).ok()) {
            Some(b) => f32::from_le_bytes(b),
            None => 0.0,
        }
    }

    /// Every entry as [`crate::ModelParams::validate`] checks Γ, for a model of `dims` with the
    /// operators `memory`.
    pub(super) fn check(&self, memory: &crate::memory::MemorySpec<f32>, dims: &Dims) -> Result<(), Error> {
        for o in 0..self.m {
            for k in 0..self.n {
                if !crate::model::gamma_ok(self.get(o, k), memory, dims, k) {
                    return Err(Error::BadParameter { field: "gamma" });
                }
            }
        }
        Ok(())
    }
}

/// One postcard field from the front of `b`, which moves past it.
pub(super) fn take<'a, T: serde::Deserialize<'a>>(b: &mut &'a [u8]) -> Result<T, postcard::Error> {
    let (v, rest) = postcard::take_from_bytes::<T>(b)?;
    *b = rest;
    Ok(v)
}

/// Postcard f32 fields from the front of `b` into every entry of `out`.
pub(super) fn floats(b: &mut &[u8], out: &mut [f32]) -> Result<(), postcard::Error> {
    for o in out.iter_mut() {
        *o = take(b)?;
    }
    Ok(())
}

/// One centre (μ over the `nz` RBF inputs, `m` weights, the variance components) from the
/// front of `bytes`; the rest after it. Out of line: one copy serves every reader.
#[inline(never)]
pub(super) fn parse_centre<'a>(
    bytes: &'a [u8],
    c: &mut Centre<f32>,
    nz: usize,
    m: usize,
) -> Result<&'a [u8], postcard::Error> {
    let mut b = bytes;
    floats(&mut b, crate::layout::head_mut(&mut c.mu, nz))?;
    floats(&mut b, crate::layout::head_mut(&mut c.w, m))?;
    floats(&mut b, &mut c.v)?;
    Ok(b)
}
