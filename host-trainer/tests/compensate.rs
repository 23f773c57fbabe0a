//! `fbg-trainer compensate`: a logged record through the model as the device would run it —
//! the same estimates as `evaluate`, gaps kept as gaps, no references needed, f32 on request.

use std::path::Path;

use crate::common;
use common::{bin, run, short_csv, train_small as train};

use fbg_trainer::compensate::{self, Precision};
use fbg_trainer::data::Dataset;
use fbg_trainer::eval::score;
use fbg_trainer::export;

/// The output CSV as rows of cells (header dropped).
fn rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path).unwrap().lines().skip(1).map(|l| l.split(',').map(str::to_string).collect()).collect()
}

#[test]
fn compensate_writes_evaluates_estimates_bit_for_bit() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = train(d.path(), &csv);
    let out = d.path().join("out/comp.csv");
    let (ok, js, err) =
        run(bin().args(["compensate", "--json", "--model"]).arg(&model).arg("--data").arg(&csv).arg("--out").arg(&out));
    assert!(ok, "{err}");
    let summary: serde_json::Value = serde_json::from_str(&js).unwrap();
    let data = Dataset::read_csv(&csv).unwrap();
    assert_eq!(summary["rows"], data.len());
    assert!(summary["reference_errors"]["rmse"][0].as_f64().unwrap() > 0.0);
    // `evaluate`'s estimates on the hold-out, from the same blob.
    let params = export::read_blob(&model).unwrap();
    let hold: Vec<usize> = data.holdout_indices().into_iter().filter(|&i| data.usable(i)).collect();
    let want = score::estimates(&params, &data, &hold).unwrap();
    let got = rows(&out);
    assert_eq!(got.len(), data.len());
    for (e, &i) in want.iter().zip(&hold) {
        for c in 0..3 {
            let v: f64 = got[i][1 + 2 * c].parse().unwrap();
            let b: f64 = got[i][2 + 2 * c].parse().unwrap();
            assert_eq!(v.to_bits(), e.values[c].to_bits(), "row {i} channel {c}");
            assert_eq!(b.to_bits(), e.band95[c].to_bits(), "row {i} band {c}");
        }
        assert_eq!(got[i][7], e.flags.0.to_string());
    }
}

#[test]
fn a_record_without_references_is_compensated_with_gaps_kept() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = train(d.path(), &csv);
    // The field record: inputs only, a gap in FBG2 on rows 100..105.
    let text = common::read_csv_body(&csv);
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<usize> =
        (0..head.len()).filter(|&k| ["t_s", "T_amb_C", "dl1_pm", "dl2_pm", "dl3_pm"].contains(&head[k])).collect();
    let dl2 = head.iter().position(|h| *h == "dl2_pm").unwrap();
    let mut field = keep.iter().map(|&k| head[k]).collect::<Vec<_>>().join(",") + "\n";
    for (r, l) in lines.enumerate() {
        let cells: Vec<&str> = l.split(',').collect();
        let row: Vec<&str> =
            keep.iter().map(|&k| if k == dl2 && (100..105).contains(&r) { "" } else { cells[k] }).collect();
        field.push_str(&row.join(","));
        field.push('\n');
    }
    let field_csv = d.path().join("field.csv");
    std::fs::write(&field_csv, field).unwrap();
    // `train` still refuses it (nothing to calibrate against) ...
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&field_csv).arg("--out").arg(d.path().join("x.fbgm")));
    assert!(!ok && err.contains("no reference column"), "{err}");
    // ... `compensate` takes it.
    let out = d.path().join("comp.csv");
    let (ok, js, err) = run(bin()
        .args(["compensate", "--json", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&field_csv)
        .arg("--out")
        .arg(&out));
    assert!(ok, "{err}");
    let s: serde_json::Value = serde_json::from_str(&js).unwrap();
    assert_eq!(s["gap_rows"], 5);
    assert!(s["reference_errors"].is_null());
    assert!(s["flag_rows"][0].as_u64().unwrap() >= 5);
    let got = rows(&out);
    for (r, row) in got.iter().enumerate() {
        let gap = (100..105).contains(&r);
        assert_eq!(row[1].is_empty(), gap, "row {r}: {row:?}");
        if gap {
            assert!(row[8].contains("non-finite"), "row {r}: {row:?}");
        }
    }
    // Human text names the gaps and says there are no references to score against.
    let (ok, _, err) =
        run(bin().args(["compensate", "--model"]).arg(&model).arg("--data").arg(&field_csv).arg("--out").arg(&out));
    assert!(ok && err.contains("5 with gaps kept as gaps") && !err.contains("against the references"), "{err}");
}

#[test]
fn f32_runs_the_device_arithmetic_within_one_percent() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = train(d.path(), &csv);
    let params = export::read_blob(&model).unwrap();
    let data = Dataset::read_csv(&csv).unwrap();
    let a = compensate::estimates(&params, &data, Precision::F64).unwrap();
    let b = compensate::estimates(&params, &data, Precision::F32).unwrap();
    let hold: Vec<usize> = data.holdout_indices();
    let (ev, _) = score::evaluate_holdout(&params, &data).unwrap();
    for c in 0..3 {
        let worst = hold.iter().map(|&i| (a[i].values[c] - b[i].values[c]).abs()).fold(0.0, f64::max);
        assert!(worst > 0.0, "f32 must actually differ from f64 somewhere (channel {c})");
        assert!(worst <= 0.01 * ev.channels[c].rmse, "channel {c}: {worst} vs RMSE {}", ev.channels[c].rmse);
    }
    assert!(hold.iter().all(|&i| a[i].flags == b[i].flags));
    // The output is refused onto its own input.
    let (ok, _, err) =
        run(bin().args(["compensate", "--f32", "--model"]).arg(&model).arg("--data").arg(&csv).arg("--out").arg(&csv));
    assert!(!ok && err.contains("data.csv"), "{err}");
}

/// `train` names a reference that is constant, or a grating that never moves, over the
/// calibration batch, before any fitting.
#[test]
fn train_refuses_a_constant_reference_or_a_dead_grating_by_column() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let text = common::read_csv_body(&csv);
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let with_constant = |col: &str, value: &str| -> std::path::PathBuf {
        let k = head.iter().position(|h| *h == col).unwrap();
        let mut out = String::new();
        for (r, l) in text.lines().enumerate() {
            let mut cells: Vec<&str> = l.split(',').collect();
            if r > 0 {
                cells[k] = value;
            }
            out.push_str(&cells.join(","));
            out.push('\n');
        }
        let p = d.path().join(format!("{col}.csv"));
        std::fs::write(&p, out).unwrap();
        p
    };
    for (col, value, want) in
        [("strain_ue", "0", "`strain_ue` is constant"), ("dl3_pm", "12.5", "`dl3_pm` never moves")]
    {
        let bad = with_constant(col, value);
        let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&bad).arg("--out").arg(d.path().join("x.fbgm")));
        assert!(!ok && err.contains(want), "{col}: {err}");
        assert!(!err.contains("trained in"), "refused before the fit: {err}");
    }
}

/// A signed model whose trailer was changed after signing is named on stderr (`compensate`
/// and `evaluate`), and refused with `--require-signature`, writing nothing.
#[test]
fn a_model_changed_after_signing_is_named_and_refused_on_request() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let key = d.path().join("lab.key");
    let (ok, _, err) = run(bin().arg("keygen").arg("--out").arg(&key));
    assert!(ok, "{err}");
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin()
        .args(["train", "--max-centres", "8", "--data"])
        .arg(&csv)
        .arg("--out")
        .arg(&model)
        .arg("--sign")
        .arg(&key)
        .env(fbg_trainer::sign::STATE_DIR_ENV, d.path().join("state")));
    assert!(ok, "{err}");
    let pubkey = d.path().join("lab.pub");
    let comp = |out: &Path, extra: &[&str]| {
        run(bin()
            .args(["compensate", "--model"])
            .arg(&model)
            .arg("--data")
            .arg(&csv)
            .arg("--out")
            .arg(out)
            .arg("--pubkey")
            .arg(&pubkey)
            .args(extra))
    };
    // Intact: used without a word about it.
    let (ok, _, err) = comp(&d.path().join("a.csv"), &["--require-signature"]);
    assert!(ok && !err.contains("warning: "), "{err}");
    // The serial raised by one after signing (the trailer's bytes 8..16 after the blob).
    let mut bytes = std::fs::read(&model).unwrap();
    let blob_len = fbg_shared::container::strip(&bytes).len();
    bytes[blob_len + 8] ^= 1;
    std::fs::write(&model, &bytes).unwrap();
    let (ok, _, err) = comp(&d.path().join("b.csv"), &[]);
    assert!(ok && err.contains("warning: ") && err.contains("does not verify"), "{err}");
    let out = d.path().join("c.csv");
    let (ok, _, err) = comp(&out, &["--require-signature"]);
    assert!(!ok && err.contains("does not verify") && err.contains("--require-signature"), "{err}");
    assert!(!out.exists(), "nothing written when refused");
    // Without a key the host cannot tell: it says the signature went unchecked.
    let (ok, _, err) = run(bin()
        .args(["compensate", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&csv)
        .arg("--out")
        .arg(d.path().join("e.csv")));
    assert!(ok && err.contains("no public key was given"), "{err}");
    let (ok, _, err) = run(bin()
        .args(["evaluate", "--quick", "--require-signature", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&csv)
        .arg("--pubkey")
        .arg(&pubkey));
    assert!(!ok && err.contains("does not verify"), "{err}");
}
