//! The audit report (DESIGN §5): from a directory holding `data.csv`
//! (+ `data.meta.json`), `model.fbgm`, `model-p.fbgm` and `metrics.json`, write into the same
//! directory the eight figures (PNG and SVG), the tables (Markdown, CSV, text), the
//! coefficient tables and `index.html`, a static page that shows all of it with the scenario,
//! the provenance and a summary generated from the numbers.
//!
//! The report recomputes the hold-out estimates from the models and the data (for the
//! figures) and checks them against `metrics.json`; it re-simulates the scenario of
//! `data.meta.json` for the true wavelengths and checks the CSV against it. Any disagreement
//! is shown at the top of the page, never papered over.

pub mod chart;
pub mod coef;
pub mod decimate;
pub mod figures;
pub mod fonts;
pub mod html;
pub mod load;
pub mod summary;
pub mod window;

use std::path::{Path, PathBuf};
use std::time::Instant;

use rayon::prelude::*;

use crate::data::files::OutputSet;
use crate::data::Dataset;
use crate::error::TrainerError;
use crate::eval::metrics::Metrics;
use crate::eval::score::{evaluate_holdout, ModelEval};
use crate::eval::tables;
use crate::export;
use crate::fit::HostParams;
use crate::sim::meta::SimMeta;
use crate::sim::{simulate, Simulation};
use figures::{count, num, Ctx, FigSpec, TimeUnit};
use html::{esc, FigEntry, Section};

/// File names the report reads.
pub const DATA_CSV: &str = "data.csv";
pub const MODEL_H: &str = "model.fbgm";
pub const MODEL_P: &str = "model-p.fbgm";
/// `evaluate`'s and `demo`'s metrics of model.fbgm (`<model stem>.metrics.json`).
pub const METRICS_JSON: &str = "model.metrics.json";
/// `train`'s and `demo`'s audit sidecar of model.fbgm (`<model stem>.coefficients.json`).
pub const COEFFICIENTS_JSON: &str = "model.coefficients.json";
/// The metrics file name of report directories written before the sidecars were named after
/// the model; read when [`METRICS_JSON`] is absent.
pub const LEGACY_METRICS_JSON: &str = "metrics.json";
/// The page.
pub const INDEX_HTML: &str = "index.html";

/// Relative tolerance when comparing metrics.json with the recomputed hold-out metrics (the
/// CSV rounds to 1e-6, which moves the metrics by far less).
pub const METRICS_REL_TOL: f64 = 1e-3;
/// Largest |Δλ| \[pm\] between the CSV and the re-simulation still taken as the same data.
pub const RESIM_TOL_PM: f64 = 1e-4;

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

/// Check the CSV against the re-simulation of its sidecar.
fn check_resim(s: &Simulation, d: &Dataset) -> Result<(), String> {
    if s.data.len() != d.len() {
        return Err(format!(
            "data.csv has {} samples but re-simulating data.meta.json gives {}: Figure 2 (true wavelength) is omitted.",
            d.len(),
            s.data.len()
        ));
    }
    let mut worst: f64 = 0.0;
    if s.data.n_gratings() != d.n_gratings() {
        return Err(format!(
            "data.csv has {} gratings but re-simulating data.meta.json gives {}: Figure 2 (true wavelength) is omitted.",
            d.n_gratings(),
            s.data.n_gratings()
        ));
    }
    for g in 0..d.n_gratings() {
        for (a, b) in s.data.dl_pm[g].iter().zip(&d.dl_pm[g]) {
            let diff = (a - b).abs();
            // A gap (NaN) in the CSV where the simulation has a value is a difference too.
            worst = if diff.is_nan() { f64::INFINITY } else { worst.max(diff) };
        }
    }
    if worst.is_nan() || worst > RESIM_TOL_PM {
        return Err(format!(
            "data.csv differs from a re-simulation of data.meta.json by up to {worst:.3e} pm (tolerance {RESIM_TOL_PM:e}): the CSV was edited or the simulator changed; Figure 2 (true wavelength) is omitted."
        ));
    }
    Ok(())
}

fn close(a: f64, b: f64) -> bool {
    (a.is_nan() && b.is_nan()) || (a - b).abs() <= METRICS_REL_TOL * b.abs().max(a.abs()) + 1e-12
}

/// Compare metrics.json with the hold-out metrics recomputed from the models and the data.
fn check_metrics(m: &Metrics, p: &ModelEval, h: &ModelEval, hold: usize, n: usize, warnings: &mut Vec<String>) {
    if m.samples != n || m.holdout_samples != hold {
        warnings.push(format!(
            "metrics.json describes {} samples ({} hold-out) but data.csv has {} ({} hold-out).",
            m.samples, m.holdout_samples, n, hold
        ));
    }
    let mut bad = Vec::new();
    for (name, stored, fresh) in [("Model-P", &m.table2.model_p, p), ("Model-H", &m.table2.model_h, h)] {
        if stored.channels.len() != fresh.channels.len() {
            bad.push(format!(
                "{name}: metrics.json has {} channels, the model {}",
                stored.channels.len(),
                fresh.channels.len()
            ));
            continue;
        }
        for (c, ch) in m.channels.iter().enumerate().take(fresh.channels.len()) {
            let (s, f) = (&stored.channels[c], &fresh.channels[c]);
            for (stat, a, b) in [
                ("RMSE", s.rmse, f.rmse),
                ("MAE", s.mae, f.mae),
                ("bias", s.bias, f.bias),
                ("coverage", s.coverage, f.coverage),
            ] {
                if !close(a, b) {
                    bad.push(format!("{name} {ch} {stat}: metrics.json {a:.6} vs recomputed {b:.6}"));
                }
            }
        }
    }
    if !bad.is_empty() {
        warnings.push(format!(
            "metrics.json does not match the models and data in this directory (tables and summary show metrics.json; figures show the recomputed estimates): {}.",
            bad.join("; ")
        ));
    }
    let n = m.table2.gain_pct.len().min(m.table2.model_h.channels.len()).min(m.table2.model_p.channels.len());
    let g: Vec<f64> = (0..n)
        .map(|c| crate::eval::score::gain_pct(m.table2.model_p.channels[c].rmse, m.table2.model_h.channels[c].rmse))
        .collect();
    let gbad: Vec<String> = (0..n)
        .filter(|&c| !close(g[c], m.table2.gain_pct[c]))
        .map(|c| {
            let ch = m.channels.get(c).map_or("?", |s| s.as_str());
            format!("{ch}: {:.2} % stored vs {:.2} % from its RMSEs", m.table2.gain_pct[c], g[c])
        })
        .collect();
    if !gbad.is_empty() {
        warnings.push(format!("metrics.json's gains disagree with its own RMSEs: {}.", gbad.join("; ")));
    }
}

fn check_provenance(inp: &Inputs, warnings: &mut Vec<String>) {
    let m = &inp.metrics;
    for (name, p) in [("model.fbgm", &inp.model_h), ("model-p.fbgm", &inp.model_p)] {
        let pr = &p.provenance;
        if pr.scenario.as_str() != m.scenario || pr.seed != m.seed {
            warnings.push(format!(
                "{name} was trained on scenario “{}”, seed {}, but metrics.json describes “{}”, seed {}.",
                pr.scenario, pr.seed, m.scenario, m.seed
            ));
        }
    }
    if let Some(meta) = &inp.meta {
        if meta.scenario.name != m.scenario || meta.seed != m.seed {
            warnings.push(format!(
                "data.meta.json describes scenario “{}”, seed {}, but metrics.json describes “{}”, seed {}.",
                meta.scenario.name, meta.seed, m.scenario, m.seed
            ));
        }
    }
    if !export::is_model_p(&inp.model_p) {
        warnings.push(format!(
            "model-p.fbgm has {} RBF centres: it is not a polynomial-only Model-P.",
            inp.model_p.centres.len()
        ));
    }
}

fn date(yyyymmdd: u32) -> String {
    format!("{:04}-{:02}-{:02}", yyyymmdd / 10_000, yyyymmdd / 100 % 100, yyyymmdd % 100)
}

/// Model-H's answer at each of `hold` split into [core Bφ, memory terms Γm, RBF Wψ] per
/// channel, each part from `fbg_shared` with the later parts removed (empty for a model with
/// neither memory nor centres).
fn contributions(
    h: &HostParams,
    d: &Dataset,
    hold: &[usize],
    est_h: &[fbg_shared::Estimate<f64>],
) -> Result<Vec<[[f64; fbg_shared::layout::MAX_OUTPUTS]; 3]>, TrainerError> {
    if !h.has_memory() && h.centres.is_empty() {
        return Ok(Vec::new());
    }
    let mut no_rbf = h.clone();
    no_rbf.centres.clear();
    let mut core_only = no_rbf.clone();
    core_only.memory = fbg_shared::MemorySpec::off();
    core_only.gamma = [[0.0; fbg_shared::layout::MAX_MEMORY]; fbg_shared::layout::MAX_OUTPUTS];
    let (a, b) = rayon::join(|| crate::fit::run(&core_only, d, hold), || crate::fit::run(&no_rbf, d, hold));
    let (a, b) = (a?, b?);
    Ok(a.iter()
        .zip(&b)
        .zip(est_h)
        .map(|((c, m), f)| {
            [
                c.values,
                std::array::from_fn(|k| m.values[k] - c.values[k]),
                std::array::from_fn(|k| f.values[k] - m.values[k]),
            ]
        })
        .collect())
}

/// Write the report for `inp` into `dir`.
pub fn write(dir: &Path, inp: &Inputs) -> Result<Outcome, TrainerError> {
    write_guarded(dir, inp, &[])
}

/// [`write()`], refusing to replace any of `inputs`. Every page, table and figure is one output
/// set: the directory keeps the old report whole until the new one is complete.
pub fn write_guarded(dir: &Path, inp: &Inputs, inputs: &[&Path]) -> Result<Outcome, TrainerError> {
    let t0 = Instant::now();
    let set = OutputSet::in_dir(dir)?.with_inputs(inputs);
    fonts::ensure_registered();
    let d = &inp.data;
    let m = &inp.metrics;
    // The hold-out rows the evaluation scores: finite inputs and references (as
    // `evaluate_holdout`, whose estimates line up with these).
    let all_hold = d.holdout_indices();
    let hold: Vec<usize> = all_hold.iter().copied().filter(|&i| d.usable(i)).collect();
    if hold.is_empty() || d.len() < 2 {
        return Err(TrainerError::Dataset {
            message: "the report needs usable hold-out rows (split column `holdout`, finite inputs and references)"
                .into(),
        });
    }
    let ((rp, rh), sim) = rayon::join(
        || rayon::join(|| evaluate_holdout(&inp.model_p, d), || evaluate_holdout(&inp.model_h, d)),
        || inp.meta.as_ref().map(|mm| simulate(&mm.scenario, mm.seed)),
    );
    let (ev_p, est_p) = rp?;
    let (ev_h, est_h) = rh?;
    let parts_h = contributions(&inp.model_h, d, &hold, &est_h)?;

    let mut out = Outcome::default();
    let sim = match sim {
        Some(s) => match check_resim(&s, d) {
            Ok(()) => Some(s),
            Err(msg) => {
                out.warnings.push(msg);
                None
            }
        },
        None => {
            out.notes.push(
                "data.meta.json is absent, so the data cannot be re-simulated: Figure 2 (true wavelength shift) and the per-sample oracle are omitted, and the scenario is known only by the name recorded in metrics.json."
                    .into(),
            );
            None
        }
    };
    if est_p.len() != hold.len() || est_h.len() != hold.len() {
        return Err(TrainerError::Dataset {
            message: format!(
                "internal: {} / {} estimates for {} usable hold-out rows",
                est_p.len(),
                est_h.len(),
                hold.len()
            ),
        });
    }
    if hold.len() < all_hold.len() {
        out.notes.push(format!(
            "{} of the {} hold-out rows have a gap (a non-finite input or reference) and are neither evaluated nor drawn as estimates.",
            count(all_hold.len() - hold.len()),
            count(all_hold.len())
        ));
    }
    let dims = inp.model_h.dims;
    let missing: Vec<String> = (0..dims.n_outputs())
        .filter(|&c| !d.reference_of(&dims, c).is_present())
        .map(|c| figures::ChannelNames::of(crate::data::Measurand::of_output(dims.outputs()[c])).long)
        .collect();
    if !missing.is_empty() {
        out.notes.push(format!(
            "data.csv has no reference for {}: those channels are estimated but cannot be scored, so their errors, parity and histograms are empty.",
            missing.join(", ").to_lowercase()
        ));
    }
    check_metrics(m, &ev_p, &ev_h, all_hold.len(), d.len(), &mut out.warnings);
    check_provenance(inp, &mut out.warnings);
    if m.drift_sweep.is_none() {
        out.notes.push("metrics.json has no drift sweep (e.g. `evaluate --quick` or data without data.meta.json): Figure 8 is omitted.".into());
    }

    let span = d.t_s[d.len() - 1] - d.t_s[0];
    let ctx = Ctx {
        data: d,
        sim: sim.as_ref(),
        hold: &hold,
        est_p: &est_p,
        est_h: &est_h,
        metrics: m,
        time: TimeUnit::for_span(span),
        parts_h: &parts_h,
        dims,
    };
    let mut specs: Vec<FigSpec> = vec![figures::fig1_inputs(&ctx)];
    specs.extend(figures::fig2_wavelength(&ctx, 0));
    for ch in 0..ctx.n_channels() {
        specs.push(figures::fig_channel(&ctx, ch));
    }

    specs.push(figures::fig6_parity(&ctx));
    specs.push(figures::fig7_errors(&ctx));
    specs.extend(figures::fig8_drift(&ctx));
    specs.extend(figures::fig9_contributions(&ctx));
    specs.extend(figures::fig10_pace(&ctx));
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
    for f in &specs {
        out.files.push(format!("{}.png", f.stem));
        out.files.push(format!("{}.svg", f.stem));
    }

    // Tables.
    let results = tables::all(m);
    for (name, t) in &results {
        for (ext, body) in [("md", t.markdown()), ("csv", t.csv()), ("txt", t.text())] {
            let f = format!("{name}.{ext}");
            set.stage_bytes(&dir.join(&f), body.as_bytes())?;
            out.files.push(f);
        }
    }
    let coefs = coef::tables(&inp.model_p, &inp.model_h, m);
    for (name, t) in &coefs {
        for (ext, body) in [("md", format!("**{}**\n\n{}", t.title, t.markdown())), ("csv", t.csv())] {
            let f = format!("{name}.{ext}");
            set.stage_bytes(&dir.join(&f), body.as_bytes())?;
            out.files.push(f);
        }
    }

    // The page.
    let page = page(dir, inp, &specs, &results, &coefs, &out, sim.is_some());
    set.stage_bytes(&dir.join(INDEX_HTML), page.as_bytes())?;
    set.commit()?;
    out.files.push(INDEX_HTML.into());
    out.seconds = t0.elapsed().as_secs_f64();
    Ok(out)
}

/// The warnings of metrics.json (`train`'s and `evaluate`'s), the first thing on the page: each
/// message with its channel and code, and the numbers behind it.
fn warnings_block(ws: &[crate::warning::Warning]) -> String {
    if ws.is_empty() {
        return "<p class=\"note\" id=\"warnings\"><strong>Warnings:</strong> none recorded in metrics.json (by <code>train</code> or <code>evaluate</code>).</p>\n".into();
    }
    let mut o = format!(
        "<div class=\"warn\" id=\"warnings\"><strong>{} recorded by <code>train</code> and <code>evaluate</code> (metrics.json):</strong>\n<ul>\n",
        if ws.len() == 1 { "1 warning".to_string() } else { format!("{} warnings", ws.len()) }
    );
    for w in ws {
        let numbers: Vec<String> = w.numbers.iter().map(|(k, v)| format!("{k} = {}", num(*v, 4))).collect();
        o.push_str(&format!(
            "<li>{}{} <span class=\"files\">({}{})</span></li>\n",
            w.channel.as_deref().map(|c| format!("<strong>{}:</strong> ", esc(c))).unwrap_or_default(),
            esc(&w.message),
            esc(&w.code),
            if numbers.is_empty() { String::new() } else { format!("; {}", esc(&numbers.join(", "))) }
        ));
    }
    o.push_str("</ul></div>\n");
    o
}

fn page(
    dir: &Path,
    inp: &Inputs,
    specs: &[FigSpec],
    results: &[(&'static str, crate::eval::tables::Table)],
    coefs: &[(String, crate::eval::tables::Table)],
    out: &Outcome,
    resimulated: bool,
) -> String {
    let m = &inp.metrics;
    let d = &inp.data;
    let pr = &inp.model_h.provenance;
    let today = crate::fit::today_yyyymmdd();
    let title = if m.table2.oracle_floor.is_some() {
        format!("FBG compensation audit report — scenario “{}”, seed {}", m.scenario, m.seed)
    } else {
        format!("FBG compensation audit report — “{}” (recorded data)", m.scenario)
    };
    let mut header = format!(
        "<p>Model-P (polynomial core, paper Eq. 3) and Model-H (the same core plus an RBF residual, paper Eqs. 4–7) evaluated on the hold-out of {} samples. Report generated {} by fbg-trainer {} from the files in this directory; regenerate with <code>fbg-trainer report --out &lt;this directory&gt;</code>.</p>\n",
        count(m.holdout_samples),
        date(today),
        env!("CARGO_PKG_VERSION")
    );
    header.push_str(&warnings_block(&m.warnings));
    let fig = |stem: &str| -> String {
        specs
            .iter()
            .find(|f| f.stem == stem)
            .map(|f| {
                html::figure(&FigEntry { stem: f.stem.clone(), title: f.title.clone(), caption: f.caption.clone() })
            })
            .unwrap_or_default()
    };
    let table_of = |name: &str| -> String {
        results.iter().find(|(n, _)| *n == name).map(|(n, t)| html::table(t, Some(n))).unwrap_or_default()
    };
    let mut sections = Vec::new();

    // Summary.
    let mut body = String::new();
    for w in &out.warnings {
        body.push_str(&format!("<p class=\"warn\"><strong>Check failed:</strong> {}</p>\n", esc(w)));
    }
    for n in &out.notes {
        body.push_str(&format!("<p class=\"note\"><strong>Note:</strong> {}</p>\n", esc(n)));
    }
    body.push_str("<div class=\"summary\">\n");
    for p in summary::paragraphs(m, inp.meta.is_some()) {
        body.push_str(&format!("<p>{}</p>\n", esc(&p)));
    }
    body.push_str("</div>\n");
    sections.push(Section { id: "summary".into(), title: "Summary".into(), body });

    // Table 2.
    sections.push(Section {
        id: "table2".into(),
        title: "Hold-out performance (Table 2)".into(),
        body: format!(
            "<p>Per channel and model on the hold-out: RMSE, MAE, R², bias (mean of estimate − truth), largest |error|, coverage of the 95 % band, hysteresis index (mean error rising − falling), Model-H's RMSE gain over Model-P and the per-sample oracle. Units are those of the channel.</p>\n{}",
            table_of("table2")
        ),
    });

    // Figures.
    let omitted2 = if specs.iter().any(|f| f.stem.starts_with("fig2")) {
        String::new()
    } else {
        format!(
            "<p class=\"note\">Figure 2 (measured vs true wavelength) is omitted: {}</p>\n",
            if inp.meta.is_none() {
                "data.meta.json is absent, and the true wavelength exists only in the simulator."
            } else {
                "the data do not match their re-simulation (see the check above)."
            }
        )
    };
    sections.push(Section {
        id: "inputs".into(),
        title: "Inputs and raw measurements (Figs. 1–2)".into(),
        body: format!("{}{}{}", fig("fig1_inputs"), omitted2, fig("fig2_wavelength_fbg1")),
    });
    sections.push(Section {
        id: "reconstructions".into(),
        title: match (0..inp.model_h.dims.n_outputs())
            .map(|ch| figures::channel_fig_no(&inp.model_h.dims, ch))
            .collect::<Vec<_>>()
            .as_slice()
        {
            [one] => format!("Reconstruction on the hold-out (Fig. {one})"),
            [first, .., last] => format!("Reconstructions on the hold-out (Figs. {first}–{last})"),
            [] => "Reconstructions on the hold-out".into(),
        },
        body: (0..inp.model_h.dims.n_outputs())
            .map(|ch| fig(&figures::channel_stem(&inp.model_h.dims, ch)))
            .collect::<String>(),
    });
    sections.push(Section {
        id: "parity".into(),
        title: "Parity and error distributions (Figs. 6–7)".into(),
        body: format!("{}{}", fig("fig6_parity"), fig("fig7_error_histograms")),
    });
    sections.push(Section {
        id: "contributions".into(),
        title: "What the memory terms and the RBF residual contribute (Fig. 9)".into(),
        body: if inp.model_h.has_memory() || !inp.model_h.centres.is_empty() {
            fig("fig9_contributions")
        } else {
            "<p class=\"note\">Model-H has neither memory terms nor RBF centres: Figure 9 is omitted.</p>\n".into()
        },
    });
    sections.push(Section {
        id: "static-fidelity".into(),
        title: "Static fidelity and the pace study (Fig. 10)".into(),
        body: format!(
            "{}{}",
            if m.static_fidelity.is_some() {
                table_of("static_fidelity")
            } else {
                "<p class=\"note\">No static gains in metrics.json (written before static fidelity).</p>\n".into()
            },
            if m.pace.is_some() {
                format!("{}{}", fig("fig10_pace"), table_of("pace"))
            } else {
                "<p class=\"note\">No pace study in metrics.json (recorded data, or written before it): Figure 10 is omitted.</p>\n".into()
            }
        ),
    });
    sections.push(Section {
        id: "drift".into(),
        title: "Drift sensitivity (Fig. 8)".into(),
        body: if m.drift_sweep.is_some() {
            format!("{}{}", fig("fig8_drift_sensitivity"), table_of("drift_sweep"))
        } else {
            "<p class=\"note\">No drift sweep in metrics.json: Figure 8 is omitted.</p>\n".into()
        },
    });
    sections.push(Section {
        id: "ablation".into(),
        title: "Ablation (Table 3) and error budget".into(),
        body: format!(
            "{}{}",
            if m.ablation.is_some() { table_of("table3") } else { "<p class=\"note\">No ablation in metrics.json.</p>\n".into() },
            if m.error_budget.is_some() {
                format!("<p>The error budget refits both models on the scenario with one artefact switched off at a time (“all”: physics and nothing else); the oracle columns are that scenario's per-sample oracle.</p>\n{}", table_of("error_budget"))
            } else {
                "<p class=\"note\">No error budget in metrics.json (it needs data.meta.json).</p>\n".into()
            }
        ),
    });

    // Any other study metrics.json carries, so that nothing it holds goes unshown.
    let placed = ["table2", "table3", "error_budget", "drift_sweep"];
    let others: Vec<&(&'static str, crate::eval::tables::Table)> =
        results.iter().filter(|(n, _)| !placed.contains(n)).collect();
    if !others.is_empty() {
        let mut body = String::new();
        for (n, t) in others {
            body.push_str(&html::table(t, Some(n)));
        }
        sections.push(Section { id: "other-studies".into(), title: "Other studies in metrics.json".into(), body });
    }

    // Sensitivities (the calibration sheet), then the coefficients.
    let is_sens = |n: &str| n.starts_with("sensitivity");
    let mut body = String::from(
        "<p>Each grating's sensitivity to each measurand and the model's inverse, as a calibration sheet gives them (fbg_trainer::fit::sensitivity; also in model.coefficients.json and <code>fbg-trainer inspect</code>).</p>\n",
    );
    for (name, t) in coefs.iter().filter(|(n, _)| is_sens(n)) {
        body.push_str(&html::table(t, Some(name)));
    }
    sections.push(Section { id: "sensitivity".into(), title: "Sensitivities at the calibration point".into(), body });
    let mut body = String::from(
        "<p>Every number the device uses, read back from the model blobs (f32 on disk, shown in f64). The polynomial core is also given in physical units, the form a metrologist can check against gauge factors or replace after service.</p>\n",
    );
    for (name, t) in coefs.iter().filter(|(n, _)| !is_sens(n)) {
        body.push_str(&html::table(t, Some(name)));
    }
    sections.push(Section { id: "coefficients".into(), title: "Coefficients".into(), body });

    // Device parity.
    if let Some(p) = &m.parity {
        let rows: Vec<(String, String)> = vec![
            ("hold-out samples compared".into(), count(p.samples)),
            (
                format!(
                    "max |f32 − f64| ({})",
                    m.channels.iter().map(|c| c.replacen("strain", "ε", 1)).collect::<Vec<_>>().join(", ")
                ),
                p.max_abs_diff.iter().zip(&m.units).map(|(v, u)| format!("{v:.3e} {u}")).collect::<Vec<_>>().join(", "),
            ),
            (
                "as a share of Model-H's RMSE".into(),
                p.max_diff_over_rmse.iter().map(|v| format!("{} %", num(100.0 * v, 4))).collect::<Vec<_>>().join(", "),
            ),
            (
                "max relative band difference".into(),
                p.max_band_rel_diff.iter().map(|v| format!("{v:.2e}")).collect::<Vec<_>>().join(", "),
            ),
            ("flag mismatches".into(), p.flag_mismatches.to_string()),
            (
                "leverage band gap (kept eigen-directions vs exact)".into(),
                format!("{:.3e} (largest exact leverage {:.3e})", p.leverage_band_gap, p.leverage_max),
            ),
        ];
        sections.push(Section {
            id: "device".into(),
            title: "Device arithmetic (f32) against the f64 reference".into(),
            body: html::facts(&rows),
        });
    }

    // Provenance and scenario.
    let dt = d.t_s[1] - d.t_s[0];
    let mut rows: Vec<(String, String)> = vec![
        ("scenario (preset or TOML name)".into(), m.scenario.clone()),
        ("seed".into(), m.seed.to_string()),
        (
            "samples (calibration / hold-out)".into(),
            format!("{} ({} / {})", count(d.len()), count(d.cal_indices().len()), count(d.holdout_indices().len())),
        ),
        (
            "record".into(),
            format!("{} s sampling, {} days", num(dt, 3), num((d.t_s[d.len() - 1] - d.t_s[0]) / 86_400.0, 2)),
        ),
        (
            "trainer version (metrics.json / model.fbgm / this report)".into(),
            format!("{} / {} / {}", m.trainer_version, pr.trainer_version, env!("CARGO_PKG_VERSION")),
        ),
        ("models trained on".into(), date(pr.date_yyyymmdd)),
        ("calibration samples recorded in the model".into(), count(pr.n_cal as usize)),
        (
            "model blobs".into(),
            format!(
                "model.fbgm {} B ({} centres), model-p.fbgm {} B",
                export::blob_bytes(&inp.model_h).map(|b| b.len()).unwrap_or(0),
                inp.model_h.centres.len(),
                export::blob_bytes(&inp.model_p).map(|b| b.len()).unwrap_or(0)
            ),
        ),
        ("report generated".into(), date(today)),
        (
            "data.meta.json".into(),
            match (&inp.meta, resimulated) {
                (None, _) => "absent".into(),
                (Some(_), true) => "present; data.csv matches its re-simulation".into(),
                (Some(_), false) => "present; data.csv does NOT match its re-simulation".into(),
            },
        ),
    ];
    for (k, v) in &m.timings_s {
        rows.push((format!("wall time of `{k}` [s]"), num(*v, 1)));
    }
    let mut body = html::facts(&rows);
    if let Some(meta) = &inp.meta {
        let s = &meta.scenario;
        let on = |b: bool| if b { "on" } else { "off" };
        let mut srows: Vec<(String, String)> = vec![
            (
                "clock".into(),
                format!(
                    "{} days at {} s, calibration fraction {}",
                    num(s.clock.days, 2),
                    num(s.clock.dt_s, 1),
                    num(s.clock.cal_fraction, 2)
                ),
            ),
            (
                "temperature".into(),
                format!(
                    "mean {} °C, diurnal ±{} °C, weekly ±{} °C, seasonal ±{} °C, AR σ {} °C",
                    num(s.temperature.mean_c, 1),
                    num(s.temperature.diurnal_amp_c, 1),
                    num(s.temperature.weekly_amp_c, 1),
                    num(s.temperature.seasonal_amp_c, 1),
                    num(s.temperature.ar_sigma_c, 2)
                ),
            ),
        ];
        // Only the measurands the scenario has (a one-output record names no strain or pressure).
        let has = |k: crate::data::Kind| s.measurands.iter().any(|m| m.kind == k);
        if has(crate::data::Kind::Strain) {
            srows.push((
                "strain".into(),
                format!(
                    "levels {} … {} µε held {} s, sines ±{} / ±{} µε, AR σ {} µε",
                    num(s.strain.level_lo_ue, 0),
                    num(s.strain.level_hi_ue, 0),
                    num(s.strain.hold_s, 0),
                    num(s.strain.sine1_amp_ue, 0),
                    num(s.strain.sine2_amp_ue, 0),
                    num(s.strain.ar_sigma_ue, 1)
                ),
            ));
        }
        if has(crate::data::Kind::Pressure) {
            srows.push((
                "pressure".into(),
                format!(
                    "mean {} kPa, sines ±{} / ±{} kPa, AR σ {} kPa",
                    num(s.pressure.mean_kpa, 0),
                    num(s.pressure.sine1_amp_kpa, 1),
                    num(s.pressure.sine2_amp_kpa, 1),
                    num(s.pressure.ar_sigma_kpa, 2)
                ),
            ));
        }
        srows.extend([
            (
                "hysteresis (Eq. 9 + play)".into(),
                format!(
                    "{}: β {}, γ {}, ρ {}, play ±{} pm",
                    on(s.hysteresis.enabled),
                    s.hysteresis.beta,
                    s.hysteresis.gamma,
                    s.hysteresis.rho,
                    s.hysteresis.play_half_width_pm
                ),
            ),
            (
                "scan nonlinearity".into(),
                format!(
                    "{}: ripple {} pm per {} nm, bow {} pm",
                    on(s.scan.enabled),
                    s.scan.ripple_amp_pm,
                    s.scan.ripple_period_nm,
                    s.scan.bow_pm
                ),
            ),
            (
                "drift (Eq. 8)".into(),
                format!(
                    "{}: σ_d {} pm per step, channel gains {:?}",
                    on(s.drift.enabled),
                    s.drift.sigma_pm,
                    s.drift.channel_gain
                ),
            ),
            (
                "electronics drift".into(),
                format!(
                    "{}: {} pm/°C, {} pm/°C²",
                    on(s.electronics.enabled),
                    s.electronics.lin_pm_per_c,
                    s.electronics.quad_pm_per_c2
                ),
            ),
            (
                "noise".into(),
                format!(
                    "{}: pink σ {} pm, white σ {} pm",
                    on(s.noise.enabled),
                    s.noise.pink_sigma_pm,
                    s.noise.white_sigma_pm
                ),
            ),
        ]);
        body.push_str("<h3>Scenario</h3>\n");
        body.push_str(&html::facts(&srows));
        let toml = toml::to_string(s).unwrap_or_else(|e| format!("(cannot serialise the scenario: {e})"));
        body.push_str(&format!("<details><summary>Every scenario parameter (TOML, usable with <code>--config</code>)</summary><pre>{}</pre></details>\n", esc(&toml)));
    }
    sections.push(Section { id: "provenance".into(), title: "Provenance and scenario".into(), body });

    // Files.
    let mut body = String::from(
        "<p>Everything in this report, beside this page (no network access is needed to view it):</p>\n<ul>\n",
    );
    for f in &out.files {
        body.push_str(&format!("<li><a href=\"{0}\">{0}</a></li>\n", esc(f)));
    }
    body.push_str(&format!("<li><a href=\"{INDEX_HTML}\">{INDEX_HTML}</a> (this page)</li>\n"));
    for f in [DATA_CSV, "data.meta.json", METRICS_JSON, MODEL_H, MODEL_P, COEFFICIENTS_JSON] {
        if dir.join(f).is_file() {
            body.push_str(&format!("<li><a href=\"{0}\">{0}</a> (input)</li>\n", f));
        }
    }
    body.push_str("</ul>\n");
    sections.push(Section { id: "files".into(), title: "Files".into(), body });

    html::page(&title, &header, &sections)
}
