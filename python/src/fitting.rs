//! The fit of `fbg-trainer train`: Model-P and Model-H with cross-validated hyper-parameters on
//! a record's calibration rows.

use fbg_trainer::export;
use fbg_trainer::fit::{self, FeatureChoice, Origin};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::columns;
use crate::error::{msg, to_py};
use crate::model::Model;

/// Fit both models on `columns` (the dataset's columns, see `columns::dataset`), the rows with
/// `cal` true calibrating (all when None), with the options of `train`: `features`
/// (`--features`), `max_centres`, `on_outlier` (`fail`/`skip`), `seed` (k-means and
/// cross-validation; `train` uses the default); `scenario` and `sim_seed` the provenance the
/// blob records (`train` takes them from the record's `.meta.json`). Returns Model-H, Model-P, the
/// `coefficients.json` text and a JSON summary (chosen hyper-parameters, CV RMSE, warnings).
/// Runs without the GIL.
#[pyfunction]
#[pyo3(signature = (columns, cal=None, features="memory", max_centres=32, on_outlier="fail", seed=None, t0_unix_s=None, source="<frame>", scenario=None, sim_seed=0))]
#[allow(clippy::too_many_arguments)]
pub fn fit(
    py: Python<'_>,
    columns: &Bound<'_, PyDict>,
    cal: Option<Vec<bool>>,
    features: &str,
    max_centres: usize,
    on_outlier: &str,
    seed: Option<u64>,
    t0_unix_s: Option<f64>,
    source: &str,
    scenario: Option<String>,
    sim_seed: u64,
) -> PyResult<(Model, Model, String, String)> {
    let d = columns::dataset(columns, cal, t0_unix_s, source)?;
    let choice: FeatureChoice = features.parse().map_err(|e: String| msg(format!("features: {e}")))?;
    let mut opts = choice.train_options(max_centres).map_err(|e| msg(format!("features/max_centres: {e}")))?;
    opts = opts.with_progress(false).with_on_outlier(on_outlier.parse().map_err(|e: String| msg(format!("on_outlier: {e}")))?);
    if let Some(s) = seed {
        opts = opts.with_seed(s);
    }
    // The provenance `train` writes: the sidecar's scenario and seed, else the source's name.
    let origin = Origin { scenario: scenario.unwrap_or_else(|| source.to_string()), seed: sim_seed };
    let tr = py.detach(|| fit::train_source(&d, source, &opts, &origin)).map_err(to_py)?;
    let coefficients = export::coefficients_text(
        &tr.model_p,
        &tr.model_h,
        &tr.core,
        Some(&tr.selection),
        Some(&tr.static_audit),
        None,
        &tr.warnings,
    )
    .map_err(to_py)?;
    let s = &tr.selection;
    let summary = serde_json::json!({
        "chosen": tr.chosen(), "cv_rmse_p": s.cv_rmse_p, "cv_rmse_h": s.cv_rmse_h,
        "n_cal": s.n_cal, "grid_points": s.rows.len(), "warnings": tr.warnings,
        "outliers_skipped": tr.skipped.len(),
    });
    let h = Model::fitted(tr.model_h).map_err(to_py)?;
    let p = Model::fitted(tr.model_p).map_err(to_py)?;
    Ok((h, p, coefficients, summary.to_string()))
}
