//! The measurands: temperature, strain and pressure trajectories, and the reference
//! thermometer that watches the temperature.

use std::f64::consts::TAU;

use crate::rng::{Rng, Stream};
use crate::sim::scenario::{Ambient, Pressure, Strain, Temperature};

/// Stationary first-order autoregressive wiggle with standard deviation `sigma` and
/// correlation time `tau_s`, sampled every `dt_s` (exact discretisation of an
/// Ornstein–Uhlenbeck process).
pub fn ar1(n: usize, sigma: f64, tau_s: f64, dt_s: f64, rng: &mut Rng) -> Vec<f64> {
    let phi = libm::exp(-dt_s / tau_s);
    let innov = sigma * libm::sqrt(1.0 - phi * phi);
    let mut x = sigma * rng.normal();
    (0..n)
        .map(|_| {
            let out = x;
            x = phi * x + innov * rng.normal();
            out
        })
        .collect()
}

fn sine(amp: f64, period_s: f64, phase: f64, t: f64) -> f64 {
    amp * libm::sin(TAU * t / period_s + phase)
}

/// T(t) [°C]: mean + diurnal + weekly (+ seasonal) sines + AR(1).
pub fn temperature(cfg: &Temperature, t_s: &[f64], dt_s: f64, seed: u64) -> Vec<f64> {
    temperature_paced(cfg, 1.0, t_s, dt_s, seed)
}

/// [`temperature`] `pace` times faster: the diurnal, weekly and seasonal periods and the AR
/// correlation time divided by `pace` (the same random draws).
pub(crate) fn temperature_paced(cfg: &Temperature, pace: f64, t_s: &[f64], dt_s: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed, Stream::Temperature);
    let w = ar1(t_s.len(), cfg.ar_sigma_c, cfg.ar_tau_s / pace, dt_s, &mut rng);
    t_s.iter()
        .zip(w)
        .map(|(&t, w)| {
            cfg.mean_c
                + sine(cfg.diurnal_amp_c, 86_400.0 / pace, cfg.diurnal_phase_rad, t)
                + sine(cfg.weekly_amp_c, 7.0 * 86_400.0 / pace, cfg.weekly_phase_rad, t)
                + sine(cfg.seasonal_amp_c, cfg.seasonal_period_days * 86_400.0 / pace, cfg.seasonal_phase_rad, t)
                + w
        })
        .collect()
}

/// Quasi-static load levels, each held `hold_s` and reached by a linear ramp of `ramp_s`
/// from the previous level \[µε\].
pub fn load_steps(cfg: &Strain, t_s: &[f64], seed: u64) -> Vec<f64> {
    load_steps_on(cfg, t_s, seed, Stream::LoadLevels)
}

/// [`load_steps`] drawn from the random stream `stream` (a second strain location has its own).
pub(crate) fn load_steps_on(cfg: &Strain, t_s: &[f64], seed: u64, stream: Stream) -> Vec<f64> {
    let mut rng = Rng::new(seed, stream);
    let t_end = t_s.last().copied().unwrap_or(0.0);
    let n_levels = (t_end / cfg.hold_s).floor() as usize + 2;
    let levels: Vec<f64> = (0..n_levels).map(|_| rng.uniform_in(cfg.level_lo_ue, cfg.level_hi_ue)).collect();
    t_s.iter()
        .map(|&t| {
            let k = ((t / cfg.hold_s).floor() as usize).min(n_levels - 1);
            let into = t - k as f64 * cfg.hold_s;
            let cur = levels[k];
            if k == 0 || cfg.ramp_s <= 0.0 || into >= cfg.ramp_s {
                cur
            } else {
                let prev = levels[k - 1];
                prev + (cur - prev) * (into / cfg.ramp_s)
            }
        })
        .collect()
}

/// ε(t) \[µε\]: load steps + two periodic loads + AR(1).
pub fn strain(cfg: &Strain, t_s: &[f64], dt_s: f64, seed: u64) -> Vec<f64> {
    strain_on(cfg, t_s, dt_s, seed, (Stream::Strain, Stream::LoadLevels))
}

/// [`strain`] drawn from the random streams (AR(1), load levels) of one strain location.
pub(crate) fn strain_on(cfg: &Strain, t_s: &[f64], dt_s: f64, seed: u64, (ar, levels): (Stream, Stream)) -> Vec<f64> {
    let mut rng = Rng::new(seed, ar);
    let w = ar1(t_s.len(), cfg.ar_sigma_ue, cfg.ar_tau_s, dt_s, &mut rng);
    let steps = load_steps_on(cfg, t_s, seed, levels);
    t_s.iter()
        .zip(steps)
        .zip(w)
        .map(|((&t, s), w)| {
            s + sine(cfg.sine1_amp_ue, cfg.sine1_period_s, 0.0, t)
                + sine(cfg.sine2_amp_ue, cfg.sine2_period_s, 0.0, t)
                + w
        })
        .collect()
}

/// p(t) \[kPa\]: mean + two periodic components + AR(1).
pub fn pressure(cfg: &Pressure, t_s: &[f64], dt_s: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed, Stream::Pressure);
    let w = ar1(t_s.len(), cfg.ar_sigma_kpa, cfg.ar_tau_s, dt_s, &mut rng);
    t_s.iter()
        .zip(w)
        .map(|(&t, w)| {
            cfg.mean_kpa
                + sine(cfg.sine1_amp_kpa, cfg.sine1_period_s, 0.0, t)
                + sine(cfg.sine2_amp_kpa, cfg.sine2_period_s, 0.0, t)
                + w
        })
        .collect()
}

/// The ambient temperature the interrogator electronics sit in: a first-order lag of T plus the
/// offset (no reading noise) [°C].
pub(crate) fn ambient_true(cfg: &Ambient, temp_c: &[f64], dt_s: f64) -> Vec<f64> {
    let a = if cfg.lag_tau_s > 0.0 { 1.0 - libm::exp(-dt_s / cfg.lag_tau_s) } else { 1.0 };
    let mut y = temp_c.first().copied().unwrap_or(0.0);
    temp_c
        .iter()
        .map(|&t| {
            y += a * (t - y);
            y + cfg.offset_c
        })
        .collect()
}

/// The reference thermometer's reading T_amb [°C]: the true ambient plus white reading noise,
/// rounded to `resolution_c` when it is set.
pub(crate) fn ambient_reading(cfg: &Ambient, ambient: &[f64], seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed, Stream::Ambient);
    let r = cfg.resolution_c;
    ambient
        .iter()
        .map(|&a| {
            let x = a + cfg.noise_sigma_c * rng.normal();
            if r > 0.0 {
                libm::round(x / r) * r
            } else {
                x
            }
        })
        .collect()
}
