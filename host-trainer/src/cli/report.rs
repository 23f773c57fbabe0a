//! `fbg-trainer report`: regenerate the audit report from the files a demo (or train and
//! evaluate) left.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};

use fbg_trainer::data::files::check_outputs;
use fbg_trainer::export;
use fbg_trainer::report;
use fbg_trainer::sim::meta::meta_path;

/// Regenerate the audit report (figures, tables, coefficient tables, index.html) in DIR from
/// the data.csv (+ data.meta.json), model.fbgm, model-p.fbgm and model.metrics.json there, or from
/// the files named by --data, --model, --model-p and --metrics.
#[derive(clap::Args)]
pub struct ReportArgs {
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
}

impl ReportArgs {
    pub fn run(self) -> Result<()> {
        let out = &self.out;
        let d = report::InputPaths::in_dir(out);
        let model = self.model;
        let model_p = self.model_p.or_else(|| model.as_deref().map(export::baseline_path)).unwrap_or(d.model_p);
        let paths = report::InputPaths {
            data: self.data.unwrap_or(d.data),
            model_h: model.clone().unwrap_or(d.model_h),
            model_p,
            metrics: self.metrics.or_else(|| model.as_deref().map(export::metrics_path)).unwrap_or(d.metrics),
        };
        let meta = meta_path(&paths.data);
        let side = fbg_trainer::data::record_meta::sidecar_path(&paths.data);
        let inputs = [&paths.data, &meta, &side, &paths.model_h, &paths.model_p, &paths.metrics];
        // A missing directory is not made here: the inputs read from it are missing too.
        if out.is_dir() {
            check_outputs(&[&out.join(report::INDEX_HTML)], &inputs.map(PathBuf::as_path))?;
        }
        let o = report::build_from(out, &paths).with_context(|| format!("writing the report in {}", out.display()))?;
        print_outcome(out, &o, self.json)
    }
}

fn print_outcome(out: &Path, o: &report::Outcome, json: bool) -> Result<()> {
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
