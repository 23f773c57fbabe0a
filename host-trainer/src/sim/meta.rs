//! The sidecar `<data>.meta.json` that `simulate` writes beside its CSV: the full scenario,
//! the seed and the summary (per-sample oracle). With it, `train` records provenance and
//! `evaluate` can show the per-sample oracle and re-run the drift sweep and error budget.

use std::path::{Path, PathBuf};

use crate::data::files::write_bytes_atomically;
use crate::error::TrainerError;
use crate::sim::scenario::ScenarioConfig;
use crate::sim::Simulation;

/// What a simulated CSV came from.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct SimMeta {
    pub scenario: ScenarioConfig,
    pub seed: u64,
    /// Oracle-floor hold-out RMSE per measurand, in the dataset's (canonical) order.
    pub oracle_floor_holdout: Vec<f64>,
    pub summary: serde_json::Value,
}

/// `data.csv` → `data.meta.json`.
pub fn meta_path(csv: &Path) -> PathBuf {
    csv.with_extension("meta.json")
}

impl SimMeta {
    /// The oracle-floor hold-out RMSE per output of a model with `outputs` (NaN where absent).
    pub(crate) fn oracle_floor_for(&self, outputs: &[crate::data::Measurand]) -> Vec<f64> {
        let mut m = self.scenario.measurands.clone();
        m.sort();
        crate::sim::values_for(&m, &self.oracle_floor_holdout, outputs)
    }

    pub fn of(sim: &Simulation) -> Self {
        SimMeta {
            scenario: sim.config.clone(),
            seed: sim.seed,
            oracle_floor_holdout: sim.oracle_floor().rmse_holdout,
            summary: sim.summary(),
        }
    }
    pub fn write(&self, csv: &Path) -> Result<(), TrainerError> {
        write_bytes_atomically(&meta_path(csv), self.to_json()?.as_bytes())
    }
    /// The sidecar's text (as [`write`](Self::write) writes it).
    pub fn to_json(&self) -> Result<String, TrainerError> {
        serde_json::to_string_pretty(self).map_err(|e| TrainerError::fit(e.to_string()))
    }
    /// The sidecar of `csv`, if there is one. A sidecar that exists but does not parse is an
    /// error (it names the file).
    pub fn read_for(csv: &Path) -> Result<Option<SimMeta>, TrainerError> {
        let p = meta_path(csv);
        if !p.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&p).map_err(|e| TrainerError::io(&p, e))?;
        let m: SimMeta = serde_json::from_str(&text).map_err(|e| TrainerError::Data {
            path: p.display().to_string(),
            line: e.line() as u64,
            column: e.column().to_string(),
            message: e.to_string(),
        })?;
        m.scenario.validate().map_err(|(key, message)| TrainerError::Config {
            origin: p.display().to_string(),
            key,
            message,
        })?;
        Ok(Some(m))
    }
}
