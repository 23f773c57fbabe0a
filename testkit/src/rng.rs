//! SplitMix64: tiny, fast, deterministic on every machine.

/// Golden-ratio increment of SplitMix64 (also what [`Rng::new`] mixes into a seed).
const GAMMA: u64 = 0x9E37_79B9_7F4A_7C15;

/// SplitMix64 with its state in the open: `Rng(s)` starts from state `s`, [`Rng::new`] from a
/// seed mixed with the increment. Both are used by fixtures whose values are pinned, so
/// neither may change.
#[derive(Clone, Debug)]
pub struct Rng(pub u64);

impl Rng {
    /// A generator for `seed` (state `seed ^ 0x9E37_79B9_7F4A_7C15`).
    pub const fn new(seed: u64) -> Self {
        Rng(seed ^ GAMMA)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(GAMMA);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1), 53 random bits.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in [lo, hi).
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// [`Rng::uniform`] rounded to f32.
    pub fn f32(&mut self, lo: f64, hi: f64) -> f32 {
        self.uniform(lo, hi) as f32
    }

    /// Standard normal (Box-Muller, one of the pair).
    pub fn normal(&mut self) -> f64 {
        let u1 = self.unit().max(1e-300);
        let u2 = self.unit();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    /// One of `xs`, uniformly (`None` when empty).
    pub fn pick<T: Copy>(&mut self, xs: &[T]) -> Option<T> {
        if xs.is_empty() {
            return None;
        }
        let i = (self.next_u64() % xs.len() as u64) as usize;
        xs.get(i).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sequence_is_pinned() {
        // SplitMix64's reference output for state 0 (Vigna's splitmix64.c).
        let mut r = Rng(0);
        assert_eq!(r.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(Rng::new(5).0, 5 ^ GAMMA);
        let mut r = Rng(3);
        for _ in 0..1000 {
            let u = r.uniform(-2.0, 3.0);
            assert!((-2.0..3.0).contains(&u));
        }
        assert_eq!(Rng(1).pick::<u8>(&[]), None);
    }
}
