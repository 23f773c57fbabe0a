//! The grating package: what each grating itself makes of the structure it sits on (DESIGN §3).
//!
//! - **Thermal lag**: a grating in an adhesive bond, a tube or a housing takes the structure's
//!   temperature through a first-order lag (`gratings.thermal_lag_s`, one time constant per
//!   grating); its temperature column and its cross-terms use the lagged temperature.
//! - **Creep**: the adhesive of a bonded grating slowly gives up part of a sustained strain. The
//!   grating sees ε − c, the creep state c a first-order follower (time constant
//!   `ageing.creep_tau_s`) of `creep_fraction`·ε, for every strain measurand.
//! - **Ageing**: the Bragg wavelength itself drifts, monotonic and saturating:
//!   rate·τ·(1 − exp(−t/τ)) \[pm\], rate `ageing.drift_pm_per_day`, τ `ageing.ageing_tau_days`.
//!
//! Each is kept as its own contribution \[pm\] (thermal lag with the true strain, creep on top
//! of the lagged temperature, ageing added), so that they sum exactly to what the package
//! changes. Lag and creep states start settled at the first sample (an installation in place
//! before the record began).

use crate::data::Kind;
use crate::sim::gauge_matrix::GaugePhysics;
use crate::sim::scenario::ScenarioConfig;

/// Per-grating, per-sample contributions of the package \[pm\].
#[derive(Clone, Debug, Default)]
pub(crate) struct Package {
    pub thermal_lag: Vec<Vec<f64>>,
    pub creep: Vec<Vec<f64>>,
    pub ageing: Vec<Vec<f64>>,
}

/// First-order lag of `x` with time constant `tau_s`, sampled every `dt_s` (exact for an input
/// held over each interval), settled at the first sample; `tau_s` = 0 gives `x` back.
pub fn first_order_lag(x: &[f64], tau_s: f64, dt_s: f64) -> Vec<f64> {
    let a = if tau_s > 0.0 { 1.0 - libm::exp(-dt_s / tau_s) } else { 1.0 };
    let mut y = x.first().copied().unwrap_or(0.0);
    x.iter()
        .map(|&v| {
            y += a * (v - y);
            y
        })
        .collect()
}

/// Ageing shift \[pm\] at time `t_s` \[s\] of a grating ageing at `rate_pm_per_day` initially.
pub(crate) fn ageing_pm(rate_pm_per_day: f64, tau_days: f64, t_s: f64) -> f64 {
    rate_pm_per_day * tau_days * (1.0 - libm::exp(-t_s / 86_400.0 / tau_days))
}

/// Whether the scenario has any package effect.
pub fn active(cfg: &ScenarioConfig) -> bool {
    cfg.gratings.thermal_lag_s.iter().any(|&t| t > 0.0)
        || cfg.ageing.creep_fraction.iter().any(|&f| f > 0.0)
        || cfg.ageing.drift_pm_per_day.iter().any(|&r| r != 0.0)
}

/// The package contributions of every grating, or `None` when the scenario has none. `truth`
/// holds the measurands in `physics.measurands` order, `phys` the gratings' shifts from them
/// (what [`GaugePhysics::forward`] gave), `t_s` the grid times.
pub(crate) fn contributions(
    cfg: &ScenarioConfig,
    physics: &GaugePhysics,
    truth: &[Vec<f64>],
    phys: &[Vec<f64>],
    t_s: &[f64],
) -> Option<Package> {
    if !active(cfg) {
        return None;
    }
    let dt = cfg.clock.dt_s;
    let n = t_s.len();
    let ms = &physics.measurands;
    let t_col = ms.iter().position(|m| m.kind == Kind::Temperature && m.index == 1);
    let strain_cols: Vec<usize> = (0..ms.len()).filter(|&j| ms[j].kind == Kind::Strain).collect();
    let ag = &cfg.ageing;
    // The strain each grating would lose entirely (fraction 1), lagged; scaled per grating below.
    let creep_lagged: Vec<Vec<f64>> =
        strain_cols.iter().map(|&j| first_order_lag(&truth[j], ag.creep_tau_s, dt)).collect();
    let mut out = Package::default();
    let mut m = vec![0.0; ms.len()];
    for (g, phys_g) in phys.iter().enumerate().take(physics.n_gratings()) {
        let tau = cfg.gratings.thermal_lag_s.get(g).copied().unwrap_or(0.0);
        let lagged_t = match t_col {
            Some(c) if tau > 0.0 => Some(first_order_lag(&truth[c], tau, dt)),
            _ => None,
        };
        let creep = ag.creep_fraction.get(g).copied().unwrap_or(0.0);
        let rate = ag.drift_pm_per_day.get(g).copied().unwrap_or(0.0);
        let (mut th, mut cr, mut ageing) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        // Only ageing (or nothing) on this grating: no forward model to re-evaluate.
        let rows = if lagged_t.is_some() || creep > 0.0 { n } else { 0 };
        for i in 0..rows {
            for (x, tr) in m.iter_mut().zip(truth) {
                *x = tr[i];
            }
            let mut lagged = phys_g[i];
            if let (Some(c), Some(l)) = (t_col, &lagged_t) {
                m[c] = l[i];
                lagged = physics.forward_row(g, &m);
                th[i] = lagged - phys_g[i];
            }
            if creep > 0.0 {
                for (&j, lag) in strain_cols.iter().zip(&creep_lagged) {
                    m[j] -= creep * lag[i];
                }
                cr[i] = physics.forward_row(g, &m) - lagged;
            }
        }
        if rate != 0.0 {
            for (a, &t) in ageing.iter_mut().zip(t_s) {
                *a = ageing_pm(rate, ag.ageing_tau_days, t);
            }
        }
        out.thermal_lag.push(th);
        out.creep.push(cr);
        out.ageing.push(ageing);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lag_settles_to_a_step_with_its_time_constant() {
        let mut x = vec![0.0; 10];
        x.extend(vec![1.0; 2000]);
        let y = first_order_lag(&x, 600.0, 60.0);
        assert_eq!(y[9], 0.0);
        // One time constant (10 samples) after the step: 1 − 1/e.
        assert!((y[19] - (1.0 - (-1.0f64).exp())).abs() < 1e-12, "{}", y[19]);
        assert!((y[1999] - 1.0).abs() < 1e-12);
        assert_eq!(first_order_lag(&x, 0.0, 60.0), x);
    }

    #[test]
    fn ageing_starts_at_its_rate_and_saturates() {
        assert_eq!(ageing_pm(0.2, 60.0, 0.0), 0.0);
        let one_day = ageing_pm(0.2, 60.0, 86_400.0);
        assert!((one_day - 0.2).abs() < 0.002, "{one_day}");
        assert!((ageing_pm(0.2, 60.0, 1e9) - 12.0).abs() < 1e-6);
    }
}
