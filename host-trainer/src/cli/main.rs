//! `fbg-trainer`: the command line (DESIGN §10). Errors end here as `anyhow` messages that name
//! the file, line, column or key. The binary uses the `fbg_trainer` library only; each bigger
//! subcommand has its own module here.

mod demo;
mod inspect;
mod recalibrate;
mod stream;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};

use fbg_trainer::compensate::Precision;
use fbg_trainer::data::files::{check_outputs, write_bytes_atomically, OutputSet};
use fbg_trainer::data::import::{self, ImportOptions, SplitChoice};
use fbg_trainer::data::Dataset;
use fbg_trainer::eval::metrics::Metrics;
use fbg_trainer::eval::score::evaluate_holdout;
use fbg_trainer::eval::studies::{self, Studies};
use fbg_trainer::eval::tables;
use fbg_trainer::export;
use fbg_trainer::fit::{self, FeatureChoice, Origin, TrainOptions};
use fbg_trainer::sign::{self, SignArgs};
use fbg_trainer::sim::meta::{meta_path, SimMeta};
use fbg_trainer::sim::scenario::{Preset, ScenarioConfig};
use fbg_trainer::{report, sim};

#[derive(Parser)]
#[command(
    name = "fbg-trainer",
    version,
    about = "Hybrid AI–polynomial compensation for FBG sensors: simulate, train, evaluate, report, export"
)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

/// Where the scenario comes from.
#[derive(clap::Args, Clone)]
struct ScenarioArgs {
    /// Built-in scenario preset.
    #[arg(long, value_enum, default_value = "paper", conflicts_with = "config")]
    preset: Preset,
    /// Scenario TOML file; keys not given keep the `paper` defaults.
    #[arg(long)]
    config: Option<PathBuf>,
    /// Random seed.
    #[arg(long, default_value_t = 7)]
    seed: u64,
}

impl ScenarioArgs {
    fn load(&self) -> Result<ScenarioConfig> {
        match &self.config {
            Some(p) => Ok(ScenarioConfig::from_toml_file(p)?),
            None => Ok(self.preset.config()),
        }
    }
}

#[derive(Subcommand)]
enum Cmd {
    /// Simulate an installation; write its CSV and a `.meta.json` sidecar (scenario, seed,
    /// per-sample oracle).
    Simulate {
        #[command(flatten)]
        scenario: ScenarioArgs,
        /// Output CSV.
        #[arg(long, default_value = "data.csv")]
        out: PathBuf,
        /// Print a JSON summary (samples, shape, std of each measurand, per-sample oracle) on stdout.
        #[arg(long)]
        json: bool,
        /// Also write the scenario as TOML (every parameter, for audit and editing).
        #[arg(long)]
        dump_config: Option<PathBuf>,
        /// An installation without an ambient thermometer: no `T_amb_C` column (the scenario
        /// key `ambient = false` does the same).
        #[arg(long)]
        no_ambient: bool,
        /// The same installation at another pace: the measurands' trajectories run F times
        /// faster (periods, holds, ramps and AR times ÷ F; 0.25 = four times slower); the
        /// instrument is unchanged (the scenario's `[pace] factor`).
        #[arg(long, value_name = "F")]
        pace: Option<f64>,
        /// With --pace: pace only this measurand (a column such as `p_kPa`).
        #[arg(long, value_name = "COLUMN", requires = "pace")]
        pace_of: Option<fbg_trainer::data::Measurand>,
        /// A steps record: the calibration part, then a hold-out stepping each measurand in
        /// turn through held levels (the scenario's `[steps]`).
        #[arg(long)]
        steps: bool,
    },
    /// Fit Model-P and Model-H on the calibration part of a CSV; write the Model-H blob, the
    /// Model-P blob beside it (`<stem>-p.fbgm`) and `<stem>.coefficients.json`.
    Train {
        /// Dataset CSV (DESIGN §3 columns, e.g. from `simulate` or `import`); its `.meta.json`
        /// sidecar, when present, gives the provenance.
        #[arg(long)]
        data: PathBuf,
        /// Feature sets cross-validation may choose from.
        #[arg(long, value_enum, default_value = "memory")]
        features: FeatureChoice,
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
        #[command(flatten)]
        sign: SignArgs,
    },
    /// Evaluate models on the hold-out of a CSV: Table 2 and Table 3 (and, for simulated data
    /// with a `.meta.json`, the per-sample oracle, drift sweep and error budget); writes `<model stem>.metrics.json`.
    Evaluate {
        /// Dataset CSV whose hold-out rows are scored (its `.meta.json`, when present, adds the
        /// per-sample oracle and the studies that re-simulate).
        #[arg(long)]
        data: PathBuf,
        /// Model-H blob.
        #[arg(long, default_value = "model.fbgm")]
        model: PathBuf,
        /// Model-P blob (default: `<model stem>-p.fbgm` beside the model).
        #[arg(long)]
        baseline: Option<PathBuf>,
        /// Where to write the metrics [default: `<model stem>.metrics.json` beside the model].
        #[arg(long)]
        metrics: Option<PathBuf>,
        /// Skip the studies that retrain (Table 3, drift sweep, error budget).
        #[arg(long)]
        quick: bool,
        /// Print metrics.json on stdout instead of the tables.
        #[arg(long)]
        json: bool,
    },
    /// Field recalibration: refit the core's offset/gain and the residual weights (centres
    /// kept) of an existing model on a short batch (the calibration rows of DATA, or its first
    /// --batch-hours). Only the batch decides: each channel's update is fitted on its first
    /// 70 % and kept only if it predicts the last 30 % better than the old model (then refitted
    /// on the whole batch); otherwise the channel keeps the old coefficients (see
    /// --allow-worse). The hold-out RMSE before and after is reported separately, plays no part
    /// in the decision, and can come out worse: a warning says so.
    Recalibrate {
        /// The model to recalibrate (its Model-P baseline `<stem>-p.fbgm` is recalibrated too
        /// when present).
        #[arg(long)]
        model: PathBuf,
        /// Dataset CSV from the installation: its calibration rows are the batch, its hold-out
        /// rows an independent report before and after (never used to decide).
        #[arg(long)]
        data: PathBuf,
        /// Use only the first H hours of the calibration rows as the batch.
        #[arg(long)]
        batch_hours: Option<f64>,
        /// Output blob (the recalibrated Model-P goes beside it as `<stem>-p.fbgm`).
        #[arg(long, default_value = "recalibrated.fbgm")]
        out: PathBuf,
        /// Write every recalibrated channel even where the batch's check (its last 30 %)
        /// scores it no better than the old model (by default such a channel keeps the old
        /// coefficients).
        #[arg(long)]
        allow_worse: bool,
        /// Print a JSON summary on stdout instead of text.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        sign: SignArgs,
    },
    /// Print a blob's header, dimensions, hyper-parameters, provenance and signature (key id,
    /// serial, and whether it verifies against --pubkey).
    Inspect {
        /// The `.fbgm` blob.
        model: PathBuf,
        /// Check the signature against this public key (`lab.pub`, raw 32 bytes, or
        /// `lab.pub.hex`) with the device's verifier; exits non-zero when it does not verify.
        #[arg(long, value_name = "FILE")]
        pubkey: Option<PathBuf>,
        /// Print the header and the whole model as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Sign an existing blob (or re-sign a signed one): the blob, a trailer with the key id, a
    /// serial and flags, and the Ed25519 signature over both.
    Sign {
        /// The blob to sign.
        #[arg(long)]
        model: PathBuf,
        /// The signed blob to write.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        sign: SignArgs,
        /// Print the signature (key id, serial, flags) as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Make an Ed25519 signing key pair for signed model updates: the private key in OUT
    /// (PKCS#8 PEM, mode 0600, never overwritten), the public key beside it as `<stem>.pub`
    /// (raw 32 bytes: the file the firmware build trusts, `FBG_TRUSTED_KEYS`) and
    /// `<stem>.pub.hex`; prints the key id (first 8 bytes of SHA-256 of the public key).
    Keygen {
        /// The private key file to create.
        #[arg(long, default_value = "lab.key")]
        out: PathBuf,
        /// Print the files, key id and public key as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Write golden vectors (device inputs and f64 expected outputs) for the firmware tests.
    Golden {
        /// Dataset CSV whose first hold-out samples become the vectors.
        #[arg(long)]
        data: PathBuf,
        /// Model-H blob the expected outputs come from.
        #[arg(long, default_value = "model.fbgm")]
        model: PathBuf,
        /// Number of hold-out samples.
        #[arg(long, default_value_t = 1000)]
        samples: usize,
        /// Output directory (created when missing): golden_inputs.bin, golden_expected.csv,
        /// golden_meta.json.
        #[arg(long, default_value = "golden")]
        out: PathBuf,
    },
    /// Regenerate the audit report (figures, tables, coefficient tables, index.html) in DIR from
    /// the data.csv (+ data.meta.json), model.fbgm, model-p.fbgm and model.metrics.json there, or from
    /// the files named by --data, --model, --model-p and --metrics.
    Report {
        /// The directory read and written (as `demo --out` left it).
        #[arg(long, default_value = "report")]
        out: PathBuf,
        /// The dataset CSV (its .meta.json is read beside it when present) [default: DIR/data.csv].
        #[arg(long)]
        data: Option<PathBuf>,
        /// Model-H blob [default: DIR/model.fbgm].
        #[arg(long)]
        model: Option<PathBuf>,
        /// Model-P blob [default: <model stem>-p.fbgm beside --model, else DIR/model-p.fbgm].
        #[arg(long)]
        model_p: Option<PathBuf>,
        /// The metrics written by evaluate [default: `<model stem>.metrics.json` beside --model, else
        /// DIR/model.metrics.json].
        #[arg(long)]
        metrics: Option<PathBuf>,
        /// Print the files written, warnings and notes as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Simulate the `paper` preset, train both models, evaluate, run every study and write the
    /// whole audit report into DIR.
    Demo {
        /// Output directory (created when missing) for the data, models, tables, figures and
        /// index.html.
        #[arg(long, default_value = "report")]
        out: PathBuf,
        #[command(flatten)]
        scenario: ScenarioArgs,
        /// Print metrics.json on stdout instead of the tables and progress.
        #[arg(long)]
        json: bool,
    },
    /// Import a real interrogator export into the dataset CSV: an ENLIGHT / Hyperion peaks file
    /// (with the references from --refs) or any logger CSV whose columns a map names.
    Import {
        /// Input layout.
        #[arg(long, value_parser = ["enlight", "csv"])]
        format: String,
        /// The export (ENLIGHT peaks file or logger CSV).
        file: PathBuf,
        /// Map (TOML): which column or peak is what, in which unit (README.md, "Real data:
        /// import and field recalibration").
        #[arg(long)]
        map: Option<PathBuf>,
        /// ENLIGHT: CSV with time, ambient temperature and references, read with the map's
        /// column mapping and interpolated onto the peak times.
        #[arg(long)]
        refs: Option<PathBuf>,
        /// Output dataset CSV (DESIGN §3 columns; directory created when missing).
        #[arg(long, default_value = "data.csv")]
        out: PathBuf,
        /// Rows up to this time calibrate: seconds from the first row, or a timestamp.
        #[arg(long, conflicts_with = "cal_fraction")]
        cal_until: Option<String>,
        /// Fraction of the record's duration that calibrates [default: 0.5].
        #[arg(long)]
        cal_fraction: Option<f64>,
        /// Bad rows: stop with an error naming file, line and column, or skip and count them.
        #[arg(long, value_parser = ["fail", "skip"], default_value = "fail")]
        on_error: String,
        /// With --on-error skip: the largest share of a file's rows, in percent, that may be
        /// skipped; above it the import fails with the counts by reason.
        #[arg(long, default_value_t = 100.0 * import::DEFAULT_MAX_SKIPPED)]
        max_skipped: f64,
        /// Zero absolute wavelengths on this model's λ_ref (a field record read against its
        /// calibration's zero) instead of the map's `ref_nm` or the first reading.
        #[arg(long)]
        model: Option<PathBuf>,
        /// Absolute time of the first row (UTC, `YYYY-MM-DDThh:mm:ss[.fff]`) for an export whose
        /// times are plain seconds: the band's clock.
        #[arg(long)]
        start: Option<String>,
        /// Print the import summary (rows, skips by reason, gratings, references, split) as
        /// JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Time the fit for benchmarks (`cargo xtask bench`): read a CSV once, fit it --repeats
    /// times (each fit timed alone), evaluate the last fit on the hold-out.
    BenchFit(fbg_trainer::benchmark::BenchFitArgs),
    /// Calibrate many sensor groups in parallel from a TOML manifest (each group's data CSV and
    /// output blob); resumes without redoing finished groups; a failing group does not stop the
    /// others.
    Fleet(fbg_trainer::fleet::FleetArgs),
    /// Stream the hold-out samples of DATA to a running device (QEMU's serial port on TCP, or a
    /// board behind a serial-to-TCP bridge) and check every estimate against the host's f64
    /// compensator on the same model (1 % of the hold-out RMSE, flags identical).
    Stream(stream::StreamArgs),
    /// Compensate a logged field record with a model, as the device would: every row's
    /// measurands with their 95 % band and flags; gaps stay gaps; references are optional (when
    /// present, their errors are printed).
    Compensate {
        /// The model blob (Model-H or Model-P).
        #[arg(long)]
        model: PathBuf,
        /// The record: `t_s`, `T_amb_C`, `dl1_pm..dl3_pm` (references and `split` optional).
        #[arg(long)]
        data: PathBuf,
        /// Output CSV: `t_s`, each measurand and its `_band95`, `flags` (bits: 1 non-finite, 2
        /// out of the calibration envelope, 4 weak RBF support) and `flag_names`.
        #[arg(long)]
        out: PathBuf,
        /// Run the device's f32 arithmetic instead of the host's f64.
        #[arg(long)]
        f32: bool,
        /// Absolute time of the record's `t_s = 0` (UTC, `YYYY-MM-DDThh:mm:ss[.fff]`), when the
        /// record does not say: the band's lead is then absolute time since calibration.
        #[arg(long)]
        start: Option<String>,
        /// Compensate even when the shifts look like another unit than pm (against the
        /// model's calibration envelope).
        #[arg(long)]
        trust_units: bool,
        /// Print the summary as JSON on stdout.
        #[arg(long)]
        json: bool,
    },
    /// Talk to a running device: `device status` prints its audit trail (active model, its
    /// signature's serial and key id, updates accepted and refused by reason) and counters.
    Device(stream::DeviceArgs),
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    let cli = Cli::parse();
    match cli.cmd {
        Cmd::Simulate { scenario, out, json, dump_config, no_ambient, pace, pace_of, steps } => {
            let side = meta_path(&out);
            let mut outputs = vec![out.as_path(), side.as_path()];
            outputs.extend(dump_config.as_deref());
            check_outputs(&outputs, &scenario.config.iter().map(|p| p.as_path()).collect::<Vec<_>>())?;
            let mut cfg = scenario.load()?;
            if no_ambient {
                cfg.ambient.thermometer = false;
            }
            if let Some(f) = pace {
                cfg = cfg.paced(f, pace_of);
            }
            if steps {
                cfg = cfg.steps();
            }
            if pace.is_some() || steps {
                cfg.validate().map_err(|(key, message)| fbg_trainer::TrainerError::Config {
                    origin: "--pace/--pace-of/--steps".into(),
                    key,
                    message,
                })?;
            }
            let s = sim::simulate(&cfg, scenario.seed);
            // The record and its sidecar are one output set: never a new record beside an old
            // sidecar (the oracle and studies read the sidecar as the record's truth).
            let set = fbg_trainer::data::files::OutputSet::beside(&out)?;
            set.stage(&out, |w| s.data.write_csv_to(w))?;
            set.stage_bytes(&side, SimMeta::of(&s).to_json()?.as_bytes())?;
            set.commit()?;
            if let Some(p) = dump_config {
                let text = toml::to_string(&cfg).context("serialising the scenario")?;
                write_bytes_atomically(&p, text.as_bytes())?;
            }
            if json {
                println!("{}", serde_json::to_string_pretty(&s.summary())?);
            } else {
                let o = s.oracle_floor();
                let floor: Vec<String> = o
                    .measurands
                    .iter()
                    .zip(&o.rmse_holdout)
                    .map(|(m, v)| {
                        let digits = if m.kind == fbg_trainer::data::Kind::Temperature { 3 } else { 2 };
                        format!("{} {v:.digits$} {}", m.short_name(), m.unit())
                    })
                    .collect();
                eprintln!(
                    "wrote {} ({} samples, {}; scenario {}, seed {}); per-sample oracle on the hold-out: {}",
                    out.display(),
                    s.data.len(),
                    s.data.shape(),
                    cfg.name,
                    scenario.seed,
                    floor.join(", ")
                );
            }
            Ok(())
        }
        Cmd::Train { data, features, max_centres, out, json, on_error, sign } => {
            let (base, coef) = (baseline_path(&out), export::coefficients_path(&out));
            let meta_file = meta_path(&data);
            let keys = key_files(&sign);
            let mut inputs = vec![data.as_path(), meta_file.as_path()];
            inputs.extend(keys.iter().map(PathBuf::as_path));
            check_outputs(&[&out, &base, &coef], &inputs)?;
            let signer = sign.signer()?;
            let d = Dataset::read_calibration_csv(&data)?;
            let meta = SimMeta::read_for(&data)?;
            let origin = origin_of(&data, meta.as_ref());
            let on_outlier = on_error.parse().map_err(anyhow::Error::msg)?;
            let opts = train_options(features, max_centres, !json)?.with_on_outlier(on_outlier);
            let t = Instant::now();
            let tr = fit::train_source(&d, &data.display().to_string(), &opts, &origin)?;
            let secs = t.elapsed().as_secs_f64();
            let (bh, sig_h) = sign::maybe_sign(export::blob_bytes(&tr.model_h)?, signer.as_ref())?;
            let (bp, sig_p) = sign::maybe_sign(export::blob_bytes(&tr.model_p)?, signer.as_ref())?;
            let (nh, np) = (bh.len(), bp.len());
            let signatures = sig_h.as_ref().map(|h| serde_json::json!({"model_h": h, "model_p": sig_p}));
            // The three files are one output set: replaced together or not at all.
            let set = OutputSet::beside(&out)?;
            set.stage_bytes(&out, &bh)?;
            set.stage_bytes(&base, &bp)?;
            let text = export::coefficients_text(
                &tr.model_p,
                &tr.model_h,
                &tr.core,
                Some(&tr.selection),
                Some(&tr.static_audit),
                signatures.clone(),
                &tr.warnings,
            )?;
            set.stage_bytes(&coef, text.as_bytes())?;
            set.commit()?;
            let s = &tr.selection;
            let chosen = tr.chosen();
            let skipped_rows = fbg_trainer::data::outliers::rows_of(&tr.skipped);
            if json {
                println!(
                    "{}",
                    serde_json::to_string_pretty(&serde_json::json!({
                        "model_h": out, "model_p": base, "coefficients": coef,
                        "model_h_bytes": nh, "model_p_bytes": np, "train_seconds": secs,
                        "chosen": chosen, "cv_rmse_p": s.cv_rmse_p, "cv_rmse_h": s.cv_rmse_h,
                        "grid_points": s.rows.len(), "signatures": signatures,
                        "static_fidelity": export::static_fidelity_json(&tr.model_h, &tr.static_audit),
                        "outliers_skipped": {
                            "rows": skipped_rows.len(),
                            "lines": skipped_rows.iter().map(|&r| fbg_trainer::data::outliers::csv_line(&d, r)).collect::<Vec<_>>(),
                            "cells": tr.skipped,
                        },
                        "warnings": tr.warnings,
                    }))?
                );
            } else {
                eprintln!(
                    "trained in {secs:.1} s on {} calibration samples ({} grid points); chose {}",
                    s.n_cal,
                    s.rows.len(),
                    chosen.text()
                );
                let outs = fbg_trainer::data::Measurand::of_dims(&tr.model_h.dims);
                let dg = |m: &fbg_trainer::data::Measurand| {
                    if m.kind == fbg_trainer::data::Kind::Temperature {
                        3
                    } else {
                        2
                    }
                };
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
                for w in &tr.warnings {
                    eprintln!("warning: {w}");
                }
                eprintln!("wrote {} ({nh} B), {} ({np} B), {}", out.display(), base.display(), coef.display());
                if let (Some(h), Some(p)) = (&sig_h, &sig_p) {
                    eprintln!(
                        "signed with key {}: Model-H serial {}, Model-P serial {}{}",
                        h.key_id,
                        h.serial,
                        p.serial,
                        if h.allow_rollback { " (allow-rollback flag set)" } else { "" }
                    );
                }
            }
            Ok(())
        }
        Cmd::Evaluate { data, model, baseline, metrics, quick, json } => {
            let base = baseline.unwrap_or_else(|| baseline_path(&model));
            let out = metrics.unwrap_or_else(|| export::metrics_path(&model));
            check_outputs(&[&out], &[&data, &meta_path(&data), &model, &base])?;
            let meta = SimMeta::read_for(&data)?;
            // Without a sidecar no quick study needs the whole record: it is streamed (two
            // passes, memory independent of its length).
            let streamed = quick && meta.is_none();
            let d = if streamed { Dataset::read_csv_header(&data)? } else { Dataset::read_csv(&data)? };
            let h = export::read_blob(&model)?;
            d.inputs_for(&h.dims, &data.display().to_string(), "evaluate")?;
            if !base.exists() {
                bail!(
                    "{}: Model-P baseline not found (train writes it beside the model; or pass --baseline)",
                    base.display()
                );
            }
            let p = export::read_blob(&base)?;
            let studies = if quick {
                Studies { pace: true, ..Studies::NONE }
            } else {
                Studies { recalibration: false, ..Studies::ALL }
            };
            let log = |s: &str| {
                if !json {
                    eprintln!("{s}");
                }
            };
            let mut m = if streamed {
                fbg_trainer::eval::streamed::evaluate_quick(&p, &h, &data, !json)?
            } else {
                studies::evaluate_models(&p, &h, &d, meta.as_ref(), studies, !json, &log)?
            };
            let train_warnings = fbg_trainer::eval::warnings::from_coefficients(&export::coefficients_path(&model));
            m.warnings = fbg_trainer::eval::warnings::merge(train_warnings, std::mem::take(&mut m.warnings));
            write_metrics(&out, &m)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&m)?);
            } else {
                print_tables(&m);
                eprintln!("wrote {}", out.display());
            }
            Ok(())
        }
        Cmd::Recalibrate { model, data, batch_hours, out, allow_worse, json, sign } => {
            recalibrate::run(&model, &data, batch_hours, &out, allow_worse, json, &sign)
        }
        Cmd::Inspect { model, pubkey, json } => inspect::run(&model, pubkey.as_deref(), json),
        Cmd::Sign { model, out, sign: sign_args, json } => {
            if sign_args.sign.is_none() {
                bail!("--sign KEY is required")
            }
            let mut inputs = vec![model.as_path()];
            let keys = key_files(&sign_args);
            inputs.extend(keys.iter().map(PathBuf::as_path));
            check_outputs(&[&out], &inputs)?;
            // Only a blob that decodes is signed: a signature vouches for a valid model.
            export::read_blob(&model)?;
            let bytes = std::fs::read(&model).with_context(|| format!("{}: cannot read", model.display()))?;
            let signer = sign_args.signer()?.context("--sign KEY is required")?;
            let (signed, rec) = signer.sign(&bytes)?;
            write_bytes_atomically(&out, &signed)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&rec)?);
            } else {
                eprintln!(
                    "wrote {} ({} B): key id {}, serial {}{}",
                    out.display(),
                    signed.len(),
                    rec.key_id,
                    rec.serial,
                    rec.rollback_text()
                );
            }
            Ok(())
        }
        Cmd::Keygen { out, json } => {
            let k = sign::keygen(&out)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&k)?);
            } else {
                println!("key id {}", k.key_id);
                eprintln!(
                    "wrote {} (private, mode 0600: keep it offline), {} (public, raw: FBG_TRUSTED_KEYS of the firmware build) and {}",
                    k.files.private.display(),
                    k.files.public.display(),
                    k.files.public_hex.display()
                );
                eprintln!("public key {}", k.public_key);
            }
            Ok(())
        }
        Cmd::Golden { data, model, samples, out } => {
            let files = export::golden_files(&out);
            check_outputs(&files.iter().map(PathBuf::as_path).collect::<Vec<_>>(), &[&data, &model])?;
            let d = Dataset::read_csv(&data)?;
            let h = export::read_blob(&model)?;
            d.inputs_for(&h.dims, &data.display().to_string(), "golden")?;
            let hold = d.holdout_indices();
            let idx: Vec<usize> = hold.into_iter().take(samples).collect();
            let (eh, _) = evaluate_holdout(&h, &d)?;
            let rmse: Vec<f64> = eh.channels.iter().map(|c| c.rmse).collect();
            export::write_golden(&out, &h, &d, &idx, &rmse)?;
            eprintln!("wrote {} golden samples into {}", idx.len(), out.display());
            Ok(())
        }
        Cmd::Report { out, data, model, model_p, metrics, json } => {
            let d = report::InputPaths::in_dir(&out);
            let model_p = model_p.or_else(|| model.as_deref().map(baseline_path)).unwrap_or(d.model_p);
            let paths = report::InputPaths {
                data: data.unwrap_or(d.data),
                model_h: model.clone().unwrap_or(d.model_h),
                model_p,
                metrics: metrics.or_else(|| model.as_deref().map(export::metrics_path)).unwrap_or(d.metrics),
            };
            let meta = meta_path(&paths.data);
            let inputs = [&paths.data, &meta, &paths.model_h, &paths.model_p, &paths.metrics];
            // A missing directory is not made here: the inputs read from it are missing too.
            if out.is_dir() {
                check_outputs(&[&out.join(report::INDEX_HTML)], &inputs.map(PathBuf::as_path))?;
            }
            let o =
                report::build_from(&out, &paths).with_context(|| format!("writing the report in {}", out.display()))?;
            print_report_outcome(&out, &o, json)
        }
        Cmd::Demo { out, scenario, json } => demo::run(&out, &scenario, json),
        Cmd::BenchFit(a) => bench_fit(&a),
        Cmd::Fleet(a) => fleet(&a),
        Cmd::Stream(a) => a.run(),
        Cmd::Compensate { model, data, out, f32, start, trust_units, json } => {
            check_outputs(&[&out], &[&model, &data])?;
            let field = fbg_trainer::compensate::FieldOptions {
                start_unix_s: start.as_deref().map(|s| utc_timestamp(s, "--start")).transpose()?,
                trust_units,
            };
            let precision = if f32 { Precision::F32 } else { Precision::F64 };
            let s = fbg_trainer::compensate::run(&model, &data, &out, precision, field, !json)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                eprintln!("{}", s.text());
            }
            Ok(())
        }
        Cmd::Device(a) => a.run(),
        Cmd::Import {
            format,
            file,
            map,
            refs,
            out,
            cal_until,
            cal_fraction,
            on_error,
            max_skipped,
            model,
            start,
            json,
        } => {
            if !(0.0..=100.0).contains(&max_skipped) {
                bail!("--max-skipped must be a percentage from 0 to 100 (got {max_skipped})");
            }
            let split = match cal_until {
                Some(t) => SplitChoice::Until(t),
                None => SplitChoice::Fraction(cal_fraction.unwrap_or(0.5)),
            };
            let opts = ImportOptions {
                format: format.parse().map_err(anyhow::Error::msg)?,
                input: file,
                map,
                refs,
                split,
                on_error: on_error.parse().map_err(anyhow::Error::msg)?,
                max_skipped: max_skipped / 100.0,
                zero_from: match &model {
                    Some(m) => {
                        let p = export::read_blob(m)?;
                        Some(import::ModelZero {
                            model: m.display().to_string(),
                            lambda_ref_nm: (0..p.dims.gratings()).map(|g| p.field.lambda_ref(g)).collect(),
                        })
                    }
                    None => None,
                },
                start_unix_s: start.as_deref().map(|s| utc_timestamp(s, "--start")).transpose()?,
            };
            let mut inputs = vec![opts.input.as_path()];
            inputs.extend(model.as_deref());
            inputs.extend(opts.map.as_deref());
            inputs.extend(opts.refs.as_deref());
            check_outputs(&[&out], &inputs)?;
            let s = import::import_to_csv(&opts, &out)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                eprintln!("{}", s.text());
            }
            Ok(())
        }
    }
}

/// A UTC timestamp argument in Unix seconds.
fn utc_timestamp(s: &str, flag: &str) -> Result<f64> {
    fbg_trainer::data::import::time_axis::parse_timestamp(s.trim().trim_end_matches('Z'), None)
        .ok_or_else(|| anyhow::anyhow!("{flag}: `{s}` is not a UTC timestamp like 2026-01-05T00:00:00"))
}

fn origin_of(data: &Path, meta: Option<&SimMeta>) -> Origin {
    match meta {
        Some(m) => Origin { scenario: m.scenario.name.clone(), seed: m.seed },
        None => {
            Origin { scenario: data.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(), seed: 0 }
        }
    }
}

fn train_options(features: FeatureChoice, max_centres: usize, progress: bool) -> Result<TrainOptions> {
    let o = features.train_options(max_centres).map_err(|e| anyhow::anyhow!("--features/--max-centres: {e}"))?;
    Ok(o.with_progress(progress))
}

/// The files of a signing key a command reads or updates (the key, its serial state and
/// lock): never an output.
pub(crate) fn key_files(sign: &fbg_trainer::sign::SignArgs) -> Vec<PathBuf> {
    fbg_trainer::sign::key_inputs(sign.options().as_ref())
}

/// `model.fbgm` → `model-p.fbgm`.
fn baseline_path(model: &Path) -> PathBuf {
    let stem = model.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "model".into());
    model.with_file_name(format!("{stem}-p.fbgm"))
}

fn write_metrics(path: &Path, m: &Metrics) -> Result<()> {
    let text = serde_json::to_string_pretty(m)?;
    write_bytes_atomically(path, text.as_bytes())?;
    Ok(())
}

fn print_tables(m: &Metrics) {
    println!("{}", tables::table2(m).text());
    eprintln!("{}", tables::flag_line(m));
    for w in &m.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(a) = &m.ablation {
        println!("{}", tables::table3(a, m).text());
    }
    if let Some(d) = &m.drift_sweep {
        println!("{}", tables::drift(d, m).text());
    }
    if let Some(b) = &m.error_budget {
        println!("{}", tables::budget(b, m).text());
    }
    if let Some(sf) = &m.static_fidelity {
        println!("{}", tables::static_fidelity(sf, m).text());
    }
    if let Some(p) = &m.pace {
        println!("{}", tables::pace(p, m).text());
    }
    if let Some(p) = &m.parity {
        let diffs: Vec<String> = p.max_abs_diff.iter().zip(&m.units).map(|(v, u)| format!("{v:.2e} {u}")).collect();
        let shares: Vec<String> = p.max_diff_over_rmse.iter().map(|v| format!("{:.3} %", 100.0 * v)).collect();
        println!(
            "Parity (f32 device path vs f64, {} hold-out samples): max |Δ| = {} ({} of Model-H RMSE); flag mismatches {}; leverage band gap {:.2e}",
            p.samples,
            diffs.join(", "),
            shares.join(", "),
            p.flag_mismatches,
            p.leverage_band_gap
        );
    }
}

fn bench_fit(a: &fbg_trainer::benchmark::BenchFitArgs) -> Result<()> {
    let b = a.run()?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&b)?);
    } else {
        eprintln!("{}", b.text());
    }
    Ok(())
}

fn fleet(a: &fbg_trainer::fleet::FleetArgs) -> Result<()> {
    if let Some(fbg_trainer::fleet::FleetCommand::Status(s)) = &a.command {
        let r = s.run()?;
        if s.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            eprintln!("{}", r.text(s.all));
        }
        if !r.all_done {
            bail!(
                "{} of {} groups are not done",
                r.groups.len() - r.counts.get("done").copied().unwrap_or(0),
                r.groups.len()
            );
        }
        return Ok(());
    }
    let r = a.run()?;
    if a.json {
        println!("{}", serde_json::to_string_pretty(&r)?);
    } else {
        eprintln!("{}", r.text());
    }
    if r.failed > 0 {
        bail!("{} of {} groups failed (the others were calibrated)", r.failed, r.groups.len());
    }
    Ok(())
}

fn print_report_outcome(out: &Path, o: &report::Outcome, json: bool) -> Result<()> {
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "dir": out, "index": out.join(report::INDEX_HTML), "files": o.files,
                "warnings": o.warnings, "notes": o.notes, "seconds": o.seconds,
            }))?
        );
        return Ok(());
    }
    for n in &o.notes {
        eprintln!("note: {n}");
    }
    for w in &o.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!("wrote {} files in {:.1} s; open {}", o.files.len(), o.seconds, out.join(report::INDEX_HTML).display());
    Ok(())
}
