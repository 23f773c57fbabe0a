//! What the report is made from ([`Inputs`]) and where it is read from ([`InputPaths`]).

use std::path::{Path, PathBuf};

use super::{load, DATA_CSV, LEGACY_METRICS_JSON, METRICS_JSON, MODEL_H, MODEL_P};
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::metrics::Metrics;
use crate::export;
use crate::fit::HostParams;
use crate::sim::meta::SimMeta;

/// Everything the report is made from.
pub struct Inputs {
    pub data: Dataset,
    pub meta: Option<SimMeta>,
    pub model_p: HostParams,
    pub model_h: HostParams,
    pub metrics: Metrics,
}

/// Where the report's inputs are read from.
#[derive(Clone, Debug, PartialEq)]
pub struct InputPaths {
    /// The dataset (its `.meta.json` sidecar, when present, is read beside it).
    pub data: PathBuf,
    pub model_h: PathBuf,
    pub model_p: PathBuf,
    pub metrics: PathBuf,
}

impl InputPaths {
    /// The fixed names in `dir`: data.csv, model.fbgm, model-p.fbgm, model.metrics.json (or an
    /// older report's metrics.json when that is the one present).
    pub fn in_dir(dir: &Path) -> Self {
        let metrics = dir.join(METRICS_JSON);
        let legacy = dir.join(LEGACY_METRICS_JSON);
        InputPaths {
            data: dir.join(DATA_CSV),
            model_h: dir.join(MODEL_H),
            model_p: dir.join(MODEL_P),
            metrics: if !metrics.exists() && legacy.is_file() { legacy } else { metrics },
        }
    }
}

impl Inputs {
    /// Read the inputs from `dir` (`data.meta.json` is optional).
    pub fn read_dir(dir: &Path) -> Result<Self, TrainerError> {
        Self::read(dir, &InputPaths::in_dir(dir))
    }

    /// Read the inputs from `paths` (names in `dir` are shown relative to it).
    pub fn read(dir: &Path, paths: &InputPaths) -> Result<Self, TrainerError> {
        // Every missing input at once, not one per run.
        let missing: Vec<String> = [&paths.data, &paths.model_h, &paths.model_p, &paths.metrics]
            .into_iter()
            .filter(|f| !f.exists())
            .map(|f| f.strip_prefix(dir).unwrap_or(f).display().to_string())
            .collect();
        if !missing.is_empty() {
            let msg = format!(
                "missing {} (`demo --out DIR` writes them all; or simulate, train and evaluate into DIR with these names; or name them with --data, --model, --model-p, --metrics)",
                missing.join(", ")
            );
            return Err(TrainerError::io(dir, std::io::Error::new(std::io::ErrorKind::NotFound, msg)));
        }
        let data = Dataset::read_csv(&paths.data)?;
        let model_h = export::read_blob(&paths.model_h)?;
        data.inputs_for(&model_h.dims, &paths.data.display().to_string(), "report")?;
        Ok(Inputs {
            data,
            meta: SimMeta::read_for(&paths.data)?,
            model_h,
            model_p: export::read_blob(&paths.model_p)?,
            metrics: load::read_metrics(&paths.metrics)?,
        })
    }
}
