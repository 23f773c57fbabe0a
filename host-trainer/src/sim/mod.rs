//! The scenario simulator (DESIGN §3): measurands → gratings (and their packages) →
//! interrogator artefacts → measured wavelengths → the logger's clock, with every effect's
//! contribution kept, and the per-sample oracle. The scenario it runs is
//! [`scenario::ScenarioConfig`]; what it wrote a CSV from goes beside it as the
//! [`meta::SimMeta`] sidecar.

pub(crate) mod clock;
pub mod gauge_matrix;
pub(crate) mod hysteresis;
pub mod interrogator;
pub mod meta;
pub mod package;
pub mod plateaus;
pub mod scenario;
pub mod spectrum;
pub mod steps;
pub mod trajectories;

use crate::data::{Dataset, GratingZero, Kind, Measurand, RecordMeta, Reference, Split};
use crate::rng::Stream;
use crate::sim::scenario::ScenarioConfig;
use crate::stats::rmse;
pub use gauge_matrix::GaugePhysics;

/// The absolute time of a simulated record's `t_s = 0` (2026-01-05T00:00:00Z, Unix s): every
/// simulated record has a clock, so a model trained on one knows when its calibration ended.
pub(crate) const SIM_START_UNIX_S: f64 = 1_767_571_200.0;

/// Names of the interrogator's artefacts, in [`Effects`] order.
pub const EFFECT_NAMES: [&str; 5] = ["hysteresis", "scan", "drift", "electronics", "noise"];

/// Names of the grating package's effects ([`package`]), in [`Effects`] order: part of the
/// installation, not of the interrogator, and zero unless the scenario has them.
pub const PACKAGE_EFFECT_NAMES: [&str; 3] = ["thermal_lag", "creep", "ageing"];

/// Per-grating, per-row contribution of each effect to the measured shift \[pm\]; the
/// measured shift is their sum.
#[derive(Clone, Debug, Default)]
pub struct Effects {
    /// True physical shift (Eq. 2-3 with cross-terms) of the structure's measurands.
    pub physics: Vec<Vec<f64>>,
    /// What the grating's package changes of it ([`package`]).
    pub thermal_lag: Vec<Vec<f64>>,
    pub creep: Vec<Vec<f64>>,
    pub ageing: Vec<Vec<f64>>,
    pub hysteresis: Vec<Vec<f64>>,
    pub scan: Vec<Vec<f64>>,
    pub drift: Vec<Vec<f64>>,
    pub electronics: Vec<Vec<f64>>,
    pub noise: Vec<Vec<f64>>,
}

impl Effects {
    /// Contribution of effect `name` (one of [`EFFECT_NAMES`] or [`PACKAGE_EFFECT_NAMES`]).
    pub fn by_name(&self, name: &str) -> Option<&Vec<Vec<f64>>> {
        match name {
            "thermal_lag" => Some(&self.thermal_lag),
            "creep" => Some(&self.creep),
            "ageing" => Some(&self.ageing),
            "hysteresis" => Some(&self.hysteresis),
            "scan" => Some(&self.scan),
            "drift" => Some(&self.drift),
            "electronics" => Some(&self.electronics),
            "noise" => Some(&self.noise),
            _ => None,
        }
    }

    /// Keep only the rows `rows` (in that order) of every contribution.
    fn select(&mut self, rows: &[usize]) {
        for e in [
            &mut self.physics,
            &mut self.thermal_lag,
            &mut self.creep,
            &mut self.ageing,
            &mut self.hysteresis,
            &mut self.scan,
            &mut self.drift,
            &mut self.electronics,
            &mut self.noise,
        ] {
            for ch in e.iter_mut() {
                *ch = rows.iter().map(|&i| ch[i]).collect();
            }
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
    /// The simulation-grid sample (time k·dt_s) of each row: all of them in order, unless
    /// recording gaps dropped some.
    pub grid_rows: Vec<usize>,
}

/// The true trajectory of a simulated measurand, at its pace (`[pace]`).
fn trajectory(cfg: &ScenarioConfig, m: Measurand, temp_c: &[f64], t_s: &[f64], seed: u64) -> Vec<f64> {
    let dt = cfg.clock.dt_s;
    let f = cfg.pace_for(m);
    match (m.kind, m.index) {
        (Kind::Temperature, _) => temp_c.to_vec(),
        (Kind::Strain, 1) => trajectories::strain(&cfg.strain.paced(f), t_s, dt, seed),
        (Kind::Strain, _) => {
            trajectories::strain_on(&cfg.strain2().paced(f), t_s, dt, seed, (Stream::Strain2, Stream::LoadLevels2))
        }
        (Kind::Pressure, _) => trajectories::pressure(&cfg.pressure.paced(f), t_s, dt, seed),
    }
}

/// The structure's temperature and the measurands' truth (in `cfg.measurands` order) on the
/// simulation grid `t_s`: the native trajectories, or for a steps record their calibration
/// part followed by the steps part ([`steps`]).
fn truth_on_grid(cfg: &ScenarioConfig, t_s: &[f64], seed: u64) -> (Vec<f64>, Vec<Vec<f64>>) {
    let dt = cfg.clock.dt_s;
    let native_t: Vec<f64>;
    let grid = if cfg.steps.enabled {
        native_t = (0..cfg.n_native_samples()).map(|k| k as f64 * dt).collect();
        &native_t
    } else {
        t_s
    };
    // The temperature drives the ambient (and so the electronics) whether or not it is a
    // measurand.
    let mut temp_c = trajectories::temperature_paced(&cfg.temperature, cfg.pace_for(Measurand::T), grid, dt, seed);
    let mut truth: Vec<Vec<f64>> = cfg.measurands.iter().map(|&m| trajectory(cfg, m, &temp_c, grid, seed)).collect();
    if cfg.plateaus.enabled {
        // One schedule per series: the temperature first, then the other measurands in their
        // order (a temperature measurand is the temperature itself).
        let n_cal = cfg.n_cal().min(grid.len());
        let others: Vec<usize> = (0..truth.len()).filter(|&k| cfg.measurands[k] != Measurand::T).collect();
        let mut series = vec![std::mem::take(&mut temp_c)];
        series.extend(others.iter().map(|&k| std::mem::take(&mut truth[k])));
        plateaus::replace_holdout(&mut series, n_cal, &cfg.plateaus, dt, seed);
        temp_c = series.remove(0);
        for (k, s) in others.into_iter().zip(series) {
            truth[k] = s;
        }
        for (k, &m) in cfg.measurands.iter().enumerate() {
            if m == Measurand::T {
                truth[k] = temp_c.clone();
            }
        }
        return (temp_c, truth);
    }
    if !cfg.steps.enabled {
        return (temp_c, truth);
    }
    let n_cal = cfg.n_cal().min(grid.len());
    // Series 0 is the temperature, then the other measurands in their order.
    let t_pos = cfg.measurands.iter().position(|&m| m == Measurand::T);
    let mut series = vec![temp_c[..n_cal].to_vec()];
    for (k, tr) in truth.iter().enumerate() {
        if Some(k) != t_pos {
            series.push(tr[..n_cal].to_vec());
        }
    }
    let index_of = |k: usize| if Some(k) == t_pos { 0 } else { 1 + k - usize::from(t_pos.is_some_and(|p| p < k)) };
    let mut canonical: Vec<usize> = (0..cfg.measurands.len()).collect();
    canonical.sort_by_key(|&k| cfg.measurands[k]);
    let stepped: Vec<usize> = canonical.into_iter().map(index_of).collect();
    let ramp = (cfg.steps.ramp_s / dt).round() as usize;
    steps::extend(&mut series, &stepped, &cfg.steps, cfg.steps_hold_samples(), ramp);
    for (k, tr) in truth.iter_mut().enumerate() {
        *tr = series[index_of(k)].clone();
    }
    temp_c = series.swap_remove(0);
    (temp_c, truth)
}

/// Simulate `cfg` with `seed`. Deterministic: the same inputs give bit-identical output. Every
/// random effect draws from its own stream, and per-grating draws go grating after grating,
/// so the `paper` and `harsh` presets give the bytes they always gave; every effect added
/// since is off in them and draws from streams of its own.
///
/// ```
/// use fbg_trainer::sim::{self, scenario::Preset};
///
/// let mut cfg = Preset::StrainPair.config();
/// cfg.clock.days = 1.0;
/// let a = sim::simulate(&cfg, 7);
/// assert_eq!(a.data.len(), cfg.n_samples());
/// // The first `n_cal` samples calibrate, the rest are the hold-out.
/// assert_eq!(a.data.cal_indices().len(), cfg.n_cal());
/// // The same scenario and seed give the same record.
/// assert_eq!(sim::simulate(&cfg, 7).data.t_s, a.data.t_s);
/// ```
pub fn simulate(cfg: &ScenarioConfig, seed: u64) -> Simulation {
    let n = cfg.n_samples();
    let n_cal = cfg.n_cal();
    let n_g = cfg.n_gratings();
    let dt = cfg.clock.dt_s;
    let grid_t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();

    let (temp_c, truth) = truth_on_grid(cfg, &grid_t, seed);
    let ambient_true_c = trajectories::ambient_true(&cfg.ambient, &temp_c, dt);
    let t_amb_c = trajectories::ambient_reading(&cfg.ambient, &ambient_true_c, seed);

    let physics = GaugePhysics::dispersed(&cfg.gratings, &cfg.measurands, seed);
    let mut phys: Vec<Vec<f64>> = vec![Vec::with_capacity(n); n_g];
    let mut m = vec![0.0; truth.len()];
    for i in 0..n {
        for (x, tr) in m.iter_mut().zip(&truth) {
            *x = tr[i];
        }
        for (p, dl) in phys.iter_mut().zip(physics.forward(&m)) {
            p.push(dl);
        }
    }

    let zeros = || vec![vec![0.0; n]; n_g];
    // What each grating reflects: the physics through its package. Without package effects it
    // is the physics itself, untouched (the presets before them keep their bytes).
    let pkg = package::contributions(cfg, &physics, &truth, &phys, &grid_t);
    let seen: Vec<Vec<f64>> = match &pkg {
        Some(p) => (0..n_g)
            .map(|g| (0..n).map(|i| phys[g][i] + p.thermal_lag[g][i] + p.creep[g][i] + p.ageing[g][i]).collect())
            .collect(),
        None => phys.clone(),
    };
    let hysteresis = if cfg.hysteresis.enabled {
        seen.iter().map(|p| interrogator::hysteresis(p, &cfg.hysteresis)).collect()
    } else {
        zeros()
    };
    let scan = if cfg.scan.enabled {
        (0..n_g)
            .map(|g| {
                interrogator::scan_nonlinearity(
                    &seen[g],
                    cfg.gratings.nominal_nm[g],
                    cfg.scan.ripple_phase_rad[g],
                    &cfg.scan,
                )
            })
            .collect()
    } else {
        zeros()
    };
    let drift = if cfg.drift.enabled { interrogator::drift(n, &cfg.drift, seed) } else { zeros() };
    let electronics = if cfg.electronics.enabled {
        vec![interrogator::electronics(&ambient_true_c, &cfg.electronics); n_g]
    } else {
        zeros()
    };
    let noise = if cfg.noise.enabled { interrogator::noise(n, n_g, &cfg.noise, seed) } else { zeros() };

    let dl_pm: Vec<Vec<f64>> = (0..n_g)
        .map(|g| {
            (0..n)
                .map(|i| {
                    let dl = phys[g][i] + hysteresis[g][i] + scan[g][i] + drift[g][i] + electronics[g][i] + noise[g][i];
                    match &pkg {
                        Some(p) => dl + p.thermal_lag[g][i] + p.creep[g][i] + p.ageing[g][i],
                        None => dl,
                    }
                })
                .collect()
        })
        .collect();
    // By grid time: the calibration part is the first n_cal samples (jitter stays below dt/2).
    let split = (0..n).map(|i| if i < n_cal { Split::Cal } else { Split::Holdout }).collect();
    let pkg = pkg.unwrap_or_else(|| package::Package { thermal_lag: zeros(), creep: zeros(), ageing: zeros() });
    let mut data = Dataset {
        t_s: clock::timestamps(&cfg.clock, n, seed),
        refs: cfg.measurands.iter().zip(truth).map(|(&measurand, values)| Reference { measurand, values }).collect(),
        t_amb_c: cfg.ambient.thermometer.then_some(t_amb_c),
        dl_pm,
        split,
        meta: RecordMeta {
            zero: cfg
                .gratings
                .nominal_nm
                .iter()
                .map(|&nm| GratingZero { nm, source: fbg_shared::ZeroSource::Simulated })
                .collect(),
            t0_unix_s: Some(SIM_START_UNIX_S),
            comment_lines: 0,
            sidecar: None,
        },
    };
    data.sort_refs();
    let mut effects = Effects {
        physics: phys,
        thermal_lag: pkg.thermal_lag,
        creep: pkg.creep,
        ageing: pkg.ageing,
        hysteresis,
        scan,
        drift,
        electronics,
        noise,
    };
    let mut ambient_true_c = ambient_true_c;
    let grid_rows = match clock::kept_rows(&cfg.clock, n, seed) {
        Some(rows) => {
            data = data.select(&rows);
            effects.select(&rows);
            ambient_true_c = rows.iter().map(|&i| ambient_true_c[i]).collect();
            rows
        }
        None => (0..n).collect(),
    };

    Simulation { config: cfg.clone(), seed, data, physics, effects, ambient_true_c, grid_rows }
}

/// The best any compensator could do: exact inversion of the true physics from wavelengths
/// that carry only the noise.
#[derive(Clone, Debug, serde::Serialize)]
pub struct OracleFloor {
    /// The measurands, in the dataset's (canonical) order.
    pub measurands: Vec<Measurand>,
    /// Hold-out RMSE per measurand.
    pub rmse_holdout: Vec<f64>,
    /// Calibration-part RMSE per measurand.
    pub rmse_cal: Vec<f64>,
}

impl OracleFloor {
    /// The hold-out RMSE per output of a model with `outputs` (NaN for one not simulated).
    pub(crate) fn holdout_for(&self, outputs: &[Measurand]) -> Vec<f64> {
        values_for(&self.measurands, &self.rmse_holdout, outputs)
    }
}

/// Values per measurand (`v[k]` for `measurands[k]`) → per output of a model whose outputs
/// are `outputs`, NaN where absent.
pub(crate) fn values_for(measurands: &[Measurand], v: &[f64], outputs: &[Measurand]) -> Vec<f64> {
    outputs
        .iter()
        .map(|p| measurands.iter().position(|m| m == p).and_then(|k| v.get(k).copied()).unwrap_or(f64::NAN))
        .collect()
}

impl Simulation {
    /// Oracle estimates for every sample, one column per measurand in the dataset's order.
    pub(crate) fn oracle_estimates(&self) -> Vec<Vec<f64>> {
        let n = self.data.len();
        let n_g = self.physics.n_gratings();
        // The physics' columns follow the configuration's order, the dataset's are canonical.
        let order: Vec<usize> = self
            .data
            .measurands()
            .iter()
            .map(|m| self.physics.measurands.iter().position(|p| p == m).unwrap_or(0))
            .collect();
        let mut out: Vec<Vec<f64>> = vec![Vec::with_capacity(n); order.len()];
        let mut dl = vec![0.0; n_g];
        for i in 0..n {
            for (g, x) in dl.iter_mut().enumerate() {
                *x = self.effects.physics[g][i] + self.effects.noise[g][i];
            }
            let m = self.physics.invert(&dl);
            for (o, &k) in out.iter_mut().zip(&order) {
                o.push(m[k]);
            }
        }
        out
    }

    /// The per-sample oracle per measurand on the hold-out and calibration parts.
    pub fn oracle_floor(&self) -> OracleFloor {
        let est = self.oracle_estimates();
        let part = |want: Split| -> Vec<f64> {
            let idx: Vec<usize> = (0..self.data.len()).filter(|&i| self.data.split[i] == want).collect();
            self.data.refs.iter().zip(&est).map(|(r, e)| rmse(idx.iter().map(|&i| e[i] - r.values[i]))).collect()
        };
        OracleFloor {
            measurands: self.data.measurands(),
            rmse_holdout: part(Split::Holdout),
            rmse_cal: part(Split::Cal),
        }
    }

    /// Machine-readable summary (what `simulate --json` prints).
    pub fn summary(&self) -> serde_json::Value {
        let d = &self.data;
        let std = |v: &[f64]| crate::stats::std_dev(v.iter().copied());
        let oracle = self.oracle_floor();
        let mut effects = serde_json::Map::new();
        // The package's effects only when the scenario has them (the summaries of the
        // scenarios before them stay as they were).
        let package = if package::active(&self.config) { &PACKAGE_EFFECT_NAMES[..] } else { &[] };
        for name in EFFECT_NAMES.iter().chain(package) {
            let Some(e) = self.effects.by_name(name) else { continue };
            let rms: Vec<f64> = e.iter().map(|ch| crate::stats::rms(ch.iter().copied())).collect();
            effects.insert(name.to_string(), serde_json::json!(rms));
        }
        let mut spread = serde_json::Map::new();
        let mut floor = serde_json::Map::new();
        for (k, r) in d.refs.iter().enumerate() {
            spread.insert(r.measurand.column(), serde_json::json!(std(&r.values)));
            floor.insert(r.measurand.column(), serde_json::json!(oracle.rmse_holdout[k]));
        }
        let mut out = serde_json::json!({
            "scenario": self.config.name,
            "seed": self.seed,
            "samples": d.len(),
            "cal_samples": d.cal_indices().len(),
            "holdout_samples": d.holdout_indices().len(),
            "gratings": d.n_gratings(),
            "measurands": d.measurands(),
            "ambient_thermometer": d.t_amb_c.is_some(),
            "std": spread,
            "oracle_floor_rmse_holdout": floor,
            "effect_rms_pm": effects,
            "gauge_matrix_pm": self.physics.k,
        });
        if self.config.clock.gaps_per_day > 0.0 {
            out["grid_samples"] = serde_json::json!(self.config.n_samples());
            out["rows_dropped_in_gaps"] = serde_json::json!(self.config.n_samples() - d.len());
        }
        out
    }
}
