//! A window's samples with their maximum, floor, noise and the run of samples above the
//! threshold: what every estimator starts from.

use super::noise::NoiseEstimate;
use super::num::at;
use crate::real::Real;

/// Where a peak's samples start: a level above the floor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Threshold<R> {
    /// floor + `f`·(maximum − floor), 0 < f < 1 (the centroid's classic 50 %: `Fraction(0.5)`).
    Fraction(R),
    /// floor + `k`·σ (σ the window's noise, [`NoiseEstimate`]), capped below the maximum.
    Noise(R),
}

impl<R: Real> Default for Threshold<R> {
    fn default() -> Self {
        Threshold::Fraction(R::from_f64(0.5))
    }
}

/// One window's samples, analysed: the maximum, floor and noise, and the contiguous run of
/// samples above the threshold that holds the maximum. Indices are local to the window.
#[derive(Clone, Copy, Debug)]
pub struct Region<'a, R> {
    /// The window's samples.
    pub samples: &'a [R],
    /// Index of the maximum (the first one on a tie).
    pub imax: usize,
    /// The maximum.
    pub vmax: R,
    /// Floor and noise σ.
    pub noise: NoiseEstimate<R>,
    /// The threshold level (absolute).
    pub level: R,
    /// First index of the run above `level` around `imax`.
    pub lo: usize,
    /// Last index of that run.
    pub hi: usize,
}

impl<'a, R: Real> Region<'a, R> {
    /// Analyse `samples` (≥ 3, all finite: the caller checks) with `threshold`.
    pub fn new(samples: &'a [R], threshold: Threshold<R>) -> Self {
        let mut imax = 0;
        let mut vmax = at(samples, 0);
        for (i, &v) in samples.iter().enumerate() {
            if v > vmax {
                imax = i;
                vmax = v;
            }
        }
        let noise = NoiseEstimate::of(samples);
        let height = vmax - noise.floor;
        let level = match threshold {
            Threshold::Fraction(f) => f.mul_add(height, noise.floor),
            Threshold::Noise(k) => {
                let l = k.mul_add(noise.sigma, noise.floor);
                // Never above the maximum's 90 %: the run keeps at least the top.
                let cap = R::from_f64(0.9).mul_add(height, noise.floor);
                if l < cap {
                    l
                } else {
                    cap
                }
            }
        };
        let (lo, hi) = run(samples, imax, level);
        Region { samples, imax, vmax, noise, level, lo, hi }
    }

    /// Height of the maximum above the floor.
    pub fn height(&self) -> R {
        self.vmax - self.noise.floor
    }

    /// The sample at `i` above the floor (NaN past the end).
    pub fn above_floor(&self, i: usize) -> R {
        at(self.samples, i) - self.noise.floor
    }

    /// The last index.
    pub fn last(&self) -> usize {
        self.samples.len().saturating_sub(1)
    }
}

/// The contiguous run of samples `> level` that holds `i` (just `i` when it is not above).
pub fn run<R: Real>(samples: &[R], i: usize, level: R) -> (usize, usize) {
    let mut lo = i;
    while lo > 0 && at(samples, lo - 1) > level {
        lo -= 1;
    }
    let mut hi = i;
    while at(samples, hi + 1) > level {
        hi += 1;
    }
    (lo, hi)
}
