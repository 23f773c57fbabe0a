//! `fbg-trainer evaluate`: score a model and its baseline on a record's hold-out, run the
//! studies, write `metrics.json` and print the tables.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};

use fbg_trainer::data::files::{check_outputs, write_bytes_atomically};
use fbg_trainer::data::Dataset;
use fbg_trainer::eval::metrics::Metrics;
use fbg_trainer::eval::studies::{self, Studies};
use fbg_trainer::eval::{streamed, tables, warnings};
use fbg_trainer::export;
use fbg_trainer::sim::meta::{meta_path, SimMeta};

/// Evaluate models on the hold-out of a CSV: Table 2 and Table 3 (and, for simulated data
/// with a `.meta.json`, the per-sample oracle, drift sweep and error budget); writes `<model stem>.metrics.json`.
#[derive(clap::Args)]
pub struct EvaluateArgs {
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
    #[command(flatten)]
    trust: crate::compensate::TrustArgs,
}

impl EvaluateArgs {
    pub fn run(self) -> Result<()> {
        let (data, model, json) = (&self.data, &self.model, self.json);
        let base = self.baseline.clone().unwrap_or_else(|| export::baseline_path(model));
        let out = self.metrics.clone().unwrap_or_else(|| export::metrics_path(model));
        let meta_file = meta_path(data);
        let side = fbg_trainer::data::record_meta::sidecar_path(data);
        let inputs: Vec<&Path> =
            [data.as_path(), &meta_file, &side, model, &base].into_iter().chain(self.trust.inputs()).collect();
        check_outputs(&[&out], &inputs)?;
        let meta = SimMeta::read_for(data)?;
        // Without a sidecar no quick study needs the whole record: it is streamed (two
        // passes, memory independent of its length).
        let streamed = self.quick && meta.is_none();
        let d = if streamed { Dataset::read_csv_header(data)? } else { Dataset::read_csv(data)? };
        let h = export::read_blob(model)?;
        d.inputs_for(&h.dims, &data.display().to_string(), "evaluate")?;
        if !base.exists() {
            bail!(
                "{}: Model-P baseline not found (train writes it beside the model; or pass --baseline)",
                base.display()
            );
        }
        let p = export::read_blob(&base)?;
        self.trust.check(&[model, &base])?;
        let studies = if self.quick {
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
            streamed::evaluate_quick(&p, &h, data, !json)?
        } else {
            studies::evaluate_models(&p, &h, &d, meta.as_ref(), studies, !json, &log)?
        };
        let train_warnings = warnings::from_coefficients(&export::coefficients_path(model));
        m.warnings = warnings::merge(train_warnings, std::mem::take(&mut m.warnings));
        write_metrics(&out, &m)?;
        if json {
            println!("{}", serde_json::to_string_pretty(&m)?);
        } else {
            print_tables(&m);
            eprintln!("wrote {}", out.display());
        }
        Ok(())
    }
}

/// `metrics.json`, atomically.
pub fn write_metrics(path: &Path, m: &Metrics) -> Result<()> {
    let text = serde_json::to_string_pretty(m)?;
    write_bytes_atomically(path, text.as_bytes())?;
    Ok(())
}

/// The tables of `m` on stdout, the flags line and warnings on stderr.
pub fn print_tables(m: &Metrics) {
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
        if !p.glitch.is_empty() {
            println!("{}", tables::glitch(p).text());
        }
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
