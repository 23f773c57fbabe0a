//! Field recalibration: on a changed installation a short batch recovers most of a
//! full recalibration's gain for strain, and a batch with no evidence of change leaves the model
//! alone. Only the batch decides what is kept (its last 30 % checks what its first 70 % fitted);
//! the hold-out is an independent report that can come out worse, and then says so.

use std::path::{Path, PathBuf};

use fbg_trainer::eval::score::evaluate_holdout;
use fbg_trainer::eval::studies::recalibration;
use fbg_trainer::export;
use fbg_trainer::fit::recalibrate::{first_hours, recalibrate, CoreUpdate, Verdict};
use fbg_trainer::fit::{train, Config, Origin, TrainOptions};
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;

use crate::common;
use common::{bin, run, short_csv};

fn cfg() -> Config {
    Config {
        feature_set: fbg_shared::FeatureSet::HysteresisAware,
        dead_band_pm: 4.0,
        k: 32,
        sigma_mult: 2.0,
        alpha_rel: 1e-5,
        cross_terms: true,
    }
}

#[test]
fn a_day_of_data_recovers_most_of_a_full_recalibration_for_strain() {
    let scen = Preset::Paper.config();
    let old = train(&simulate(&scen, 7).data, &TrainOptions::fixed(&cfg()), &Origin::default()).unwrap();
    let r = recalibration(&scen, &old.model_h, &old.model_p, 7, 8, 24.0, &cfg()).unwrap();
    // The changed installation hurts the old model's strain (new dispersion and drift) ...
    assert!(r.h_old[1] > 1.5 * r.h_full[1], "{:?} vs {:?}", r.h_old, r.h_full);
    // ... and 24 h of new data recover most of what a full recalibration would.
    assert!(r.recovered_fraction_h[1] > 0.8, "{:?}", r.recovered_fraction_h);
    assert!(r.h_short[1] < r.h_old[1]);
}

#[test]
fn recalibrating_on_the_same_installation_changes_little() {
    let s = simulate(&Preset::Paper.config(), 7);
    let old = train(&s.data, &TrainOptions::fixed(&cfg()), &Origin::default()).unwrap();
    let batch = first_hours(&s.data, 24.0);
    let (new, what) = recalibrate(&old.model_h, &s.data, &batch).unwrap();
    let (before, _) = evaluate_holdout(&old.model_h, &s.data).unwrap();
    let (after, _) = evaluate_holdout(&new, &s.data).unwrap();
    for c in 0..3 {
        assert!(
            after.channels[c].rmse < 1.15 * before.channels[c].rmse,
            "channel {c}: {} -> {}",
            before.channels[c].rmse,
            after.channels[c].rmse
        );
        let (_, gain) = what.offset_gain[c];
        assert!((gain - 1.0).abs() < 0.1, "channel {c}: gain {gain}");
    }
    // The band never narrows.
    for c in 0..3 {
        assert!(new.resid_var[c] >= old.model_h.resid_var[c]);
    }
    assert_eq!(what.n_batch, batch.len());
    assert_eq!((what.n_fit, what.n_check), (batch.len() * 7 / 10, batch.len() - batch.len() * 7 / 10));
    // Every output whose coefficients change earned it on the batch's last 30 %; the others
    // keep the old core.
    for c in 0..3 {
        let v = what.verdict[c];
        if v.changes() {
            assert_eq!(v, Verdict::Updated);
            assert!(what.check_rmse_update[c] < what.check_rmse_old[c], "channel {c}: {what:?}");
        } else {
            assert_eq!(what.core_update[c], CoreUpdate::Keep, "channel {c}: {what:?}");
            assert_eq!(new.poly[c], old.model_h.poly[c], "channel {c}");
        }
    }
}

#[test]
fn a_tiny_batch_is_refused() {
    let s = simulate(&Preset::Paper.config(), 7);
    let old = train(&s.data, &TrainOptions::fixed(&cfg()), &Origin::default()).unwrap();
    let e = recalibrate(&old.model_h, &s.data, &[0, 1, 2, 3, 4]).unwrap_err().to_string();
    assert!(e.contains("at least 20"), "{e}");
}

/// `src` with `delta` added to the reference temperature `T_C` of the rows whose `split` is one
/// of `splits`, and without the rows whose split is in `drop`, as `dst`.
fn edit_csv(src: &Path, dst: &Path, splits: &[&str], delta: f64, drop: &[&str]) -> PathBuf {
    let text = common::read_csv_body(src);
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let (t, split) = (cols.iter().position(|&c| c == "T_C").unwrap(), cols.iter().position(|&c| c == "split").unwrap());
    let mut out = format!("{header}\n");
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        if drop.contains(&cells[split].as_str()) {
            continue;
        }
        if splits.contains(&cells[split].as_str()) {
            cells[t] = format!("{:.6}", cells[t].parse::<f64>().unwrap() + delta);
        }
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    std::fs::write(dst, out).unwrap();
    dst.to_path_buf()
}

/// A model trained on a short record, and that record: (model, record).
fn trained(dir: &Path) -> (PathBuf, PathBuf) {
    let csv = short_csv(dir);
    let model = dir.join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    (model, csv)
}

/// `recalibrate --json` of `model` on `data` into `out`: the summary.
fn recal_json(model: &Path, data: &Path, out: &Path) -> serde_json::Value {
    let (ok, text, err) =
        run(bin().args(["recalibrate", "--json", "--model"]).arg(model).arg("--data").arg(data).arg("--out").arg(out));
    assert!(ok, "{err}");
    serde_json::from_str(&text).unwrap()
}

fn holdout_rmse(j: &serde_json::Value, key: &str, c: usize) -> f64 {
    j[key]["channels"][c]["rmse"].as_f64().unwrap()
}

/// A reference thermometer that read 1 °C high during the recalibration batch: the batch (its
/// last 30 % too) says T moved by +1 °C and the update is kept, the hold-out (read by a good
/// thermometer) says it did not. The summary reports the worse hold-out and says so, in text
/// and in `--json` as a warning.
#[test]
fn recalibrate_can_report_a_worse_holdout_and_says_so() {
    let d = tempfile::tempdir().unwrap();
    let (model, csv) = trained(d.path());
    let biased = edit_csv(&csv, &d.path().join("biased.csv"), &["cal"], 1.0, &[]);
    let out = d.path().join("r.fbgm");
    let j = recal_json(&model, &biased, &out);
    assert!(out.is_file() && d.path().join("r-p.fbgm").is_file());
    // T (output 0): the batch's check favoured the update (fitted on the first 70 %) ...
    let r = &j["recalibration"];
    assert_eq!(r["verdict"][0], "updated", "{r}");
    let (check_old, check_new) =
        (r["check_rmse_old"][0].as_f64().unwrap(), r["check_rmse_update"][0].as_f64().unwrap());
    assert!(check_new < 0.5 * check_old, "batch check {check_old} -> {check_new}");
    // ... the hold-out scores it clearly worse, and the written model is the update.
    let (before, after) = (holdout_rmse(&j, "holdout_before", 0), holdout_rmse(&j, "holdout_after", 0));
    assert!(after > before + 0.5, "hold-out T RMSE {before} -> {after}");
    assert_eq!(j["worse_on_holdout_channels"], serde_json::json!(["T"]), "{j}");
    let warnings = j["warnings"].as_array().unwrap();
    let w = warnings
        .iter()
        .find(|w| w["code"] == "recalibration_worse_on_holdout")
        .unwrap_or_else(|| panic!("no worse-hold-out warning: {warnings:?}"));
    assert_eq!(w["channel"], "T");
    assert_eq!(w["numbers"]["holdout_rmse_before_c"].as_f64().unwrap(), before);
    assert_eq!(w["numbers"]["holdout_rmse_after_c"].as_f64().unwrap(), after);
    assert!(w["message"].as_str().unwrap().contains("WORSE"), "{w}");
    // The Model-P baseline is recalibrated and reported the same way.
    assert!(warnings.iter().any(|w| w["code"] == "baseline_recalibration_worse_on_holdout" && w["channel"] == "T"));
    // The channels the hold-out does not contradict carry no such warning.
    assert!(warnings.iter().all(|w| w["channel"] == "T"), "{warnings:?}");
    // The text says it plainly.
    let (ok, _, err) = run(bin()
        .args(["recalibrate", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&biased)
        .arg("--out")
        .arg(d.path().join("t.fbgm")));
    assert!(ok, "{err}");
    let line =
        err.lines().find(|l| l.starts_with("warning:") && l.contains("Model-H")).unwrap_or_else(|| panic!("{err}"));
    assert!(
        line.contains("T is WORSE on the hold-out") && line.contains(&format!("{before:.4} -> {after:.4}")),
        "{err}"
    );
    // No Rust debug output such as `[Keep` or `(0.0, 1.0)`.
    assert!(
        !err.contains("[Keep") && !err.contains("Offset,") && !err.contains("(0.0, 1.0)") && !err.contains("Updated"),
        "{err}"
    );
}

/// The keep/revert decision uses the batch only: the same batch with a different hold-out (the
/// hold-out's reference shifted so that it now agrees with the update, or no hold-out at all)
/// writes the same model and the same decisions, while the hold-out's verdict flips.
#[test]
fn the_decision_does_not_depend_on_the_holdout() {
    let d = tempfile::tempdir().unwrap();
    let (model, csv) = trained(d.path());
    let a = edit_csv(&csv, &d.path().join("a.csv"), &["cal"], 1.0, &[]);
    let b = edit_csv(&csv, &d.path().join("b.csv"), &["cal", "holdout"], 1.0, &[]);
    let c = edit_csv(&csv, &d.path().join("c.csv"), &["cal"], 1.0, &["holdout"]);
    let (oa, ob, oc) = (d.path().join("ra.fbgm"), d.path().join("rb.fbgm"), d.path().join("rc.fbgm"));
    let (ja, jb, jc) = (recal_json(&model, &a, &oa), recal_json(&model, &b, &ob), recal_json(&model, &c, &oc));
    // The decisions and the models written are the same ...
    for j in [&jb, &jc] {
        assert_eq!(j["recalibration"], ja["recalibration"]);
        assert_eq!(j["baseline_recalibration"], ja["baseline_recalibration"]);
        assert_eq!(j["kept_old_channels"], ja["kept_old_channels"]);
    }
    // Same bytes but for the provenance date (a run across midnight).
    let bytes = |p: &Path| {
        let mut m = export::read_blob(p).unwrap();
        m.provenance.date_yyyymmdd = 0;
        export::blob_bytes(&m).unwrap()
    };
    for suffix in ["", "-p"] {
        let blob = |x: &str| bytes(&d.path().join(format!("r{x}{suffix}.fbgm")));
        assert_eq!(blob("a"), blob("b"), "model{suffix}");
        assert_eq!(blob("a"), blob("c"), "model{suffix}");
    }
    // ... while the hold-outs disagree: worse on T in a, better in b, absent in c.
    assert!(holdout_rmse(&ja, "holdout_after", 0) > holdout_rmse(&ja, "holdout_before", 0), "{ja}");
    assert!(holdout_rmse(&jb, "holdout_after", 0) < holdout_rmse(&jb, "holdout_before", 0), "{jb}");
    assert!(jc["holdout_before"].is_null());
    assert!(jc["warnings"].as_array().unwrap().iter().any(|w| w["code"] == "recalibration_no_holdout"), "{jc}");
}
