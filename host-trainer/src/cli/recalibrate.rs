//! `fbg-trainer recalibrate`: recalibrate a model on a short batch (each output's update kept
//! or reverted by the batch's own check), write it, and report the hold-out before and after
//! as an independent check that can come out worse.

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};

use fbg_shared::layout::Dims;
use fbg_trainer::data::files::{check_outputs, OutputSet};
use fbg_trainer::data::Dataset;
use fbg_trainer::error::ShortNumber;
use fbg_trainer::eval::score::{channels, evaluate_holdout, units, ModelEval};
use fbg_trainer::export;
use fbg_trainer::fit::recalibrate::{first_hours, recalibrate_with, CoreUpdate, Recalibration, Verdict};
use fbg_trainer::fit::HostParams;
use fbg_trainer::sign::{self, SignatureRecord};
use fbg_trainer::warning::Warning;

use crate::args::SignArgs;

/// A recalibrated model and its hold-out report.
struct CheckedRecal {
    params: HostParams,
    what: Recalibration,
    /// Hold-out of the old model and of the model written (none without hold-out rows). They
    /// play no part in what is written.
    before: Option<ModelEval>,
    after: Option<ModelEval>,
    /// Outputs the hold-out scores worse after the recalibration than before.
    worse_on_holdout: Vec<usize>,
}

/// Recalibrate `old` on `batch` (the decision uses the batch only), then score the old and the
/// new model on the hold-out of `d`, if it has one.
fn checked_recalibration(old: &HostParams, d: &Dataset, batch: &[usize], allow_worse: bool) -> Result<CheckedRecal> {
    let (params, what) = recalibrate_with(old, d, batch, allow_worse)?;
    if d.holdout_indices().is_empty() {
        return Ok(CheckedRecal { params, what, before: None, after: None, worse_on_holdout: vec![] });
    }
    let before = evaluate_holdout(old, d)?.0;
    let after = evaluate_holdout(&params, d)?.0;
    let worse_on_holdout =
        (0..after.channels.len()).filter(|&c| after.channels[c].rmse > before.channels[c].rmse).collect();
    Ok(CheckedRecal { params, what, before: Some(before), after: Some(after), worse_on_holdout })
}

/// The warnings of one recalibration (`model`: "Model-H", or "Model-P baseline" whose codes
/// start with `baseline_`).
fn warnings(r: &CheckedRecal, dims: &Dims, model: &str, data: &Path) -> Vec<Warning> {
    let prefix = if model.starts_with("Model-P") { "baseline_" } else { "" };
    let (chs, us) = (channels(dims), units(dims));
    let suffix: Vec<String> = dims.outputs().iter().map(|o| o.quantity.column_unit().to_lowercase()).collect();
    let w = &r.what;
    let mut out = vec![];
    for (c, v) in w.verdict.iter().enumerate() {
        if *v == Verdict::WorseWritten {
            out.push(
                Warning::new(
                    format!("{prefix}recalibration_worse_on_batch_written"),
                    format!(
                        "{model}: {}'s update does not predict the batch's last 30 % better than the old model (RMSE {:.4} -> {:.4} {}); written because of --allow-worse",
                        chs[c], w.check_rmse_old[c], w.check_rmse_update[c], us[c]
                    ),
                )
                .on_channel(&chs[c])
                .with(format!("check_rmse_old_{}", suffix[c]), w.check_rmse_old[c])
                .with(format!("check_rmse_update_{}", suffix[c]), w.check_rmse_update[c]),
            );
        }
    }
    if let (Some(bf), Some(af)) = (&r.before, &r.after) {
        for &c in &r.worse_on_holdout {
            let (b, a) = (bf.channels[c].rmse, af.channels[c].rmse);
            let why = if w.verdict[c].changes() {
                format!(
                    "although the batch's own check favoured the update (RMSE on its last 30 % {:.4} -> {:.4} {}): the batch does not represent the hold-out (too short, or the installation or its reference differs)",
                    w.check_rmse_old[c], w.check_rmse_update[c], us[c]
                )
            } else {
                "with its old coefficients kept".to_string()
            };
            out.push(
                Warning::new(
                    format!("{prefix}recalibration_worse_on_holdout"),
                    format!(
                        "{model}: {} is WORSE on the hold-out of {} after recalibration (RMSE {b:.4} -> {a:.4} {}), {why}; the model written keeps the batch's decision, check it before deploying",
                        chs[c],
                        data.display(),
                        us[c]
                    ),
                )
                .on_channel(&chs[c])
                .with(format!("holdout_rmse_before_{}", suffix[c]), b)
                .with(format!("holdout_rmse_after_{}", suffix[c]), a)
                .with(format!("check_rmse_old_{}", suffix[c]), w.check_rmse_old[c])
                .with(format!("check_rmse_update_{}", suffix[c]), w.check_rmse_update[c]),
            );
        }
    }
    out
}

/// "T and p", "strain": the outputs `cs` of a model whose outputs are `all`.
fn channel_list(all: &[String], cs: &[usize]) -> String {
    let names: Vec<&str> = cs.iter().map(|&c| all[c].as_str()).collect();
    match names.len() {
        0 => "no channel".into(),
        1 => names[0].into(),
        n => format!("{} and {}", names[..n - 1].join(", "), names[n - 1]),
    }
}

/// Field recalibration: refit the core's offset/gain and the residual weights (centres
/// kept) of an existing model on a short batch (the calibration rows of DATA, or its first
/// --batch-hours). Only the batch decides: each channel's update is fitted on its first
/// 70 % and kept only if it predicts the last 30 % better than the old model (then refitted
/// on the whole batch); otherwise the channel keeps the old coefficients (see
/// --allow-worse). The hold-out RMSE before and after is reported separately, plays no part
/// in the decision, and can come out worse: a warning says so.
#[derive(clap::Args)]
pub struct RecalibrateArgs {
    /// The model to recalibrate (its Model-P baseline `<stem>-p.fbgm` is recalibrated too
    /// when present).
    #[arg(long)]
    model: PathBuf,
    /// Dataset CSV from the installation: its calibration rows are the batch, its hold-out
    /// rows an independent report before and after (never used to decide).
    #[arg(long)]
    data: PathBuf,
    /// Use only the first H hours of the calibration rows as the batch.
    #[arg(long, allow_negative_numbers = true)]
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
}

/// Both recalibrations, their warnings and what was written.
struct Outcome {
    model_h: CheckedRecal,
    /// Model-P's, when the baseline was there, with its dimensions.
    model_p: Option<(CheckedRecal, Dims)>,
    warnings: Vec<Warning>,
    bytes: usize,
    new_base: Option<PathBuf>,
    signature: Option<SignatureRecord>,
    base_signature: Option<SignatureRecord>,
}

impl RecalibrateArgs {
    pub fn run(self) -> Result<()> {
        // The flag's range before any file is read.
        if let Some(h) = self.batch_hours.filter(|h| h.is_nan() || *h <= 0.0) {
            bail!("--batch-hours must be positive (got {})", ShortNumber(h));
        }
        let (model, data, out) = (self.model.as_path(), self.data.as_path(), self.out.as_path());
        let (base, new_base_path) = (export::baseline_path(model), export::baseline_path(out));
        let keys = self.sign.key_files();
        let side = fbg_trainer::data::record_meta::sidecar_path(data);
        let mut inputs = vec![model, data, side.as_path(), base.as_path()];
        inputs.extend(keys.iter().map(PathBuf::as_path));
        check_outputs(&[out, &new_base_path], &inputs)?;
        let signer = self.sign.signer()?;
        let d = Dataset::read_csv(data)?;
        let old = export::read_blob(model)?;
        d.inputs_for(&old.dims, &data.display().to_string(), "recalibrate")?;
        let batch = match self.batch_hours {
            Some(h) => first_hours(&d, h),
            None => d.cal_indices(),
        };
        let h = checked_recalibration(&old, &d, &batch, self.allow_worse)?;
        let p = if base.exists() {
            let old_p = export::read_blob(&base)?;
            let p = checked_recalibration(&old_p, &d, &batch, self.allow_worse)?;
            Some((p, old_p.dims))
        } else {
            None
        };
        let mut warns = warnings(&h, &old.dims, "Model-H", data);
        if let Some((p, dims)) = &p {
            warns.extend(warnings(p, dims, "Model-P baseline", data));
        }
        if h.before.is_none() {
            warns.push(Warning::new(
                "recalibration_no_holdout",
                format!(
                    "no hold-out rows in {}: nothing independent of the batch checks the recalibration",
                    data.display()
                ),
            ));
        }
        let (bytes, signature) = sign::maybe_sign(export::blob_bytes(&h.params)?, signer.as_ref())?;
        // Model-H and its baseline are one output set: replaced together or not at all.
        let set = OutputSet::beside(out)?;
        set.stage_bytes(out, &bytes)?;
        let mut base_signature = None;
        let new_base = match &p {
            Some((p, _)) => {
                let (b, s) = sign::maybe_sign(export::blob_bytes(&p.params)?, signer.as_ref())?;
                set.stage_bytes(&new_base_path, &b)?;
                base_signature = s;
                Some(new_base_path.clone())
            }
            None => None,
        };
        set.commit()?;
        let o = Outcome {
            model_h: h,
            model_p: p,
            warnings: warns,
            bytes: bytes.len(),
            new_base,
            signature,
            base_signature,
        };
        let chs = channels(&old.dims);
        if self.json {
            println!("{}", serde_json::to_string_pretty(&self.summary_json(&o, &chs))?);
        } else {
            self.print_summary(&o, &chs, &units(&old.dims));
        }
        Ok(())
    }

    fn summary_json(&self, o: &Outcome, chs: &[String]) -> serde_json::Value {
        let h = &o.model_h;
        let names = |cs: &[usize]| cs.iter().map(|&c| chs[c].clone()).collect::<Vec<_>>();
        let with = |r: &CheckedRecal, v: &[Verdict]| {
            names(&(0..chs.len()).filter(|&c| v.contains(&r.what.verdict[c])).collect::<Vec<_>>())
        };
        let p = o.model_p.as_ref().map(|(p, _)| p);
        serde_json::json!({
            "model": self.out, "baseline": o.new_base, "bytes": o.bytes, "recalibration": h.what,
            "holdout_before": h.before, "holdout_after": h.after,
            "kept_old_channels": with(h, &[Verdict::Reverted]),
            "worse_channels_written": with(h, &[Verdict::WorseWritten]),
            "worse_on_holdout_channels": names(&h.worse_on_holdout),
            "baseline_recalibration": p.map(|p| &p.what),
            "baseline_holdout_before": p.and_then(|p| p.before.as_ref()),
            "baseline_holdout_after": p.and_then(|p| p.after.as_ref()),
            "baseline_kept_old_channels": p.map(|p| with(p, &[Verdict::Reverted])),
            "warnings": o.warnings,
            "signature": o.signature, "baseline_signature": o.base_signature,
        })
    }

    fn print_summary(&self, o: &Outcome, chs: &[String], us: &[String]) {
        let h = &o.model_h;
        let w = &h.what;
        eprintln!(
            "recalibrated {} on {} batch samples (updates fitted on the first {}, checked on the last {}); residual weights {}",
            self.model.display(),
            w.n_batch,
            w.n_fit,
            w.n_check,
            if w.w_updated { "updated" } else { "kept (the batch did not support a change)" }
        );
        for c in 0..chs.len() {
            eprintln!("  {:>6} [{}]: {}", chs[c], us[c], channel_line(h, c, &us[c]));
        }
        let reverted = (0..chs.len()).filter(|&c| w.verdict[c] == Verdict::Reverted).collect::<Vec<_>>();
        if !reverted.is_empty() {
            eprintln!(
                "kept the old model's {} (the batch's check scored the update no better; --allow-worse writes it)",
                channel_list(chs, &reverted)
            );
        }
        if let Some((p, dims)) = &o.model_p {
            let v = &p.what.verdict;
            let reverted = (0..v.len()).filter(|&c| v[c] == Verdict::Reverted).collect::<Vec<_>>();
            if !reverted.is_empty() {
                eprintln!(
                    "Model-P baseline: kept the old {} (no better on the batch's check)",
                    channel_list(&channels(dims), &reverted)
                );
            }
        }
        for warning in &o.warnings {
            eprintln!("warning: {warning}");
        }
        eprintln!(
            "wrote {} ({} B){}",
            self.out.display(),
            o.bytes,
            o.new_base.as_ref().map(|p| format!(" and {}", p.display())).unwrap_or_default()
        );
        if let Some(s) = &o.signature {
            eprintln!(
                "signed with key {}: serial {}{}",
                s.key_id,
                s.serial,
                o.base_signature
                    .as_ref()
                    .map(|b| format!(" (Model-P baseline: serial {})", b.serial))
                    .unwrap_or_default()
            );
        }
    }
}

/// Output `c`'s line of the text summary (after its name and unit `unit`): the update, the
/// verdict, the batch's check and the hold-out before and after.
fn channel_line(h: &CheckedRecal, c: usize, unit: &str) -> String {
    let w = &h.what;
    let (a, b) = w.offset_gain[c];
    let detail = match w.core_update[c] {
        CoreUpdate::Offset => format!(" (offset {a:+.4} {unit})"),
        CoreUpdate::OffsetGain => format!(" (offset {a:+.4} {unit}, gain {b:.4})"),
        _ => String::new(),
    };
    let what = if w.verdict[c].changes() { format!("{}{detail}, ", w.core_update[c].text()) } else { String::new() };
    let check = match w.verdict[c] {
        Verdict::NoReference => String::new(),
        Verdict::Unchanged => format!(" (RMSE {:.4})", w.check_rmse_old[c]),
        _ => format!(" (RMSE {:.4} -> {:.4})", w.check_rmse_old[c], w.check_rmse_update[c]),
    };
    let holdout = match (&h.before, &h.after) {
        (Some(bf), Some(af)) => format!(
            "; hold-out RMSE {:.4} -> {:.4}{}",
            bf.channels[c].rmse,
            af.channels[c].rmse,
            if h.worse_on_holdout.contains(&c) { " (WORSE)" } else { "" }
        ),
        _ => String::new(),
    };
    format!("{what}{}{check}{holdout}", w.verdict[c].text())
}
