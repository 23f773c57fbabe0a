//! The interrogator's artefacts on a clean wavelength-shift series: hysteresis (one of the
//! models of `crate::sim::hysteresis`), scan nonlinearity, random-walk drift (Eq. 8),
//! electronics thermal drift, and 1/f + white noise. Each function returns the *contribution* it adds, so
//! the simulator can keep every effect separately.

use crate::rng::{Rng, Stream};
use crate::sim::scenario::{Drift, Electronics, Hysteresis, Noise, Scan};

/// Hysteresis contribution \[pm\] of the configured model (`hysteresis.model`; by default
/// play(Eq. 9(x)) − x).
pub fn hysteresis(x: &[f64], cfg: &Hysteresis) -> Vec<f64> {
    crate::sim::hysteresis::contribution(x, cfg)
}

/// Scan-nonlinearity contribution \[pm\] of one channel: ripple with a period in wavelength plus
/// a quadratic bow, evaluated at the grating's absolute wavelength `nominal_nm + shift`.
///
/// Evaluated at the physical wavelength (not the hysteresis-shifted one) so that every effect's
/// contribution is exactly additive; the difference is below 0.1 pm for the defaults.
pub(crate) fn scan_nonlinearity(shift_pm: &[f64], nominal_nm: f64, phase_rad: f64, cfg: &Scan) -> Vec<f64> {
    shift_pm
        .iter()
        .map(|&s| {
            let lambda_nm = nominal_nm + s * 1e-3;
            let ripple =
                cfg.ripple_amp_pm * libm::sin(std::f64::consts::TAU * lambda_nm / cfg.ripple_period_nm + phase_rad);
            let u = (lambda_nm - cfg.bow_centre_nm) / cfg.bow_half_span_nm;
            ripple + cfg.bow_pm * u * u
        })
        .collect()
}

/// Paper Eq. 8 random walk d_{t+1} = d_t + ω_t, ω ~ N(0, σ_d²), starting at 0 \[pm\]; common to
/// the interrogator (channel gains are applied by the caller).
pub fn random_walk(n: usize, sigma_pm: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed, Stream::Drift);
    let mut d = 0.0;
    (0..n)
        .map(|_| {
            let out = d;
            d += sigma_pm * rng.normal();
            out
        })
        .collect()
}

/// Drift contribution per grating \[pm\].
pub fn drift(n: usize, cfg: &Drift, seed: u64) -> Vec<Vec<f64>> {
    let d = random_walk(n, cfg.sigma_pm, seed);
    cfg.channel_gain.iter().map(|g| d.iter().map(|v| g * v).collect()).collect()
}

/// Electronics thermal drift \[pm\], the same on every channel, driven by the true ambient
/// temperature of the interrogator.
pub fn electronics(ambient_c: &[f64], cfg: &Electronics) -> Vec<f64> {
    ambient_c
        .iter()
        .map(|&a| {
            let d = a - cfg.ref_c;
            cfg.lin_pm_per_c * d + cfg.quad_pm_per_c2 * d * d
        })
        .collect()
}

/// Voss–McCartney 1/f noise with standard deviation `sigma`: `octaves` independent normal rows,
/// row j redrawn every 2^j samples, summed. The spectrum falls as 1/f between fs/2^octaves and
/// fs/2; each row has variance σ²/octaves, so the sum has variance σ² at every sample.
pub(crate) fn pink_noise(n: usize, sigma: f64, octaves: u32, rng: &mut Rng) -> Vec<f64> {
    let rows = octaves as usize;
    let row_sigma = sigma / (rows as f64).sqrt();
    let mut state: Vec<f64> = (0..rows).map(|_| row_sigma * rng.normal()).collect();
    let mut sum: f64 = state.iter().sum();
    (0..n)
        .map(|k| {
            if k > 0 {
                // Row j changes when bit j of the counter is the lowest set bit: row 0 every
                // other sample, row 1 every fourth, ...
                let j = (k as u64).trailing_zeros() as usize;
                if j < rows {
                    let new = row_sigma * rng.normal();
                    sum += new - state[j];
                    state[j] = new;
                }
            }
            sum
        })
        .collect()
}

/// Noise contribution per grating \[pm\]: pink + white, each grating its own draws (grating
/// after grating from the same two streams, so the first three gratings draw what the paper's
/// three always did).
pub fn noise(n: usize, gratings: usize, cfg: &Noise, seed: u64) -> Vec<Vec<f64>> {
    let mut pink = Rng::new(seed, Stream::PinkNoise);
    let mut white = Rng::new(seed, Stream::WhiteNoise);
    (0..gratings)
        .map(|_| {
            let p = pink_noise(n, cfg.pink_sigma_pm, cfg.pink_octaves, &mut pink);
            p.into_iter().map(|v| v + cfg.white_sigma_pm * white.normal()).collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pink_noise_variance_and_spectrum_slope() {
        let mut rng = Rng::new(11, Stream::PinkNoise);
        let n = 1 << 16;
        let x = pink_noise(n, 1.0, 16, &mut rng);
        let var = x.iter().map(|v| v * v).sum::<f64>() / n as f64;
        assert!((var - 1.0).abs() < 0.35, "var {var}");
        // Power in octave bands via block averages: for 1/f noise the variance of block means
        // halves much more slowly than for white noise (which halves per doubling).
        let block_var = |b: usize| {
            let means: Vec<f64> = x.chunks(b).map(|c| c.iter().sum::<f64>() / b as f64).collect();
            let m = means.iter().sum::<f64>() / means.len() as f64;
            means.iter().map(|v| (v - m).powi(2)).sum::<f64>() / means.len() as f64
        };
        let r = block_var(16) / block_var(256);
        // White noise would give 16; pink stays within a small factor.
        assert!(r < 4.0, "block-variance ratio {r} is white-like");
    }
}
