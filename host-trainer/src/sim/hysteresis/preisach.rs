//! A discrete Preisach model: a weighted sum of relays on a triangular grid of thresholds.
//!
//! `cells` thresholds t_0 < … < t_{K−1} sit at the cell centres of [lo_pm, hi_pm]; relay (i, j)
//! with i ≥ j switches up to +1 when the shift reaches α = t_i and down to −1 when it falls to
//! β = t_j. The relay sum is P = Σ μ_ij·R_ij with Σ μ = 1 (uniform weights, or Gaussian in the
//! relay half-width (α − β)/2), between −1 and +1. The contribution is w·(P − L(x)), where L
//! is the straight line from −1 at lo_pm to +1 at hi_pm (held beyond): the relays' mean rise
//! across the range is a gain the calibration of the interrogator takes out, what is left is
//! the loop. w makes the major loop `loop_width_pm` wide where it is widest. Only the sequence
//! of extrema of the input matters, so the model is exactly rate-independent.

use crate::sim::scenario::{Preisach, PreisachWeights};

/// The relays of one grating: thresholds, weights and states.
struct Relays {
    thresholds: Vec<f64>,
    /// μ_ij for i ≥ j, row by row (i = 0: (0,0); i = 1: (1,0), (1,1); …).
    weights: Vec<f64>,
    state: Vec<f64>,
    /// Output scale w \[pm\].
    scale: f64,
    lo: f64,
    hi: f64,
}

impl Relays {
    fn new(p: &Preisach) -> Relays {
        let k = p.cells.max(1) as usize;
        let cell = (p.hi_pm - p.lo_pm) / k as f64;
        let thresholds: Vec<f64> = (0..k).map(|i| p.lo_pm + (i as f64 + 0.5) * cell).collect();
        let mut weights = Vec::with_capacity(k * (k + 1) / 2);
        for i in 0..k {
            for j in 0..=i {
                weights.push(match p.weights {
                    PreisachWeights::Uniform => 1.0,
                    PreisachWeights::Gaussian => {
                        let half = 0.5 * (thresholds[i] - thresholds[j]) / p.sigma_pm;
                        libm::exp(-0.5 * half * half)
                    }
                });
            }
        }
        let total: f64 = weights.iter().sum();
        if total > 0.0 {
            weights.iter_mut().for_each(|w| *w /= total);
        }
        // Between thresholds m and m+1 the major loop's branches differ by twice the weight of
        // the relays that straddle the input (j ≤ m < i): up on the falling branch, down on
        // the rising one.
        let mut widest: f64 = 0.0;
        for m in 0..k.saturating_sub(1) {
            let mut straddle = 0.0;
            for i in m + 1..k {
                for j in 0..=m {
                    straddle += weights[i * (i + 1) / 2 + j];
                }
            }
            widest = widest.max(2.0 * straddle);
        }
        let scale = if widest > 0.0 { p.loop_width_pm / widest } else { 0.0 };
        let state = vec![-1.0; weights.len()];
        Relays { thresholds, weights, state, scale, lo: p.lo_pm, hi: p.hi_pm }
    }

    /// A demagnetised start at `x0`: relays whose centre (α + β)/2 lies below it are up.
    fn start_at(&mut self, x0: f64) {
        let t = &self.thresholds;
        let mut r = 0;
        for i in 0..t.len() {
            for j in 0..=i {
                self.state[r] = if 0.5 * (t[i] + t[j]) < x0 { 1.0 } else { -1.0 };
                r += 1;
            }
        }
    }

    /// Apply the input `x` and return the contribution \[pm\].
    fn step(&mut self, x: f64) -> f64 {
        let t = &self.thresholds;
        let mut r = 0;
        let mut sum = 0.0;
        for (i, &alpha) in t.iter().enumerate() {
            let up = x >= alpha;
            for &beta in &t[..=i] {
                if up {
                    self.state[r] = 1.0;
                } else if x <= beta {
                    self.state[r] = -1.0;
                }
                sum += self.weights[r] * self.state[r];
                r += 1;
            }
        }
        let line = (2.0 * (x - self.lo) / (self.hi - self.lo) - 1.0).clamp(-1.0, 1.0);
        self.scale * (sum - line)
    }
}

/// Hysteresis contribution \[pm\] on the shift series `x` \[pm\], from a demagnetised state at
/// the first sample.
pub fn contribution(x: &[f64], p: &Preisach) -> Vec<f64> {
    let mut relays = Relays::new(p);
    relays.start_at(x.first().copied().unwrap_or(0.0));
    x.iter().map(|&v| relays.step(v)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::hysteresis::paths::{branches, triangle};

    #[test]
    fn major_loop_has_the_configured_width_and_minor_loops_are_narrower() {
        for weights in [PreisachWeights::Uniform, PreisachWeights::Gaussian] {
            let p = Preisach { weights, ..Preisach::default() };
            // Beyond the threshold range: the major loop.
            let x = triangle(320.0, 3, 1.0);
            let y = contribution(&x, &p);
            let mut widest: f64 = 0.0;
            for at in [-200.0, -100.0, 0.0, 100.0, 200.0] {
                let (rise, fall) = branches(&x, &y, at);
                assert!(rise < fall, "{weights:?} at {at}: rising {rise}, falling {fall}");
                widest = widest.max(fall - rise);
            }
            assert!((widest - p.loop_width_pm).abs() < 0.05 * p.loop_width_pm, "{weights:?}: {widest}");
            // The loop is centred: no gain across the range, nothing beyond it.
            assert!(y.iter().all(|v| v.abs() <= p.loop_width_pm), "{weights:?}");
            let (rise, fall) = branches(&x, &y, 310.0);
            assert!(rise.abs() < 1e-12 && fall.abs() < 1e-12, "{weights:?}: {rise} {fall}");
            // A reversal of 60 pm: a real but narrower loop.
            let x = triangle(30.0, 3, 0.5);
            let y = contribution(&x, &p);
            let (rise, fall) = branches(&x, &y, 0.0);
            assert!(rise < fall && fall - rise < widest, "{weights:?}: rising {rise}, falling {fall}");
        }
    }

    #[test]
    fn rate_independent() {
        let p = Preisach { weights: PreisachWeights::Gaussian, ..Preisach::default() };
        let fast = triangle(120.0, 3, 4.0);
        let slow = triangle(120.0, 3, 1.0);
        let (yf, ys) = (contribution(&fast, &p), contribution(&slow, &p));
        for (k, &v) in yf.iter().enumerate() {
            assert_eq!(v, ys[4 * k], "sample {k}");
        }
    }
}
