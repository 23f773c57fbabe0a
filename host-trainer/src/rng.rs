//! Seeded, portable random streams.
//!
//! ChaCha8 (value-stable across platforms and rand_chacha patch releases) with one stream per
//! physical effect, so switching an effect off never shifts the random numbers of another.
//! Normal deviates use Box–Muller with `libm`, whose results do not depend on the platform's C
//! library: the same seed gives the same bytes on any machine.

use rand_chacha::ChaCha8Rng;
use rand_core::{RngCore, SeedableRng};

/// Stream identifiers: one per source of randomness.
#[derive(Clone, Copy, Debug)]
#[repr(u64)]
pub enum Stream {
    Temperature = 1,
    Strain = 2,
    Pressure = 3,
    Ambient = 4,
    GaugeDispersion = 5,
    Drift = 6,
    PinkNoise = 7,
    WhiteNoise = 8,
    LoadLevels = 9,
    Kmeans = 10,
    /// The second strain location's AR(1) (`strain2_ue`).
    Strain2 = 11,
    /// The second strain location's load levels.
    LoadLevels2 = 12,
    /// The logger's time-stamping jitter (`clock.jitter_s`).
    ClockJitter = 13,
    /// The recording gaps: their starts and lengths (`clock.gaps_per_day`).
    ClockGaps = 14,
    /// The detector noise of simulated spectrum frames (`sim::spectrum`).
    SpectrumNoise = 15,
    /// The plateau record's levels and hold times (`[plateaus]`).
    Plateaus = 16,
}

/// A seeded random stream with uniform and normal deviates.
pub struct Rng {
    inner: ChaCha8Rng,
    spare_normal: Option<f64>,
}

impl Rng {
    /// The stream `stream` of seed `seed`.
    pub fn new(seed: u64, stream: Stream) -> Self {
        let mut inner = ChaCha8Rng::seed_from_u64(seed);
        inner.set_stream(stream as u64);
        Rng { inner, spare_normal: None }
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        (self.inner.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [lo, hi).
    pub fn uniform_in(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }

    /// Standard normal deviate (Box–Muller, both outputs used).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        // u1 in (0, 1] so that ln(u1) is finite.
        let u1 = 1.0 - self.uniform();
        let u2 = self.uniform();
        let r = libm::sqrt(-2.0 * libm::log(u1));
        let a = 2.0 * std::f64::consts::PI * u2;
        self.spare_normal = Some(r * libm::sin(a));
        r * libm::cos(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f64> = (0..5)
            .map({
                let mut r = Rng::new(7, Stream::Drift);
                move |_| r.normal()
            })
            .collect();
        let b: Vec<f64> = (0..5)
            .map({
                let mut r = Rng::new(7, Stream::Drift);
                move |_| r.normal()
            })
            .collect();
        let c: Vec<f64> = (0..5)
            .map({
                let mut r = Rng::new(7, Stream::PinkNoise);
                move |_| r.normal()
            })
            .collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn normal_moments() {
        let mut r = Rng::new(1, Stream::WhiteNoise);
        let n = 200_000;
        let xs: Vec<f64> = (0..n).map(|_| r.normal()).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.01, "var {var}");
    }
}
