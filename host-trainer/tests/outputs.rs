//! Nothing the user had is lost (DESIGN §9). An output that exists and is not a
//! regular file is refused, an output that is one of the inputs is refused, and a missing or
//! unwritable output directory is found before the work with one clean message.

use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::Command;

mod common;
use common::{bin, run, short_csv};

fn mkfifo(p: &Path) {
    let ok = Command::new("mkfifo").arg(p).status().map(|s| s.success()).unwrap_or(false);
    assert!(ok, "mkfifo {} failed", p.display());
}

fn is_fifo(p: &Path) -> bool {
    std::fs::symlink_metadata(p).map(|m| m.file_type().is_fifo()).unwrap_or(false)
}

fn is_root() -> bool {
    Command::new("id").arg("-u").output().map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0").unwrap_or(false)
}

#[test]
fn simulate_onto_a_fifo_is_refused_and_the_fifo_survives() {
    let d = tempfile::tempdir().unwrap();
    let fifo = d.path().join("pipe.csv");
    mkfifo(&fifo);
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "7", "--out"]).arg(&fifo));
    assert!(!ok, "writing onto a FIFO must be refused");
    assert!(err.contains("pipe.csv") && err.contains("not a regular file"), "{err}");
    assert!(is_fifo(&fifo), "the FIFO was replaced");
    assert!(!d.path().join("pipe.meta.json").exists(), "no sidecar beside a refused output");
}

#[test]
fn train_onto_a_fifo_is_refused_before_the_fit() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let fifo = d.path().join("model.fbgm");
    mkfifo(&fifo);
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&fifo));
    assert!(!ok);
    assert!(err.contains("model.fbgm") && err.contains("not a regular file"), "{err}");
    assert!(!err.contains("trained"), "refused before the fit: {err}");
    assert!(is_fifo(&fifo));
    assert!(!d.path().join("model-p.fbgm").exists() && !d.path().join("model.coefficients.json").exists());
}

#[test]
fn import_onto_a_directory_is_refused_by_name() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let out = d.path().join("out.csv");
    std::fs::create_dir(&out).unwrap();
    let (ok, _, err) = run(bin().args(["import", "--format", "csv"]).arg(&csv).arg("--out").arg(&out));
    assert!(!ok);
    assert!(err.contains("out.csv") && err.contains("directory") && err.contains("refusing"), "{err}");
    assert!(out.is_dir());
}

/// As root, a device node (made in a temporary directory, never `/dev/null` itself) must
/// survive `--out` just like a FIFO.
#[test]
fn a_device_node_output_is_refused_when_root() {
    if !is_root() {
        eprintln!("skipped: mknod needs root");
        return;
    }
    let d = tempfile::tempdir().unwrap();
    let null = d.path().join("null");
    let ok = Command::new("mknod").arg(&null).args(["c", "1", "3"]).status().map(|s| s.success()).unwrap_or(false);
    if !ok {
        eprintln!("skipped: mknod failed (no device nodes in this file system)");
        return;
    }
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "7", "--out"]).arg(&null));
    assert!(!ok);
    assert!(err.contains("not a regular file"), "{err}");
    assert!(std::fs::symlink_metadata(&null).unwrap().file_type().is_char_device(), "the device node was replaced");
    assert!(!d.path().join("null.meta.json").exists());
}

#[test]
fn import_onto_its_own_input_is_refused_and_the_input_kept() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let before = std::fs::read(&csv).unwrap();
    let (ok, _, err) = run(bin().args(["import", "--format", "csv"]).arg(&csv).arg("--out").arg(&csv));
    assert!(!ok, "import over its own input must be refused");
    assert!(err.contains("data.csv") && err.contains("also an input"), "{err}");
    // Another spelling of the same path, and a hard link, are the same file too.
    let sub = d.path().join("sub");
    std::fs::create_dir(&sub).unwrap();
    let other = sub.join("..").join("data.csv");
    let (ok, _, err) = run(bin().args(["import", "--format", "csv"]).arg(&csv).arg("--out").arg(&other));
    assert!(!ok && err.contains("also an input"), "{err}");
    let link = d.path().join("link.csv");
    std::fs::hard_link(&csv, &link).unwrap();
    let (ok, _, err) = run(bin().args(["import", "--format", "csv"]).arg(&csv).arg("--out").arg(&link));
    assert!(!ok && err.contains("also an input"), "{err}");
    assert_eq!(std::fs::read(&csv).unwrap(), before, "the input is unchanged");
}

#[test]
fn train_evaluate_recalibrate_refuse_an_output_that_is_an_input() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let before = std::fs::read(&csv).unwrap();
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&csv));
    assert!(!ok && err.contains("data.csv") && err.contains("also an input"), "train: {err}");
    let model = d.path().join("m.fbgm");
    std::fs::write(&model, b"not checked before the refusal").unwrap();
    let (ok, _, err) =
        run(bin().args(["evaluate", "--data"]).arg(&csv).arg("--model").arg(&model).arg("--metrics").arg(&csv));
    assert!(!ok && err.contains("also an input"), "evaluate: {err}");
    let (ok, _, err) =
        run(bin().args(["recalibrate", "--data"]).arg(&csv).arg("--model").arg(&model).arg("--out").arg(&model));
    assert!(!ok && err.contains("m.fbgm") && err.contains("also an input"), "recalibrate: {err}");
    assert_eq!(std::fs::read(&csv).unwrap(), before);
    assert_eq!(std::fs::read(&model).unwrap(), b"not checked before the refusal");
}

#[test]
fn a_missing_output_directory_is_created_before_the_work() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("models").join("run1").join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    assert!(model.exists() && d.path().join("models/run1/m-p.fbgm").exists());
    let golden = d.path().join("g").join("h");
    let (ok, _, err) = run(bin()
        .args(["golden", "--samples", "5", "--data"])
        .arg(&csv)
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(&golden));
    assert!(ok, "{err}");
    assert!(golden.join("golden_meta.json").exists());
}

#[test]
fn an_output_directory_that_cannot_be_made_fails_first_with_one_clean_message() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    // A regular file where a directory is needed: fails even as root.
    let file = d.path().join("plain.txt");
    std::fs::write(&file, "x").unwrap();
    for model in [file.join("m.fbgm"), file.join("sub").join("m.fbgm")] {
        let (ok, out, err) =
            run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
        assert!(!ok);
        assert!(err.contains("plain.txt"), "names the directory: {err}");
        assert!(!err.contains(".fbg-tmp"), "no temporary file name: {err}");
        assert!(!err.contains("trained") && out.is_empty(), "fails before the fit: {err}");
        assert_eq!(err.trim().lines().count(), 1, "one line: {err}");
        assert_eq!(err.to_lowercase().matches("not a directory").count(), 1, "the cause once: {err}");
    }
}

#[test]
fn sidecars_are_named_after_the_model_so_two_models_in_one_directory_keep_theirs() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let (a, b) = (d.path().join("pier-a.fbgm"), d.path().join("pier-b.fbgm"));
    for (model, k) in [(&a, "8"), (&b, "4")] {
        let (ok, _, err) = run(bin().args(["train", "--max-centres", k, "--data"]).arg(&csv).arg("--out").arg(model));
        assert!(ok, "{err}");
        let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(model));
        assert!(ok, "{err}");
    }
    let read = |f: &str| std::fs::read_to_string(d.path().join(f)).unwrap();
    for stem in ["pier-a", "pier-b"] {
        for kind in ["coefficients", "metrics"] {
            assert!(d.path().join(format!("{stem}.{kind}.json")).is_file(), "{stem}.{kind}.json missing");
        }
    }
    assert!(!d.path().join("coefficients.json").exists() && !d.path().join("metrics.json").exists());
    // Each model keeps its own numbers: the RBF capacities differ.
    assert_ne!(read("pier-a.coefficients.json"), read("pier-b.coefficients.json"));
    assert_ne!(read("pier-a.metrics.json"), read("pier-b.metrics.json"));
    // `report --model` finds that model's metrics beside it without --metrics.
    let out = d.path().join("rep");
    let (ok, _, err) = run(bin().args(["report", "--out"]).arg(&out).arg("--data").arg(&csv).arg("--model").arg(&b));
    assert!(ok, "{err}");
    assert!(out.join("index.html").is_file());
}
