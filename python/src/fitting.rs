//! The fit of `fbg-trainer train`: Model-P and Model-H with cross-validated hyper-parameters on
//! a record's calibration rows.

use fbg_trainer::benchmark::{BenchFitOptions, DEFAULT_FIXED};
use fbg_trainer::data::Measurand;
use fbg_trainer::export::ModelFiles;
use fbg_trainer::fit::{train_source, FeatureChoice, Origin};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::columns;
use crate::error::{msg, to_py};
use crate::model::Model;

/// Fit both models on `columns` (the dataset's columns, see `columns::dataset`), the rows with
/// `cal` true calibrating (all when None), with the options of `train`: `features`
/// (`--features`), `max_centres`, `on_outlier` (`fail`/`skip`), `seed` (k-means and
/// cross-validation; `train` uses the default); `scenario` and `sim_seed` the provenance the
/// blob records (`train` takes them from the record's `.meta.json`); `fixed` one
/// configuration instead of the cross-validated choice, as `bench-fit --fixed` (keys
/// `feature_set`, `k`, `sigma_mult`, `alpha_rel`, `dead_band_pm`, `memory`). Returns Model-H, Model-P, the
/// `coefficients.json` text and a JSON summary (chosen hyper-parameters, CV RMSE, warnings).
/// `drift_spec` is the interrogator's stated stability [pm/√day], as `train --drift-spec`;
/// `drift_gains` its relative gain per grating, as `train --drift-gains`.
/// `precision` is only checked (predict's arithmetic, refused here rather than at the first
/// predict). Runs without the GIL; Ctrl-C stops it.
#[pyfunction]
#[pyo3(signature = (columns, cal=None, features="memory", max_centres=32, on_outlier="fail", seed=None, t0_unix_s=None, source="<frame>", scenario=None, sim_seed=0, fixed=None, targets=None, precision="f64", drift_spec=None, zero=None, drift_gains=None))]
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
    fixed: Option<&Bound<'_, PyDict>>,
    targets: Option<Vec<String>>,
    precision: &str,
    drift_spec: Option<f64>,
    zero: Option<crate::columns::Zero>,
    drift_gains: Option<Vec<f64>>,
) -> PyResult<(Model, Model, String, String)> {
    crate::stream::precision(precision)?;
    // The columns given as y must all be references: another name would be dropped silently
    // (or overwrite an input), and the model would have fewer outputs than asked for.
    for name in targets.iter().flatten() {
        name.parse::<Measurand>().map_err(|e| msg(format!("y: column {e}")))?;
    }
    let mut d = columns::dataset(columns, cal, t0_unix_s, source)?;
    // The record's zero travels into the model, as `train` takes it from the sidecar.
    crate::records::set_zero(&mut d, zero)?;
    let choice: FeatureChoice = features.parse().map_err(|e: String| msg(format!("features: {e}")))?;
    let mut opts = match fixed {
        None => choice.train_options(max_centres).map_err(|e| msg(format!("features/max_centres: {e}")))?,
        Some(f) => fixed_options(f)?,
    };
    opts = opts
        .with_progress(false)
        .with_on_outlier(on_outlier.parse().map_err(|e: String| msg(format!("on_outlier: {e}")))?)
        .with_skip_outliers_hint("fit with `on_outlier=\"skip\"`");
    if let Some(s) = seed {
        opts = opts.with_seed(s);
    }
    let opts = opts
        .to_builder()
        .drift_spec_pm_per_sqrt_day(drift_spec)
        .check()
        .map_err(|e| msg(format!("drift_spec: {e}")))?;
    let opts = opts
        .to_builder()
        .drift_gains(drift_gains)
        .check()
        .map_err(|e| msg(format!("drift_gains: {e}")))?
        .with_drift_gains_name("drift_gains");
    // The provenance `train` writes: the sidecar's scenario and seed, else the source's name.
    let origin = Origin { scenario: scenario.unwrap_or_else(|| source.to_string()), seed: sim_seed };
    let src = source.to_string();
    let cancel = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let opts = opts.with_cancel(cancel.clone());
    let tr = crate::interrupt::interruptible(py, Some(cancel), move || train_source(&d, &src, &opts, &origin))?
        .map_err(to_py)?;
    let files = ModelFiles::of(&tr, None).map_err(to_py)?;
    let s = &tr.selection;
    let summary = serde_json::json!({
        "chosen": tr.chosen(), "cv_rmse_p": s.cv_rmse_p, "cv_rmse_h": s.cv_rmse_h,
        "n_cal": s.n_cal, "grid_points": s.rows.len(), "warnings": tr.warnings,
        "outliers_skipped": tr.skipped.len(),
    });
    let h = Model::fitted(files.model_h).map_err(to_py)?;
    let p = Model::fitted(files.model_p).map_err(to_py)?;
    Ok((h, p, files.coefficients, summary.to_string()))
}

/// The options of `bench-fit --fixed` from a dict of its flags (the missing ones its defaults).
fn fixed_options(f: &Bound<'_, PyDict>) -> PyResult<fbg_trainer::fit::TrainOptions> {
    let get = |k: &str| f.get_item(k);
    let mut b = BenchFitOptions {
        data: std::path::PathBuf::new(),
        repeats: 1,
        fixed: true,
        features: FeatureChoice::Memory,
        memory: false,
        max_centres: 32,
        feature_set: DEFAULT_FIXED.feature_set.name().to_string(),
        k: DEFAULT_FIXED.k,
        sigma_mult: DEFAULT_FIXED.sigma_mult,
        alpha_rel: DEFAULT_FIXED.alpha_rel,
        dead_band_pm: DEFAULT_FIXED.dead_band_pm,
        threads: 0,
        holdout_errors: None,
        drift_spec: None,
        drift_gains: None,
    };
    for key in f.keys() {
        let k: String = key.extract().map_err(|_| msg(format!("fixed: the key {key} is not a string")))?;
        if !["feature_set", "k", "sigma_mult", "alpha_rel", "dead_band_pm", "memory"].contains(&k.as_str()) {
            return Err(msg(format!(
                "fixed: unknown key `{k}` (feature_set, k, sigma_mult, alpha_rel, dead_band_pm, memory)"
            )));
        }
    }
    if let Some(v) = get("feature_set")? {
        b.feature_set = v.extract().map_err(|e| msg(format!("fixed['feature_set']: {v}: {e}")))?;
    }
    if let Some(v) = get("k")? {
        b.k = v.extract().map_err(|e| msg(format!("fixed['k']: {v}: {e}")))?;
    }
    if let Some(v) = get("sigma_mult")? {
        b.sigma_mult = v.extract().map_err(|e| msg(format!("fixed['sigma_mult']: {v}: {e}")))?;
    }
    if let Some(v) = get("alpha_rel")? {
        b.alpha_rel = v.extract().map_err(|e| msg(format!("fixed['alpha_rel']: {v}: {e}")))?;
    }
    if let Some(v) = get("dead_band_pm")? {
        b.dead_band_pm = v.extract().map_err(|e| msg(format!("fixed['dead_band_pm']: {v}: {e}")))?;
    }
    if let Some(v) = get("memory")? {
        b.memory = v.extract().map_err(|e| msg(format!("fixed['memory']: {v}: {e}")))?;
    }
    b.options_named(&|flag| format!("fixed['{}']", flag.replace('-', "_"))).map(|(o, _)| o).map_err(to_py)
}
