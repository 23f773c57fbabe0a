//! The noise floor and the noise σ of a window, from a fixed-size selection (no heap).

use super::num::{abs, at};
use crate::real::Real;

/// Samples the floor and the noise are taken from: at most this many, evenly strided over the
/// window (all of them in a shorter window), on the stack.
pub const NOISE_SAMPLES: usize = 32;

/// 1/(Φ⁻¹(3/4)·√6): the median of |x₋ − 2x₀ + x₊| over white noise of σ is 0.6745·√6·σ.
const MAD_D2_TO_SIGMA: f64 = 0.605_3;

/// √(π/2)/√6: the mean of |x₋ − 2x₀ + x₊| over white noise of σ is √(2/π)·√6·σ.
const MEAN_D2_TO_SIGMA: f64 = 0.511_663;

/// Second differences above this multiple of their median are left out of the mean (≈ 4 σ of
/// the difference even when the strided median comes out at its 5 % quantile, 0.65 of its
/// value: white noise loses under 10⁻⁴ of its mass there).
const CLIP: f64 = 6.0;

/// The level a window's peak stands on and the noise around it.
///
/// - `floor`: the lower quartile of the strided samples (the ⌊(m−1)/4⌋-th smallest of m ≤
///   [`NOISE_SAMPLES`]). It is the baseline as long as the peak covers less than about three
///   quarters of the window; on a flat baseline with white noise it lies within one σ below
///   the mean level (at the 25th percentile of the noise when the peak is narrow, nearer the
///   mean when it fills part of the window).
/// - `sigma`: the noise σ from the second differences d = x₋ − 2x₀ + x₊ (they remove a
///   baseline's level and slope): the median |d| at the strided pixels gives a robust scale,
///   then the mean of every |d| up to 6× that median, ×√(π/2)/√6 (exact for white Gaussian
///   noise). A peak's flanks that curve more than the noise are clipped out; where they curve
///   less they raise the estimate a little (the SNR is then under-stated).
///
/// Cost: m reads and a selection among m values, twice (Wirth's: ≈ 2–3·m compares each on
/// average, m ≤ 32), then one pass over the window (a second difference, a compare and an
/// add per sample).
///
/// ```
/// use fbg_shared::spectrum::NoiseEstimate;
/// let flat = [2.0f64; 40];
/// let n = NoiseEstimate::of(&flat);
/// assert_eq!((n.floor, n.sigma), (2.0, 0.0));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct NoiseEstimate<R> {
    /// The floor, in the spectrum's intensity unit.
    pub floor: R,
    /// The noise σ, in the spectrum's intensity unit.
    pub sigma: R,
}

impl<R: Real> NoiseEstimate<R> {
    /// The estimate of one window's samples (NaN for fewer than three samples).
    pub fn of(samples: &[R]) -> Self {
        let n = samples.len();
        if n < 3 {
            return NoiseEstimate { floor: R::NAN, sigma: R::NAN };
        }
        let mut level = [R::ZERO; NOISE_SAMPLES];
        let m = fill_strided(&mut level, n, |i| at(samples, i));
        let floor = select(&mut level, m, (m - 1) / 4);
        // Second differences at the interior pixels, strided the same way.
        let mut d2 = [R::ZERO; NOISE_SAMPLES];
        let md = fill_strided(&mut d2, n - 2, |i| {
            let (a, b, c) = (at(samples, i), at(samples, i + 1), at(samples, i + 2));
            abs(a - (b + b) + c)
        });
        let median = select(&mut d2, md, (md - 1) / 2);
        // The clipped mean of every second difference: 4× lower variance than the median of
        // the strided ones, and the clip drops the peak's flanks where they curve more than the
        // noise does.
        let clip = R::from_f64(CLIP) * median;
        let (mut sum, mut count) = (R::ZERO, R::ZERO);
        for t in samples.windows(3) {
            if let [a, b, c] = *t {
                let d = abs(a - (b + b) + c);
                if d <= clip {
                    sum += d;
                    count += R::ONE;
                }
            }
        }
        let sigma = if count > R::ZERO {
            sum / count * R::from_f64(MEAN_D2_TO_SIGMA)
        } else {
            median * R::from_f64(MAD_D2_TO_SIGMA)
        };
        NoiseEstimate { floor, sigma }
    }
}

/// Fill `buf` with `f(i)` at up to [`NOISE_SAMPLES`] indices evenly spread over `0..n`
/// (first and last included); returns how many (≥ 1 for n ≥ 1).
fn fill_strided<R: Real>(buf: &mut [R; NOISE_SAMPLES], n: usize, f: impl Fn(usize) -> R) -> usize {
    let m = n.min(NOISE_SAMPLES);
    let span = n.saturating_sub(1);
    let gaps = m.saturating_sub(1).max(1);
    for (k, slot) in buf.iter_mut().take(m).enumerate() {
        *slot = f(k * span / gaps);
    }
    m
}

/// The `k`-th smallest of `buf[..m]` (`k < m`), by Wirth's selection (Hoare's partition, no
/// recursion; ≈ 2–3·m compares on average), reordering `buf`. The values are finite (the
/// detector checks), so every compare is an order.
fn select<R: Real>(buf: &mut [R; NOISE_SAMPLES], m: usize, k: usize) -> R {
    let s = buf.get_mut(..m).unwrap_or_default();
    let get = |s: &[R], i: usize| s.get(i).copied().unwrap_or(R::NAN);
    let (mut lo, mut hi) = (0usize, m.saturating_sub(1));
    while lo < hi {
        let pivot = get(s, k);
        let (mut i, mut j) = (lo, hi);
        loop {
            while get(s, i) < pivot {
                i += 1;
            }
            while pivot < get(s, j) {
                j -= 1;
            }
            if i <= j {
                s.swap(i, j);
                i += 1;
                match j.checked_sub(1) {
                    Some(jj) => j = jj,
                    None => break,
                }
            }
            if i > j {
                break;
            }
        }
        if j < k {
            lo = i;
        }
        if k < i {
            hi = j;
        }
    }
    get(s, k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use fbg_testkit::Rng;

    #[test]
    fn select_is_the_kth_smallest() {
        let mut rng = Rng::new(1);
        for trial in 0..2000 {
            let m = 1 + trial % NOISE_SAMPLES;
            let mut buf = [0.0f64; NOISE_SAMPLES];
            for v in buf.iter_mut().take(m) {
                // Ties on purpose: values from a small set half of the time.
                *v = if trial % 2 == 0 { (rng.uniform(0.0, 4.0)).floor() } else { rng.normal() };
            }
            let mut sorted = buf[..m].to_vec();
            sorted.sort_by(f64::total_cmp);
            for (k, &want) in sorted.iter().enumerate() {
                let mut b = buf;
                assert_eq!(select(&mut b, m, k), want, "m = {m}, k = {k}, {:?}", &buf[..m]);
            }
        }
    }

    #[test]
    fn sigma_of_white_noise() {
        let mut rng = Rng::new(5);
        let mut v: std::vec::Vec<f64> = (0..400)
            .map(|_| {
                let s: std::vec::Vec<f64> = (0..250).map(|_| rng.normal()).collect();
                NoiseEstimate::of(&s).sigma
            })
            .collect();
        v.sort_by(f64::total_cmp);
        let (p5, p50, p95) = (v[20], v[200], v[380]);
        std::eprintln!("σ estimate of unit white noise: 5 % {p5:.3}, median {p50:.3}, 95 % {p95:.3}");
        assert!(p50 > 0.95 && p50 < 1.05 && p5 > 0.85 && p95 < 1.15, "{p5} {p50} {p95}");
    }
}
