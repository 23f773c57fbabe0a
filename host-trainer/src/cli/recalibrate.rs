//! `fbg-trainer recalibrate`: recalibrate a model on a short batch, check it on the hold-out
//! channel by channel, write it.

use std::path::Path;

use anyhow::{bail, Result};

use fbg_trainer::data::files::{check_outputs, write_bytes_atomically};
use fbg_trainer::data::Dataset;
use fbg_trainer::eval::score::{channels, evaluate_holdout, units, ModelEval};
use fbg_trainer::export;
use fbg_trainer::fit::recalibrate::{first_hours, keep_old_where_worse, recalibrate, CoreUpdate, Recalibration};
use fbg_trainer::fit::HostParams;
use fbg_trainer::sign::{self, SignArgs};

use crate::baseline_path;

/// A recalibrated model and its hold-out check.
struct CheckedRecal {
    params: HostParams,
    what: Recalibration,
    /// Hold-out of the old model and of the model written (none without hold-out rows).
    before: Option<ModelEval>,
    after: Option<ModelEval>,
    /// Hold-out of the recalibration as fitted, before any channel was put back.
    tried: Option<ModelEval>,
    /// Outputs that kept the old coefficients because the recalibration scored worse.
    kept_old: Vec<usize>,
    /// Outputs written although worse (only with --allow-worse).
    worse: Vec<usize>,
}

/// Recalibrate `old` on `batch` and check it on the hold-out of `d`: unless `allow_worse`, every
/// channel the check scores worse keeps the old coefficients (DESIGN §9).
fn checked_recalibration(old: &HostParams, d: &Dataset, batch: &[usize], allow_worse: bool) -> Result<CheckedRecal> {
    let (mut params, what) = recalibrate(old, d, batch)?;
    if d.holdout_indices().is_empty() {
        return Ok(CheckedRecal {
            params,
            what,
            before: None,
            after: None,
            tried: None,
            kept_old: vec![],
            worse: vec![],
        });
    }
    let before = evaluate_holdout(old, d)?.0;
    let tried = evaluate_holdout(&params, d)?.0;
    let mut after = tried.clone();
    let mut kept_old = vec![];
    if !allow_worse {
        let rmse = |e: &ModelEval| -> Vec<f64> { e.channels.iter().map(|c| c.rmse).collect() };
        kept_old = keep_old_where_worse(&mut params, old, &rmse(&before), &rmse(&after));
        if !kept_old.is_empty() {
            after = evaluate_holdout(&params, d)?.0;
        }
    }
    let worse: Vec<usize> =
        (0..after.channels.len()).filter(|&c| after.channels[c].rmse > before.channels[c].rmse).collect();
    if !allow_worse && !worse.is_empty() {
        bail!(
            "recalibration: {} still scores worse on the hold-out after keeping the old coefficients; nothing written (--allow-worse writes it anyway)",
            channel_list(&channels(&old.dims), &worse)
        );
    }
    Ok(CheckedRecal { params, what, before: Some(before), after: Some(after), tried: Some(tried), kept_old, worse })
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

/// `fbg-trainer recalibrate`.
pub fn run(
    model: &Path,
    data: &Path,
    batch_hours: Option<f64>,
    out: &Path,
    allow_worse: bool,
    json: bool,
    sign_args: &SignArgs,
) -> Result<()> {
    let (base, new_base_path) = (baseline_path(model), baseline_path(out));
    let mut inputs = vec![model, data, base.as_path()];
    inputs.extend(sign_args.sign.as_deref());
    check_outputs(&[out, &new_base_path], &inputs)?;
    let signer = sign_args.signer()?;
    let d = Dataset::read_csv(data)?;
    let old = export::read_blob(model)?;
    d.inputs_for(&old.dims, &data.display().to_string(), "recalibrate")?;
    let (chs, us) = (channels(&old.dims), units(&old.dims));
    let batch = match batch_hours {
        Some(h) if h > 0.0 => first_hours(&d, h),
        Some(h) => bail!("--batch-hours must be positive (got {h})"),
        None => d.cal_indices(),
    };
    let h = checked_recalibration(&old, &d, &batch, allow_worse)?;
    let p = if base.exists() {
        Some(checked_recalibration(&export::read_blob(&base)?, &d, &batch, allow_worse)?)
    } else {
        None
    };
    let (bytes, signature) = sign::maybe_sign(export::blob_bytes(&h.params)?, signer.as_ref())?;
    write_bytes_atomically(out, &bytes)?;
    let n = bytes.len();
    let mut base_signature = None;
    let new_base = match &p {
        Some(p) => {
            let (b, s) = sign::maybe_sign(export::blob_bytes(&p.params)?, signer.as_ref())?;
            write_bytes_atomically(&new_base_path, &b)?;
            base_signature = s;
            Some(new_base_path.clone())
        }
        None => None,
    };
    let names = |cs: &[usize]| cs.iter().map(|&c| chs[c].clone()).collect::<Vec<_>>();
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "model": out, "baseline": new_base, "bytes": n, "recalibration": h.what,
                "holdout_before": h.before, "holdout_after": h.after,
                "kept_old_channels": names(&h.kept_old), "worse_channels_written": names(&h.worse),
                "baseline_kept_old_channels": p.as_ref().map(|p| names(&p.kept_old)),
                "signature": signature, "baseline_signature": base_signature,
            }))?
        );
        return Ok(());
    }
    let w = &h.what;
    eprintln!(
        "recalibrated {} on {} batch samples; residual weights {}",
        model.display(),
        w.n_batch,
        if w.w_updated { "updated" } else { "kept (the batch did not support a change)" }
    );
    for c in 0..chs.len() {
        let (a, b) = w.offset_gain[c];
        let detail = match w.core_update[c] {
            CoreUpdate::Offset => format!(" (offset {a:+.4} {})", us[c]),
            CoreUpdate::OffsetGain => format!(" (offset {a:+.4} {}, gain {b:.4})", us[c]),
            _ => String::new(),
        };
        let check = match (&h.before, &h.after, &h.tried) {
            (Some(bf), _, Some(tr)) if h.kept_old.contains(&c) => format!(
                "; hold-out RMSE {:.4} -> {:.4} is worse, so the old coefficients are kept (RMSE {:.4})",
                bf.channels[c].rmse, tr.channels[c].rmse, bf.channels[c].rmse
            ),
            (Some(bf), Some(af), _) if h.worse.contains(&c) => format!(
                "; hold-out RMSE {:.4} -> {:.4} (WORSE, written because of --allow-worse)",
                bf.channels[c].rmse, af.channels[c].rmse
            ),
            (Some(bf), Some(af), _) => {
                format!("; hold-out RMSE {:.4} -> {:.4}", bf.channels[c].rmse, af.channels[c].rmse)
            }
            _ => String::new(),
        };
        eprintln!("  {:>6} [{}]: {}{detail}{check}", chs[c], us[c], w.core_update[c].text());
    }
    if h.before.is_none() {
        eprintln!("  (no hold-out rows in {}: nothing to check the recalibration against)", data.display());
    } else if !h.kept_old.is_empty() {
        eprintln!(
            "kept the old model's {} (--allow-worse writes the recalibrated ones)",
            channel_list(&chs, &h.kept_old)
        );
    }
    if let Some(p) = &p {
        if !p.kept_old.is_empty() {
            eprintln!("Model-P baseline: kept the old {} (worse on the hold-out)", channel_list(&chs, &p.kept_old));
        } else if !p.worse.is_empty() {
            eprintln!(
                "Model-P baseline: {} WORSE on the hold-out, written because of --allow-worse",
                channel_list(&chs, &p.worse)
            );
        }
    }
    eprintln!(
        "wrote {} ({n} B){}",
        out.display(),
        new_base.map(|p| format!(" and {}", p.display())).unwrap_or_default()
    );
    if let Some(s) = &signature {
        eprintln!(
            "signed with key {}: serial {}{}",
            s.key_id,
            s.serial,
            base_signature.as_ref().map(|b| format!(" (Model-P baseline: serial {})", b.serial)).unwrap_or_default()
        );
    }
    Ok(())
}
