//! Records on disk and simulated: `simulate`, `read_dataset`, and `compensate` run on files
//! exactly as the command line runs it.

use std::path::PathBuf;

use fbg_trainer::compensate::{self, FieldOptions};
use fbg_trainer::data::files::check_outputs;
use fbg_trainer::data::import::{self, ImportOptions, SplitChoice};
use fbg_trainer::data::{Dataset, GratingZero};
use fbg_trainer::sim::{self, scenario::Preset};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::columns;
use crate::error::{msg, to_py};

/// Columns (name -> array), the split of each row (`cal`/`holdout`), the absolute time of
/// `t_s = 0` (Unix s; None when unknown), the record's zero (per grating, λ_ref \[nm\] or None
/// and its source; empty when it states none).
type Columns<'py> = (Bound<'py, PyDict>, Vec<&'static str>, Option<f64>, columns::Zero);

/// The built-in scenario names (`simulate --preset`).
#[pyfunction]
pub fn presets() -> Vec<&'static str> {
    Preset::ALL.iter().map(|p| p.name()).collect()
}

/// Simulate the built-in scenario `preset` with `seed` (deterministic), as `fbg-trainer
/// simulate --preset P --seed S`; `days` shortens or lengthens the record, `dt_s` \[s\] changes
/// its sample interval. Runs without the GIL; Ctrl-C stops it.
#[pyfunction]
#[pyo3(signature = (preset="paper", seed=7, days=None, dt_s=None))]
pub fn simulate<'py>(
    py: Python<'py>,
    preset: &str,
    seed: u64,
    days: Option<f64>,
    dt_s: Option<f64>,
) -> PyResult<Columns<'py>> {
    let p: Preset = preset.parse().map_err(|e: String| msg(format!("preset: {e}")))?;
    let mut cfg = p.config();
    if let Some(d) = days {
        cfg.clock.days = d;
    }
    if let Some(dt) = dt_s {
        cfg.clock.dt_s = dt;
    }
    // The scenario's own ranges, as `simulate` checks a configuration (1 h to 3650 days, at
    // most 5e7 samples): without them a huge record aborts the interpreter on allocation.
    cfg.validate().map_err(|(key, message)| {
        let param = match key.as_str() {
            "clock.days" if message.contains("samples") => "days/dt_s",
            "clock.days" => "days",
            "clock.dt_s" => "dt_s",
            _ => "preset",
        };
        msg(format!("{param}: {message} (the scenario's {key})"))
    })?;
    let data = crate::interrupt::interruptible(py, None, move || sim::simulate(&cfg, seed).data)?;
    columns::to_dict(py, data)
}

/// Read a dataset CSV (DESIGN §3 columns, e.g. from `simulate` or `import`) as `train` and
/// `evaluate` read it; `field=True` reads a field record (no reference needed), as
/// `compensate` does. Errors name the file, line and column. Ctrl-C stops it.
#[pyfunction]
#[pyo3(signature = (path, field=false))]
pub fn read_dataset<'py>(py: Python<'py>, path: PathBuf, field: bool) -> PyResult<Columns<'py>> {
    let d = crate::interrupt::interruptible(py, None, move || {
        if field {
            Dataset::read_field_csv(&path)
        } else {
            Dataset::read_csv(&path)
        }
    })?
    .map_err(to_py)?;
    columns::to_dict(py, d)
}

/// `fbg-trainer compensate --model M --data D --out O [--f32] [--trust-units]`, the same
/// function: the summary as JSON text. Runs without the GIL; Ctrl-C stops it, and nothing is
/// written then.
#[pyfunction]
#[pyo3(signature = (model, data, out, precision="f64", trust_units=false, start_unix_s=None))]
pub fn compensate_file(
    py: Python<'_>,
    model: PathBuf,
    data: PathBuf,
    out: PathBuf,
    precision: &str,
    trust_units: bool,
    start_unix_s: Option<f64>,
) -> PyResult<String> {
    let precision = crate::stream::precision(precision)?;
    // The command line's check: `out` may not be the model, the record, or another spelling
    // or link of either.
    let side = fbg_trainer::data::record_meta::sidecar_path(&data);
    check_outputs(&[&out], &[&model, &data, &side]).map_err(|e| msg(format!("out: {e}")))?;
    let field = FieldOptions { start_unix_s, trust_units };
    let s = crate::interrupt::cancellable(py, move |cancel| {
        compensate::run_cancellable(&model, &data, &out, precision, field, false, cancel)
    })?
    .map_err(to_py)?;
    serde_json::to_string(&s).map_err(|e| msg(e.to_string()))
}

/// Write `columns` (with the split: `cal` true calibrating, all when None; `t0_unix_s` the
/// absolute time of `t_s = 0`; `zero` each grating's λ_ref \[nm\] or None and its source, as
/// [`record_zero`] gives them) as a dataset CSV and its sidecar, atomically, as `simulate`
/// writes them.
#[pyfunction]
#[pyo3(signature = (columns, path, cal=None, t0_unix_s=None, zero=None))]
pub fn write_dataset(
    columns: &Bound<'_, PyDict>,
    path: PathBuf,
    cal: Option<Vec<bool>>,
    t0_unix_s: Option<f64>,
    zero: Option<columns::Zero>,
) -> PyResult<()> {
    let mut d = columns::dataset(columns, cal, t0_unix_s, &path.display().to_string())?;
    set_zero(&mut d, zero)?;
    d.write_csv(&path).map_err(to_py)
}

/// Give `d` the zero a frame's `attrs['zero']` states (as [`record_zero`] gives it; None or
/// empty: unknown), checked grating by grating.
pub fn set_zero(d: &mut Dataset, zero: Option<columns::Zero>) -> PyResult<()> {
    if let Some(z) = zero.filter(|z| !z.is_empty()) {
        if z.len() != d.n_gratings() {
            return Err(msg(format!(
                "attrs['zero']: {} gratings where the record has {} (dl1_pm..)",
                z.len(),
                d.n_gratings()
            )));
        }
        d.meta.zero = z
            .iter()
            .enumerate()
            .map(|(g, (nm, source))| {
                GratingZero::parse(*nm, source).map_err(|m| msg(format!("attrs['zero'][{g}]: {m}")))
            })
            .collect::<PyResult<_>>()?;
    }
    Ok(())
}

/// The zero a dataset CSV states (its sidecar's): per grating, λ_ref \[nm\] (None when
/// unknown) and its source; empty when it states none.
#[pyfunction]
pub fn record_zero(py: Python<'_>, path: PathBuf) -> PyResult<columns::Zero> {
    let meta = py.detach(|| Dataset::read_csv_meta(&path)).map_err(to_py)?;
    Ok(columns::zero_of(&meta))
}

/// `fbg-trainer import --format F FILE [--map M] [--refs R] [--scale S] [--cal-fraction C]
/// [--on-error E]`, the same function without the output file: the imported record's columns
/// and its summary as JSON text. Errors name the file, line and column. Runs without the GIL;
/// Ctrl-C stops it.
#[pyfunction]
#[pyo3(signature = (format, path, map=None, refs=None, scale=None, cal_fraction=0.5, on_error="fail", max_skipped=0.05, start_unix_s=None))]
#[allow(clippy::too_many_arguments)]
pub fn import_file<'py>(
    py: Python<'py>,
    format: &str,
    path: PathBuf,
    map: Option<PathBuf>,
    refs: Option<PathBuf>,
    scale: Option<&str>,
    cal_fraction: f64,
    on_error: &str,
    max_skipped: f64,
    start_unix_s: Option<f64>,
) -> PyResult<(Columns<'py>, String)> {
    let opts = ImportOptions {
        format: format.parse().map_err(|e: String| msg(format!("format: {e}")))?,
        input: path,
        map,
        refs,
        split: SplitChoice::Fraction(cal_fraction),
        on_error: on_error.parse().map_err(|e: String| msg(format!("on_error: {e}")))?,
        max_skipped,
        zero_from: None,
        start_unix_s,
        scale: scale.map(|s| s.parse().map_err(|e: String| msg(format!("scale: {e}")))).transpose()?,
    };
    let (d, summary) = crate::interrupt::interruptible(py, None, move || import::import(&opts))?.map_err(to_py)?;
    let text = serde_json::to_string(&summary).map_err(|e| msg(e.to_string()))?;
    Ok((columns::to_dict(py, d)?, text))
}
