//! The scenario simulator (DESIGN §3): measurands → gratings → interrogator artefacts →
//! measured wavelengths, with every effect's contribution kept, and the per-sample oracle. The
//! scenario it runs is [`scenario::ScenarioConfig`]; what it wrote a CSV from goes beside it as
//! the [`meta::SimMeta`] sidecar.

pub mod gauge_matrix;
pub mod interrogator;
pub mod meta;
pub mod scenario;
pub mod trajectories;

use crate::data::{Dataset, Split};
use crate::sim::scenario::ScenarioConfig;
use crate::stats::rmse;
pub use gauge_matrix::GaugePhysics;

/// Names of the artefacts, in [`Effects`] order.
pub const EFFECT_NAMES: [&str; 5] = ["hysteresis", "scan", "drift", "electronics", "noise"];

/// Per-channel, per-sample contribution of each effect to the measured shift \[pm\].
#[derive(Clone, Debug, Default)]
pub struct Effects {
    /// True physical shift (Eq. 2-3 with cross-terms).
    pub physics: [Vec<f64>; 3],
    pub hysteresis: [Vec<f64>; 3],
    pub scan: [Vec<f64>; 3],
    pub drift: [Vec<f64>; 3],
    pub electronics: [Vec<f64>; 3],
    pub noise: [Vec<f64>; 3],
}

impl Effects {
    /// Contribution of artefact `name` (one of [`EFFECT_NAMES`]).
    pub fn by_name(&self, name: &str) -> Option<&[Vec<f64>; 3]> {
        match name {
            "hysteresis" => Some(&self.hysteresis),
            "scan" => Some(&self.scan),
            "drift" => Some(&self.drift),
            "electronics" => Some(&self.electronics),
            "noise" => Some(&self.noise),
            _ => None,
        }
    }
}

/// A simulated installation: the data a user would see plus everything only a simulator knows.
#[derive(Clone, Debug)]
pub struct Simulation {
    pub config: ScenarioConfig,
    pub seed: u64,
    pub data: Dataset,
    pub physics: GaugePhysics,
    pub effects: Effects,
    /// True ambient temperature of the interrogator (no reading noise) [°C].
    pub ambient_true_c: Vec<f64>,
}

/// Simulate `cfg` with `seed`. Deterministic: the same inputs give bit-identical output.
pub fn simulate(cfg: &ScenarioConfig, seed: u64) -> Simulation {
    let n = cfg.n_samples();
    let n_cal = cfg.n_cal();
    let dt = cfg.clock.dt_s;
    let t_s: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();

    let temp_c = trajectories::temperature(&cfg.temperature, &t_s, dt, seed);
    let strain_ue = trajectories::strain(&cfg.strain, &t_s, dt, seed);
    let p_kpa = trajectories::pressure(&cfg.pressure, &t_s, dt, seed);
    let ambient_true_c = trajectories::ambient_true(&cfg.ambient, &temp_c, dt);
    let t_amb_c = trajectories::ambient_reading(&cfg.ambient, &ambient_true_c, seed);

    let physics = GaugePhysics::dispersed(&cfg.gratings, seed);
    let mut phys: [Vec<f64>; 3] = Default::default();
    for i in 0..n {
        let dl = physics.forward([temp_c[i], strain_ue[i], p_kpa[i]]);
        for g in 0..3 {
            phys[g].push(dl[g]);
        }
    }

    let zeros = || [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
    let hysteresis = if cfg.hysteresis.enabled {
        std::array::from_fn(|g| interrogator::hysteresis(&phys[g], &cfg.hysteresis))
    } else {
        zeros()
    };
    let scan = if cfg.scan.enabled {
        std::array::from_fn(|g| {
            interrogator::scan_nonlinearity(
                &phys[g],
                cfg.gratings.nominal_nm[g],
                cfg.scan.ripple_phase_rad[g],
                &cfg.scan,
            )
        })
    } else {
        zeros()
    };
    let drift = if cfg.drift.enabled { interrogator::drift(n, &cfg.drift, seed) } else { zeros() };
    let electronics = if cfg.electronics.enabled {
        let e = interrogator::electronics(&ambient_true_c, &cfg.electronics);
        [e.clone(), e.clone(), e]
    } else {
        zeros()
    };
    let noise = if cfg.noise.enabled { interrogator::noise(n, &cfg.noise, seed) } else { zeros() };

    let dl_pm: [Vec<f64>; 3] = std::array::from_fn(|g| {
        (0..n)
            .map(|i| phys[g][i] + hysteresis[g][i] + scan[g][i] + drift[g][i] + electronics[g][i] + noise[g][i])
            .collect()
    });
    let split = (0..n).map(|i| if i < n_cal { Split::Cal } else { Split::Holdout }).collect();

    Simulation {
        config: cfg.clone(),
        seed,
        data: Dataset { t_s, temp_c, strain_ue, p_kpa, t_amb_c, dl_pm, split, has_target: [true; 3] },
        physics,
        effects: Effects { physics: phys, hysteresis, scan, drift, electronics, noise },
        ambient_true_c,
    }
}

/// The best any compensator could do: exact inversion of the true physics from wavelengths
/// that carry only the noise.
#[derive(Clone, Debug, serde::Serialize)]
pub struct OracleFloor {
    /// Hold-out RMSE per output (T °C, ε µε, p kPa).
    pub rmse_holdout: [f64; 3],
    /// Calibration-part RMSE per output.
    pub rmse_cal: [f64; 3],
}

impl Simulation {
    /// Oracle estimates (T, ε, p) for every sample.
    pub fn oracle_estimates(&self) -> [Vec<f64>; 3] {
        let n = self.data.len();
        let mut out: [Vec<f64>; 3] = [Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n)];
        for i in 0..n {
            let dl = std::array::from_fn(|g| self.effects.physics[g][i] + self.effects.noise[g][i]);
            let m = self.physics.invert(dl);
            for c in 0..3 {
                out[c].push(m[c]);
            }
        }
        out
    }

    /// The per-sample oracle per output on the hold-out and calibration parts.
    pub fn oracle_floor(&self) -> OracleFloor {
        let est = self.oracle_estimates();
        let part = |want: Split| -> [f64; 3] {
            let idx: Vec<usize> = (0..self.data.len()).filter(|&i| self.data.split[i] == want).collect();
            std::array::from_fn(|c| {
                let truth = self.data.target(c);
                rmse(idx.iter().map(|&i| est[c][i] - truth[i]))
            })
        };
        OracleFloor { rmse_holdout: part(Split::Holdout), rmse_cal: part(Split::Cal) }
    }

    /// Machine-readable summary (what `simulate --json` prints).
    pub fn summary(&self) -> serde_json::Value {
        let d = &self.data;
        let std = |v: &[f64]| crate::stats::std_dev(v.iter().copied());
        let oracle = self.oracle_floor();
        let mut effects = serde_json::Map::new();
        for name in EFFECT_NAMES {
            let Some(e) = self.effects.by_name(name) else { continue };
            let rms: Vec<f64> = e.iter().map(|ch| crate::stats::rms(ch.iter().copied())).collect();
            effects.insert(name.to_string(), serde_json::json!(rms));
        }
        serde_json::json!({
            "scenario": self.config.name,
            "seed": self.seed,
            "samples": d.len(),
            "cal_samples": d.cal_indices().len(),
            "holdout_samples": d.holdout_indices().len(),
            "std": {"T_C": std(&d.temp_c), "strain_ue": std(&d.strain_ue), "p_kPa": std(&d.p_kpa)},
            "oracle_floor_rmse_holdout": {
                "T_C": oracle.rmse_holdout[0], "strain_ue": oracle.rmse_holdout[1], "p_kPa": oracle.rmse_holdout[2]
            },
            "effect_rms_pm": effects,
            "gauge_matrix_pm": self.physics.k,
        })
    }
}
