//! `fbg-trainer train`: fit Model-P and Model-H on a record's calibration rows and write both
//! blobs and the coefficients as one output set.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Result;

use fbg_trainer::data::files::check_outputs;
use fbg_trainer::data::{outliers, Dataset, Kind, Measurand};
use fbg_trainer::export::{self, ModelFiles};
use fbg_trainer::fit::{self, FeatureChoice, Origin, TrainOptions, Trained};
use fbg_trainer::sim::meta::{meta_path, SimMeta};

use crate::args::{FeaturesArg, SignArgs};

/// Fit Model-P and Model-H on the calibration part of a CSV; write the Model-H blob, the
/// Model-P blob beside it (`<stem>-p.fbgm`) and `<stem>.coefficients.json`.
#[derive(clap::Args)]
pub struct TrainArgs {
    /// Dataset CSV (DESIGN §3 columns, e.g. from `simulate` or `import`); its `.meta.json`
    /// sidecar, when present, gives the provenance.
    #[arg(long)]
    data: PathBuf,
    /// Feature sets cross-validation may choose from.
    #[arg(long, value_enum, default_value = "memory")]
    features: FeaturesArg,
    /// Largest number of RBF centres to consider (the device capacity).
    #[arg(long, default_value_t = 32)]
    max_centres: usize,
    /// Model-H blob; Model-P goes beside it as `<stem>-p.fbgm`, the coefficients as
    /// `<stem>.coefficients.json` in the same directory (created when missing).
    #[arg(long, default_value = "model.fbgm")]
    out: PathBuf,
    /// Print a JSON summary (outputs, sizes, chosen hyper-parameters and memory terms, CV
    /// RMSE, warnings) on stdout.
    #[arg(long)]
    json: bool,
    /// Reference outliers in the calibration rows (a cell beyond a robust z-score of 8
    /// against its running median): stop with an error naming file, line and column, or
    /// leave their rows out of the fit and count them.
    #[arg(long, value_parser = ["fail", "skip"], default_value = "fail")]
    on_error: String,
    /// The interrogator's stated wavelength stability as a random walk [pm/√day]: the bands
    /// add such a walk through each output, from its offset at the end of calibration on (one
    /// calibration week shows one path of the drift, too little to read its rate well).
    /// Without it, the bands grow at the rate the calibration's errors show.
    #[arg(long, value_name = "PM_PER_SQRT_DAY", allow_negative_numbers = true)]
    drift_spec: Option<f64>,
    /// The drift's relative gain per grating, comma-separated in the record's order (e.g.
    /// `1.0,1.1,1.2` for an interrogator whose channels drift 10 and 20 % more than the
    /// first): the bands take the walk through each output as those gains carry it. Without
    /// it, every grating is taken to drift alike.
    #[arg(long, value_name = "G1,G2,..", value_delimiter = ',', allow_negative_numbers = true)]
    drift_gains: Option<Vec<f64>>,
    #[command(flatten)]
    sign: SignArgs,
}

/// What was written, for the summary.
struct Written {
    base: PathBuf,
    coef: PathBuf,
    files: ModelFiles,
    seconds: f64,
}

impl TrainArgs {
    pub fn run(self) -> Result<()> {
        let (out, data) = (&self.out, &self.data);
        // The options first: a value out of range is refused before any file is read.
        let on_outlier = self.on_error.parse().map_err(anyhow::Error::msg)?;
        let opts =
            train_options(self.features.0, self.max_centres, !self.json, (self.drift_spec, self.drift_gains.clone()))?
                .with_on_outlier(on_outlier);
        let (base, coef) = (export::baseline_path(out), export::coefficients_path(out));
        let meta_file = meta_path(data);
        let keys = self.sign.key_files();
        // The record's sidecar (its zero and clock) is an input too.
        let side = fbg_trainer::data::record_meta::sidecar_path(data);
        let mut inputs = vec![data.as_path(), meta_file.as_path(), side.as_path()];
        inputs.extend(keys.iter().map(PathBuf::as_path));
        check_outputs(&[out, &base, &coef], &inputs)?;
        let signer = self.sign.signer()?;
        let d = Dataset::read_calibration_csv(data)?;
        let meta = SimMeta::read_for(data)?;
        let origin = origin_of(data, meta.as_ref());
        let t = Instant::now();
        let tr = fit::train_source(&d, &data.display().to_string(), &opts, &origin)?;
        let seconds = t.elapsed().as_secs_f64();
        let files = ModelFiles::of(&tr, signer.as_ref())?;
        files.write(out)?;
        let w = Written { base, coef, files, seconds };
        if self.json {
            println!("{}", serde_json::to_string_pretty(&self.summary_json(&d, &tr, &w)?)?);
        } else {
            self.print_summary(&tr, &w);
        }
        Ok(())
    }

    fn summary_json(&self, d: &Dataset, tr: &Trained, w: &Written) -> Result<serde_json::Value> {
        let s = &tr.selection;
        let skipped_rows = outliers::rows_of(&tr.skipped);
        Ok(serde_json::json!({
            "model_h": self.out, "model_p": w.base, "coefficients": w.coef,
            "model_h_bytes": w.files.model_h.len(), "model_p_bytes": w.files.model_p.len(),
            "train_seconds": w.seconds, "chosen": tr.chosen(), "cv_rmse_p": s.cv_rmse_p,
            "cv_rmse_h": s.cv_rmse_h, "grid_points": s.rows.len(), "signatures": w.files.signatures_json(),
            "static_fidelity": export::static_fidelity_json(&tr.model_h, &tr.static_audit),
            "outliers_skipped": {
                "rows": skipped_rows.len(),
                "lines": skipped_rows.iter().map(|&r| outliers::csv_line(d, r)).collect::<Vec<_>>(),
                "cells": tr.skipped,
            },
            "warnings": tr.warnings,
        }))
    }

    fn print_summary(&self, tr: &Trained, w: &Written) {
        let s = &tr.selection;
        eprintln!(
            "trained in {:.1} s on {} calibration samples ({} grid points); chose {}",
            w.seconds,
            s.n_cal,
            s.rows.len(),
            tr.chosen().text()
        );
        let outs = Measurand::of_dims(&tr.model_h.dims);
        let dg = |m: &Measurand| if m.kind == Kind::Temperature { 3 } else { 2 };
        let with_units: Vec<String> = outs
            .iter()
            .zip(&s.cv_rmse_p)
            .map(|(m, v)| format!("{} {:.*} {}", m.short_name(), dg(m), v, m.unit()))
            .collect();
        let bare: Vec<String> =
            outs.iter().zip(&s.cv_rmse_h).map(|(m, v)| format!("{} {:.*}", m.short_name(), dg(m), v)).collect();
        eprintln!("CV RMSE Model-P: {}; Model-H: {}", with_units.join(", "), bare.join(", "));
        let a = &tr.static_audit;
        let gains = |g: &[f64]| -> String {
            outs.iter().zip(g).map(|(m, v)| format!("{} {v:.4}", m.short_name())).collect::<Vec<_>>().join(", ")
        };
        eprintln!(
            "static gain (truth on the settled reading over the calibration batch; 1 is right): Model-P {}; Model-H {}",
            gains(&a.model_p.gain),
            gains(&a.model_h.gain)
        );
        for warning in &tr.warnings {
            eprintln!("warning: {warning}");
        }
        eprintln!(
            "wrote {} ({} B), {} ({} B), {}",
            self.out.display(),
            w.files.model_h.len(),
            w.base.display(),
            w.files.model_p.len(),
            w.coef.display()
        );
        if let Some((h, p)) = &w.files.signatures {
            eprintln!(
                "signed with key {}: Model-H serial {}, Model-P serial {}{}",
                h.key_id,
                h.serial,
                p.serial,
                if h.allow_rollback { " (allow-rollback flag set)" } else { "" }
            );
        }
    }
}

/// The provenance of a record: its sidecar's scenario and seed, else its file stem.
fn origin_of(data: &Path, meta: Option<&SimMeta>) -> Origin {
    match meta {
        Some(m) => Origin { scenario: m.scenario.name.clone(), seed: m.seed },
        None => {
            Origin { scenario: data.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(), seed: 0 }
        }
    }
}

fn train_options(
    features: FeatureChoice,
    max_centres: usize,
    progress: bool,
    (drift_spec, drift_gains): (Option<f64>, Option<Vec<f64>>),
) -> Result<TrainOptions> {
    let o = features.train_options(max_centres).map_err(|e| anyhow::anyhow!("--features/--max-centres: {e}"))?;
    let o = o
        .to_builder()
        .drift_spec_pm_per_sqrt_day(drift_spec)
        .check()
        .map_err(|e| anyhow::anyhow!("--drift-spec: {e}"))?;
    let o = o.to_builder().drift_gains(drift_gains).check().map_err(|e| anyhow::anyhow!("--drift-gains: {e}"))?;
    Ok(o.with_progress(progress))
}
