//! The audit report (DESIGN §5): from a directory holding `data.csv`
//! (+ `data.meta.json`), `model.fbgm`, `model-p.fbgm` and `metrics.json`, write into the same
//! directory the figures (PNG and SVG), the tables (Markdown, CSV, text), the
//! coefficient tables and `index.html`, a static page that shows all of it with the scenario,
//! the provenance and a summary generated from the numbers.
//!
//! The report recomputes the hold-out estimates from the models and the data (for the
//! figures) and checks them against `metrics.json`; it re-simulates the scenario of
//! `data.meta.json` for the true wavelengths and checks the CSV against it. Any disagreement
//! is shown at the top of the page, never papered over.

pub mod chart;
mod checks;
pub mod coef;
pub(crate) mod decimate;
pub mod figures;
pub(crate) mod fonts;
pub(crate) mod html;
mod inputs;
pub mod load;
mod page;
mod recompute;
pub(crate) mod summary;
pub(crate) mod window;

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;

use crate::data::files::OutputSet;
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::tables::{self, Table};
use figures::{Ctx, FigSpec, TimeUnit};
pub use inputs::{InputPaths, Inputs};
use page::Page;
use recompute::Recomputed;

/// File names the report reads.
pub(crate) const DATA_CSV: &str = "data.csv";
pub(crate) const MODEL_H: &str = "model.fbgm";
pub(crate) const MODEL_P: &str = "model-p.fbgm";
/// `evaluate`'s and `demo`'s metrics of model.fbgm (`<model stem>.metrics.json`).
pub const METRICS_JSON: &str = "model.metrics.json";
/// `train`'s and `demo`'s audit sidecar of model.fbgm (`<model stem>.coefficients.json`).
pub const COEFFICIENTS_JSON: &str = "model.coefficients.json";
/// The metrics file name of report directories written before the sidecars were named after
/// the model; read when [`METRICS_JSON`] is absent.
pub(crate) const LEGACY_METRICS_JSON: &str = "metrics.json";
/// The page.
pub const INDEX_HTML: &str = "index.html";

/// Relative tolerance when comparing metrics.json with the recomputed hold-out metrics (the
/// CSV rounds to 1e-6, which moves the metrics by far less).
pub(crate) const METRICS_REL_TOL: f64 = 1e-3;
/// Largest |Δλ| \[pm\] between the CSV and the re-simulation still taken as the same data.
pub(crate) const RESIM_TOL_PM: f64 = 1e-4;

/// What writing the report produced.
#[derive(Clone, Debug, Default)]
pub struct Outcome {
    /// Files written, relative to the directory.
    pub files: Vec<String>,
    /// Disagreements shown at the top of the page.
    pub warnings: Vec<String>,
    /// Omissions shown at the top of the page (e.g. no data.meta.json).
    pub notes: Vec<String>,
    pub seconds: f64,
}

/// Read `dir` and write the report into it.
pub fn build(dir: &Path) -> Result<Outcome, TrainerError> {
    build_from(dir, &InputPaths::in_dir(dir))
}

/// Read `paths` and write the report into `dir`.
pub fn build_from(dir: &Path, paths: &InputPaths) -> Result<Outcome, TrainerError> {
    let t = Instant::now();
    let inp = Inputs::read(dir, paths)?;
    let meta = crate::sim::meta::meta_path(&paths.data);
    let inputs = [&paths.data, &meta, &paths.model_h, &paths.model_p, &paths.metrics].map(PathBuf::as_path);
    let mut o = write_guarded(dir, &inp, &inputs)?;
    o.seconds = t.elapsed().as_secs_f64();
    Ok(o)
}

/// Write the report for `inp` into `dir`.
pub fn write(dir: &Path, inp: &Inputs) -> Result<Outcome, TrainerError> {
    write_guarded(dir, inp, &[])
}

/// [`write()`], refusing to replace any of `inputs`. Every page, table and figure is one output
/// set: the directory keeps the old report whole until the new one is complete.
pub(crate) fn write_guarded(dir: &Path, inp: &Inputs, inputs: &[&Path]) -> Result<Outcome, TrainerError> {
    let t0 = Instant::now();
    let set = OutputSet::in_dir(dir)?.with_inputs(inputs);
    fonts::ensure_registered();
    let d = &inp.data;
    let m = &inp.metrics;
    let (all_hold, hold) = holdout_rows(d)?;
    let mut r = Recomputed::of(inp, &hold)?;
    let mut out = Outcome::default();
    let sim = checks::run(inp, &mut r, &all_hold, &hold, &mut out)?;

    let ctx = Ctx {
        data: d,
        sim: sim.as_ref(),
        hold: &hold,
        est_p: &r.est_p,
        est_h: &r.est_h,
        metrics: m,
        time: TimeUnit::for_span(d.t_s[d.len() - 1] - d.t_s[0]),
        parts_h: &r.parts_h,
        dims: inp.model_h.dims,
    };
    let specs = figures::all(&ctx);
    stage_figures(&set, dir, &specs, &mut out.files)?;
    let results = tables::all(m);
    let coefs = coef::tables(&inp.model_p, &inp.model_h, m);
    stage_tables(&set, dir, &results, &coefs, &mut out.files)?;

    let today = crate::fit::today_yyyymmdd();
    let html = page::page(&Page {
        dir,
        inp,
        specs: &specs,
        results: &results,
        coefs: &coefs,
        out: &out,
        resimulated: sim.is_some(),
        today,
    });
    set.stage_bytes(&dir.join(INDEX_HTML), html.as_bytes())?;
    set.commit()?;
    out.files.push(INDEX_HTML.into());
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// The hold-out rows, and those of them the evaluation scores: finite inputs and references
/// (as `evaluate_holdout`, whose estimates line up with these).
fn holdout_rows(d: &Dataset) -> Result<(Vec<usize>, Vec<usize>), TrainerError> {
    let all_hold = d.holdout_indices();
    let hold: Vec<usize> = all_hold.iter().copied().filter(|&i| d.usable(i)).collect();
    if hold.is_empty() || d.len() < 2 {
        return Err(TrainerError::Dataset {
            message: "the report needs usable hold-out rows (split column `holdout`, finite inputs and references)"
                .into(),
        });
    }
    Ok((all_hold, hold))
}

/// Draw every figure as PNG and SVG (in parallel) into the output set; `files` gets their
/// names.
fn stage_figures(set: &OutputSet, dir: &Path, specs: &[FigSpec], files: &mut Vec<String>) -> Result<(), TrainerError> {
    specs
        .par_iter()
        .map(|f| {
            let fail = |ext: &str, e: String| {
                let p = dir.join(format!("{}.{ext}", f.stem));
                TrainerError::io(&p, std::io::Error::other(format!("drawing the figure failed: {e}")))
            };
            let png = f.grid.png().map_err(|e| fail("png", e))?;
            set.stage_bytes(&dir.join(format!("{}.png", f.stem)), &png)?;
            let svg = f.grid.svg().map_err(|e| fail("svg", e))?;
            set.stage_bytes(&dir.join(format!("{}.svg", f.stem)), svg.as_bytes())
        })
        .collect::<Result<Vec<()>, TrainerError>>()?;
    for f in specs {
        files.push(format!("{}.png", f.stem));
        files.push(format!("{}.svg", f.stem));
    }
    Ok(())
}

/// metrics.json's tables (Markdown, CSV, text) and the coefficient tables (Markdown, CSV) into
/// the output set; `files` gets their names.
fn stage_tables(
    set: &OutputSet,
    dir: &Path,
    results: &[(&'static str, Table)],
    coefs: &[(String, Table)],
    files: &mut Vec<String>,
) -> Result<(), TrainerError> {
    for (name, t) in results {
        for (ext, body) in [("md", t.markdown()), ("csv", t.csv()), ("txt", t.text())] {
            let f = format!("{name}.{ext}");
            set.stage_bytes(&dir.join(&f), body.as_bytes())?;
            files.push(f);
        }
    }
    for (name, t) in coefs {
        for (ext, body) in [("md", format!("**{}**\n\n{}", t.title, t.markdown())), ("csv", t.csv())] {
            let f = format!("{name}.{ext}");
            set.stage_bytes(&dir.join(&f), body.as_bytes())?;
            files.push(f);
        }
    }
    Ok(())
}
