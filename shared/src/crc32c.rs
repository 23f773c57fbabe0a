//! CRC-32/ISCSI (Castagnoli), the check of the blob trailer and of every link frame: reflected
//! polynomial `0x82F6_3B78`, initial value and final XOR `0xFFFF_FFFF` (the `crc` crate's
//! `CRC_32_ISCSI`; check value of `"123456789"`: `0xE306_9283`).
//!
//! Four bits at a time with a 16-entry table (64 bytes): the device's flash budget has no room
//! for the 1 KiB byte-wise table, and the CRC runs over a few hundred bytes per sample (two
//! frames) and a few KiB per model update, where two table steps per byte instead of one do not
//! matter.

/// The reflected Castagnoli polynomial.
const POLY: u32 = 0x82F6_3B78;

/// CRC of each nibble value: four bit steps of the polynomial.
static NIBBLE: [u32; 16] = {
    let mut t = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 4 {
            c = if c & 1 != 0 { (c >> 1) ^ POLY } else { c >> 1 };
            k += 1;
        }
        // `i < 16`: inside the table (compile-time evaluation).
        #[allow(clippy::indexing_slicing)]
        {
            t[i] = c;
        }
        i += 1;
    }
    t
};

/// An incremental CRC-32/ISCSI: [`Crc32c::update`] with the bytes in order, then
/// [`Crc32c::finish`].
#[derive(Clone, Copy, Debug)]
pub struct Crc32c(u32);

impl Default for Crc32c {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32c {
    /// The CRC of no bytes yet.
    pub const fn new() -> Self {
        Crc32c(!0)
    }

    /// Feed `bytes`.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut c = self.0;
        for &b in bytes {
            c ^= u32::from(b);
            c = (c >> 4) ^ nibble(c);
            c = (c >> 4) ^ nibble(c);
        }
        self.0 = c;
    }

    /// The CRC of every byte fed.
    pub const fn finish(self) -> u32 {
        !self.0
    }
}

/// The table entry of the low nibble of `c`.
fn nibble(c: u32) -> u32 {
    // The index is below 16: never the fallback.
    NIBBLE.get((c & 0xF) as usize).copied().unwrap_or(0)
}

/// CRC-32/ISCSI of `bytes`.
pub fn crc32c(bytes: &[u8]) -> u32 {
    let mut c = Crc32c::new();
    c.update(bytes);
    c.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_crc_crate_and_the_check_value() {
        const ISCSI: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);
        assert_eq!(crc32c(b"123456789"), 0xE306_9283);
        assert_eq!(crc32c(b""), ISCSI.checksum(b""));
        let mut x = 0x1234_5678u32;
        let bytes: [u8; 1500] = core::array::from_fn(|_| {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x as u8
        });
        for n in [1, 2, 3, 7, 64, 255, 1500] {
            assert_eq!(crc32c(&bytes[..n]), ISCSI.checksum(&bytes[..n]), "{n} bytes");
            // In pieces, as the blob check feeds header and payload.
            let mut c = Crc32c::new();
            c.update(&bytes[..n / 3]);
            c.update(&bytes[n / 3..n]);
            assert_eq!(c.finish(), ISCSI.checksum(&bytes[..n]), "{n} bytes in two pieces");
        }
    }
}
