//! Nothing the user had is lost (DESIGN §9). An output that exists and is not a
//! regular file is refused, an output that is one of the inputs is refused, and a missing or
//! unwritable output directory is found before the work with one clean message.

use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::Command;

use crate::common;
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

// ---- One output check for every command ----------------------------------

/// A two-day record (fast to fit) named `name` in `dir`.
fn tiny_csv(dir: &Path, name: &str, seed: u64) -> std::path::PathBuf {
    let cfg = dir.join("tiny.toml");
    std::fs::write(&cfg, "name = \"tiny\"\n[clock]\ndays = 2.0\n").unwrap();
    let csv = dir.join(name);
    let (ok, _, err) =
        run(bin().args(["simulate", "--seed", &seed.to_string(), "--config"]).arg(&cfg).arg("--out").arg(&csv));
    assert!(ok, "{err}");
    csv
}

/// The issue's reproduction: a group whose `out` is its own `data`.
#[test]
fn fleet_refuses_a_group_whose_out_is_its_own_data_and_the_data_survives() {
    let d = tempfile::tempdir().unwrap();
    tiny_csv(d.path(), "g.csv", 2);
    let before = std::fs::read(d.path().join("g.csv")).unwrap();
    std::fs::write(d.path().join("f.toml"), "[[group]]\nname=\"a\"\ndata=\"g.csv\"\nout=\"g.csv\"\n").unwrap();
    let (ok, _, err) = run(bin().current_dir(d.path()).args(["fleet", "--manifest", "f.toml"]));
    assert!(!ok, "fleet must fail");
    assert!(err.contains("group[0].out") && err.contains("group[0].data") && err.contains("f.toml"), "{err}");
    let after = std::fs::read(d.path().join("g.csv")).unwrap();
    assert_eq!(&after[..4], &before[..4], "still CSV, not FBGM");
    assert_eq!(after, before);
    assert!(!d.path().join("g-p.fbgm").exists(), "refused before any work");
}

/// The error of `fleet::Manifest::check_paths` for a manifest `text` in `dir` (`Ok` text when
/// it passes: the outputs outside, allowed).
fn fleet_check(dir: &Path, text: &str, allow_outside: bool) -> Result<Vec<std::path::PathBuf>, String> {
    use fbg_trainer::fleet::Manifest;
    let path = dir.join("f.toml");
    std::fs::write(&path, text).unwrap();
    let m = Manifest { allow_outside, ..Manifest::from_file(&path).map_err(|e| e.to_string())? };
    m.check_paths(None, None).map_err(|e| e.to_string())
}

fn group(name: &str, data: &str, out: &str) -> String {
    format!("[[group]]\nname = \"{name}\"\ndata = \"{data}\"\nout = \"{out}\"\n")
}

#[test]
fn fleet_refuses_outputs_that_are_inputs_or_other_outputs_however_spelt() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    std::fs::write(p.join("a.csv"), "x").unwrap();
    std::fs::write(p.join("b.csv"), "y").unwrap();
    std::fs::create_dir(p.join("sub")).unwrap();
    // Clean: two groups, two outputs.
    assert_eq!(fleet_check(p, &(group("a", "a.csv", "m.fbgm") + &group("b", "b.csv", "n.fbgm")), false), Ok(vec![]));
    // `sub/../m.fbgm` is `m.fbgm`.
    let e =
        fleet_check(p, &(group("a", "a.csv", "m.fbgm") + &group("b", "b.csv", "sub/../m.fbgm")), false).unwrap_err();
    assert!(e.contains("group[1].out") && e.contains("group[0]"), "{e}");
    // The manifest itself.
    let e = fleet_check(p, &group("a", "a.csv", "f.toml"), false).unwrap_err();
    assert!(e.contains("group[0].out") && e.contains("the manifest"), "{e}");
    // Another group's CSV.
    let e = fleet_check(p, &(group("a", "a.csv", "m.fbgm") + &group("b", "b.csv", "a.csv")), false).unwrap_err();
    assert!(e.contains("group[1].out") && e.contains("group[0].data"), "{e}");
    // Another group's Model-P blob, through a symbolic link to the directory.
    std::os::unix::fs::symlink(p, p.join("here")).unwrap();
    let e =
        fleet_check(p, &(group("a", "a.csv", "m.fbgm") + &group("b", "b.csv", "here/m-p.fbgm")), false).unwrap_err();
    assert!(e.contains("group[1].out") && e.contains("Model-P") && e.contains("group[0].out"), "{e}");
    // A symbolic link and a hard link to an input.
    std::os::unix::fs::symlink(p.join("a.csv"), p.join("soft.fbgm")).unwrap();
    let e = fleet_check(p, &(group("a", "a.csv", "m.fbgm") + &group("b", "b.csv", "soft.fbgm")), false).unwrap_err();
    assert!(e.contains("group[1].out") && e.contains("group[0].data"), "{e}");
    std::fs::hard_link(p.join("a.csv"), p.join("hard.fbgm")).unwrap();
    let e = fleet_check(p, &(group("a", "a.csv", "m.fbgm") + &group("b", "b.csv", "hard.fbgm")), false).unwrap_err();
    assert!(e.contains("group[1].out") && e.contains("group[0].data"), "{e}");
    // A group's out is its own data's `.meta.json` sidecar.
    let e = fleet_check(p, &group("a", "a.csv", "a.meta.json"), false).unwrap_err();
    assert!(e.contains(".meta.json"), "{e}");
}

#[test]
fn fleet_refuses_outputs_outside_the_manifest_directory_unless_allowed() {
    let root = tempfile::tempdir().unwrap();
    let p = root.path().join("a").join("b");
    std::fs::create_dir_all(&p).unwrap();
    std::fs::write(p.join("a.csv"), "x").unwrap();
    let elsewhere = tempfile::tempdir().unwrap();
    let abs = elsewhere.path().join("x.fbgm");
    for out in ["../../x.fbgm".to_string(), abs.display().to_string()] {
        let e = fleet_check(&p, &group("a", "a.csv", &out), false).unwrap_err();
        assert!(e.contains("group[0].out") && e.contains("outside") && e.contains("--allow-outside"), "{out}: {e}");
        let ok = fleet_check(&p, &group("a", "a.csv", &out), true).unwrap();
        assert!(!ok.is_empty(), "{out}: the outside outputs are reported");
    }
    // Inside through `..`: allowed.
    std::fs::create_dir(p.join("s")).unwrap();
    assert_eq!(fleet_check(&p, &group("a", "a.csv", "s/../m.fbgm"), false), Ok(vec![]));
    // The CLI: refused before any work; with --allow-outside it says so on stderr.
    std::fs::write(p.join("f.toml"), group("a", "missing.csv", "../../x.fbgm")).unwrap();
    let (ok, _, err) = run(bin().arg("fleet").arg("--manifest").arg(p.join("f.toml")));
    assert!(!ok && err.contains("outside") && err.contains("--allow-outside"), "{err}");
    assert!(!err.contains("missing.csv"), "refused before reading any group: {err}");
    let (_, _, err) = run(bin().arg("fleet").arg("--allow-outside").arg("--manifest").arg(p.join("f.toml")));
    assert!(err.contains("outside the manifest's directory") && err.contains("--allow-outside"), "{err}");
}

/// 10 000 groups: the check hashes, so it is quick; the time is printed (the bench measures it).
#[test]
fn a_ten_thousand_group_manifest_is_checked_by_hashing() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let n = 10_000;
    let mut text = String::with_capacity(n * 64);
    for i in 0..n {
        text.push_str(&group(&format!("g{i}"), &format!("data/{i}.csv"), &format!("models/{i}.fbgm")));
    }
    let t = std::time::Instant::now();
    assert_eq!(fleet_check(p, &text, false), Ok(vec![]));
    eprintln!("10 000 groups parsed and checked in {:.3} s", t.elapsed().as_secs_f64());
    // The last group writes the first group's data: found, and named.
    let clash = text.replace("out = \"models/9999.fbgm\"", "out = \"data/0.csv\"");
    let e = fleet_check(p, &clash, false).unwrap_err();
    assert!(e.contains("group[9999].out") && e.contains("group[0].data"), "{e}");
}

/// The record's sidecar (its zero and clock) is an input of every command that reads the
/// record: an output onto it is refused before anything is read or written.
#[test]
fn the_records_sidecar_is_an_input_of_train_evaluate_and_recalibrate() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let side = d.path().join("data.record.json");
    std::fs::write(&side, b"the sidecar, not read before the refusal").unwrap();
    let model = d.path().join("m.fbgm");
    std::fs::write(&model, b"not checked before the refusal").unwrap();
    for (what, args) in [
        ("train", vec!["train", "--max-centres", "8", "--out"]),
        ("evaluate", vec!["evaluate", "--model", model.to_str().unwrap(), "--metrics"]),
        ("recalibrate", vec!["recalibrate", "--model", model.to_str().unwrap(), "--out"]),
    ] {
        let (ok, _, err) = run(bin().args(&args).arg(&side).arg("--data").arg(&csv));
        assert!(!ok && err.contains("data.record.json") && err.contains("also an input"), "{what}: {err}");
        assert_eq!(std::fs::read(&side).unwrap(), b"the sidecar, not read before the refusal", "{what}");
    }
}

#[test]
fn every_command_refuses_an_output_that_is_an_input_or_another_output() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let csv = tiny_csv(p, "data.csv", 2);
    let model = p.join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "4", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let keep: Vec<(std::path::PathBuf, Vec<u8>)> =
        [&csv, &model].iter().map(|f| (f.to_path_buf(), std::fs::read(f).unwrap())).collect();
    // simulate: --dump-config onto --out.
    let (ok, _, err) =
        run(bin().args(["simulate", "--out"]).arg(p.join("s.csv")).arg("--dump-config").arg(p.join("s.csv")));
    assert!(!ok && err.contains("another output"), "simulate: {err}");
    // compensate: --out a hard link to the model.
    std::fs::hard_link(&model, p.join("hard.csv")).unwrap();
    let (ok, _, err) = run(bin()
        .args(["compensate", "--data"])
        .arg(&csv)
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(p.join("hard.csv")));
    assert!(!ok && err.contains("also an input"), "compensate: {err}");
    // sign: --out the key, through a symbolic link.
    let (ok, _, err) = run(bin().arg("keygen").arg("--out").arg(p.join("lab.key")));
    assert!(ok, "{err}");
    std::os::unix::fs::symlink(p.join("lab.key"), p.join("key-link")).unwrap();
    let key_before = std::fs::read(p.join("lab.key")).unwrap();
    let (ok, _, err) = run(bin()
        .arg("sign")
        .arg("--model")
        .arg(&model)
        .arg("--sign")
        .arg(p.join("lab.key"))
        .arg("--out")
        .arg(p.join("key-link")));
    assert!(!ok && err.contains("also an input"), "sign: {err}");
    assert_eq!(std::fs::read(p.join("lab.key")).unwrap(), key_before);
    // sign: --out the key id's serial ledger in the signing state directory.
    let sign_into = |out: &std::path::Path| {
        run(bin()
            .arg("sign")
            .arg("--model")
            .arg(&model)
            .arg("--sign")
            .arg(p.join("lab.key"))
            .arg("--serial-state")
            .arg(p.join("state"))
            .arg("--out")
            .arg(out))
    };
    let (ok, _, err) = sign_into(&p.join("signed.fbgm"));
    assert!(ok, "{err}");
    let ledger = std::fs::read_dir(p.join("state"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|f| f.extension().is_some_and(|x| x == "serial"))
        .expect("a ledger");
    let ledger_before = std::fs::read(&ledger).unwrap();
    let (ok, _, err) = sign_into(&ledger);
    assert!(!ok && err.contains("also an input"), "sign onto its ledger: {err}");
    assert_eq!(std::fs::read(&ledger).unwrap(), ledger_before);
    // golden: the data is one of its files.
    let gdir = p.join("g");
    std::fs::create_dir(&gdir).unwrap();
    std::fs::copy(&csv, gdir.join("golden_expected.csv")).unwrap();
    let (ok, _, err) = run(bin()
        .args(["golden", "--samples", "3", "--data"])
        .arg(gdir.join("golden_expected.csv"))
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(&gdir));
    assert!(!ok && err.contains("also an input"), "golden: {err}");
    // report: an input is the page it would write.
    let rdir = p.join("r");
    std::fs::create_dir(&rdir).unwrap();
    std::fs::copy(&csv, rdir.join("index.html")).unwrap();
    let (ok, _, err) = run(bin()
        .args(["report", "--out"])
        .arg(&rdir)
        .arg("--data")
        .arg(rdir.join("index.html"))
        .arg("--model")
        .arg(&model));
    assert!(!ok && err.contains("also an input"), "report: {err}");
    // train: Model-P's name is the data (`--out x.fbgm` writes `x-p.fbgm`).
    std::fs::copy(&csv, p.join("x-p.fbgm")).unwrap();
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(p.join("x-p.fbgm")).arg("--out").arg(p.join("x.fbgm")));
    assert!(!ok && err.contains("also an input"), "train: {err}");
    for (f, bytes) in keep {
        assert_eq!(std::fs::read(&f).unwrap(), bytes, "{} changed", f.display());
    }
}

// ---- Output sets ----------------------------------------------------------

/// Every regular file of `dir` (not recursing) and its bytes, minus names starting with `skip`.
fn snapshot(dir: &Path, skip: &str) -> std::collections::BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .filter(|e| e.file_type().unwrap().is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| skip.is_empty() || !n.starts_with(skip))
        .map(|n| {
            let b = std::fs::read(dir.join(&n)).unwrap();
            (n, b)
        })
        .collect()
}

/// Names an output set may leave while it runs.
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".fbg-tmp-") || n.starts_with(".fbg-journal-") || n.starts_with(".fbg-rollback-"))
        .collect()
}

fn restore(dir: &Path, set: &std::collections::BTreeMap<String, Vec<u8>>) {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).unwrap();
    for (n, b) in set {
        std::fs::write(dir.join(n), b).unwrap();
    }
}

#[test]
fn train_that_cannot_write_model_p_leaves_the_old_set_untouched() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let csv = tiny_csv(p, "data.csv", 2);
    let out = p.join("set");
    let (ok, _, err) =
        run(bin().args(["train", "--max-centres", "4", "--data"]).arg(&csv).arg("--out").arg(out.join("m.fbgm")));
    assert!(ok, "{err}");
    let old = snapshot(&out, "");
    // A directory stands where Model-P goes: nothing may be replaced.
    std::fs::remove_file(out.join("m-p.fbgm")).unwrap();
    std::fs::create_dir(out.join("m-p.fbgm")).unwrap();
    let (ok, _, err) =
        run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(out.join("m.fbgm")));
    assert!(!ok && err.contains("m-p.fbgm"), "{err}");
    let mut still = old.clone();
    still.remove("m-p.fbgm");
    assert_eq!(snapshot(&out, ""), still, "Model-H and the coefficients are the old ones");
    assert!(temporaries(&out).is_empty(), "{:?}", temporaries(&out));
}

#[test]
fn a_report_whose_fig6_is_blocked_leaves_the_old_report_untouched() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let csv = tiny_csv(p, "data.csv", 2);
    let mut models = Vec::new();
    for k in ["4", "8"] {
        let m = p.join(format!("k{k}")).join("m.fbgm");
        let (ok, _, err) = run(bin().args(["train", "--max-centres", k, "--data"]).arg(&csv).arg("--out").arg(&m));
        assert!(ok, "{err}");
        let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(&m));
        assert!(ok, "{err}");
        models.push(m);
    }
    let rep = p.join("rep");
    let report =
        |m: &Path| run(bin().args(["report", "--out"]).arg(&rep).arg("--data").arg(&csv).arg("--model").arg(m));
    let (ok, _, err) = report(&models[0]);
    assert!(ok, "{err}");
    let old = snapshot(&rep, "");
    assert!(old.contains_key("fig6_parity.png") && old.contains_key("fig1_inputs.png"));
    // fig6 is blocked (a directory stands there); the figures before it and the tables are
    // drawn, but none may replace the old ones.
    std::fs::remove_file(rep.join("fig6_parity.png")).unwrap();
    std::fs::create_dir(rep.join("fig6_parity.png")).unwrap();
    let (ok, _, err) = report(&models[1]);
    assert!(!ok && err.contains("fig6_parity.png"), "{err}");
    let mut still = old.clone();
    still.remove("fig6_parity.png");
    assert_eq!(snapshot(&rep, ""), still, "every old file is kept as it was");
    assert!(temporaries(&rep).is_empty(), "{:?}", temporaries(&rep));
    // Unblocked, the new report replaces the whole set.
    std::fs::remove_dir(rep.join("fig6_parity.png")).unwrap();
    let (ok, _, err) = report(&models[1]);
    assert!(ok, "{err}");
    assert_ne!(snapshot(&rep, "")["index.html"], old["index.html"]);
}

/// splitmix64: the seeded delays of the kill test.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Kill `cmd` (writing into `dir`, which holds `old`) after seeded random delays, `kills`
/// times; after each kill the next command writing there (a `keygen` into the directory)
/// must leave exactly `old` or exactly `new`, and no temporaries. Returns (old, new) counts.
fn kill_at_random(
    dir: &Path,
    cmd: &dyn Fn() -> Command,
    old: &std::collections::BTreeMap<String, Vec<u8>>,
    new: &std::collections::BTreeMap<String, Vec<u8>>,
    span: std::time::Duration,
    kills: usize,
    rng: &mut Rng,
) -> (usize, usize) {
    let (mut n_old, mut n_new) = (0, 0);
    for i in 0..kills {
        restore(dir, old);
        // Half the kills anywhere in the run, half near its end, where the set is committed.
        let u = if i % 2 == 0 { 1.2 * rng.next() } else { 0.8 + 0.3 * rng.next() };
        let mut child = cmd().stdout(std::process::Stdio::null()).stderr(std::process::Stdio::null()).spawn().unwrap();
        std::thread::sleep(span.mul_f64(u));
        let _ = child.kill(); // SIGKILL
        let _ = child.wait();
        let (ok, _, err) = run(bin().arg("keygen").arg("--out").arg(dir.join("next.key")));
        assert!(ok, "{err}");
        let now = snapshot(dir, "next.");
        assert!(temporaries(dir).is_empty(), "kill {i} at {u:.2}: left {:?}", temporaries(dir));
        if &now == old {
            n_old += 1;
        } else if &now == new {
            n_new += 1;
        } else {
            let diff: Vec<&String> = now
                .keys()
                .chain(old.keys())
                .filter(|k| now.get(*k) != new.get(*k) && now.get(*k) != old.get(*k))
                .collect();
            let mixed: Vec<&String> =
                now.keys().filter(|k| now.get(*k) == new.get(*k) && new.get(*k) != old.get(*k)).collect();
            panic!(
                "kill {i} at {u:.2} of the run: a mix of the old and the new set (new: {mixed:?}; neither: {diff:?})"
            );
        }
    }
    (n_old, n_new)
}

/// `train` and `report`, killed at random: every directory afterwards holds the old set or the
/// new set, never a mix, and no temporaries once the next command has written there.
fn kills_leave_an_old_or_a_new_set(train_kills: usize, report_kills: usize, seed: u64) {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let (csv_a, csv_b) = (tiny_csv(p, "a.csv", 2), tiny_csv(p, "b.csv", 3));
    let work = p.join("work");
    let train = |csv: &Path, k: &str| {
        let mut c = bin();
        c.env("SOURCE_DATE_EPOCH", "1760000000")
            .args(["train", "--max-centres", k, "--data"])
            .arg(csv)
            .arg("--out")
            .arg(work.join("m.fbgm"));
        c
    };
    // Reference sets, written where the killed runs write (a path inside may be recorded).
    restore(&work, &Default::default());
    let (ok, _, err) = run(&mut train(&csv_a, "4"));
    assert!(ok, "{err}");
    let old = snapshot(&work, "");
    let t = std::time::Instant::now();
    let (ok, _, err) = run(&mut train(&csv_b, "8"));
    let span = t.elapsed();
    assert!(ok, "{err}");
    let new = snapshot(&work, "");
    assert_eq!(old.keys().collect::<Vec<_>>(), new.keys().collect::<Vec<_>>());
    assert!(old.iter().all(|(k, v)| new[k] != *v), "every file of the new set differs from the old");
    let mut rng = Rng(seed);
    let t0 = std::time::Instant::now();
    let (a, b) = kill_at_random(&work, &|| train(&csv_b, "8"), &old, &new, span, train_kills, &mut rng);
    eprintln!("train: {train_kills} kills over a {span:?} run: {a} old sets, {b} new sets ({:?})", t0.elapsed());

    // The report: old from model A, new from model B, both read from outside the directory.
    let mut inputs = Vec::new();
    for (csv, k, name) in [(&csv_a, "4", "ma"), (&csv_b, "8", "mb")] {
        let m = p.join(name).join("m.fbgm");
        let (ok, _, err) = run(bin().args(["train", "--max-centres", k, "--data"]).arg(csv).arg("--out").arg(&m));
        assert!(ok, "{err}");
        let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(csv).arg("--model").arg(&m));
        assert!(ok, "{err}");
        inputs.push((csv.clone(), m));
    }
    let rep = p.join("rep");
    let report = |i: usize| {
        let mut c = bin();
        c.env("SOURCE_DATE_EPOCH", "1760000000")
            .args(["report", "--out"])
            .arg(&rep)
            .arg("--data")
            .arg(&inputs[i].0)
            .arg("--model")
            .arg(&inputs[i].1);
        c
    };
    restore(&rep, &Default::default());
    let (ok, _, err) = run(&mut report(0));
    assert!(ok, "{err}");
    let old = snapshot(&rep, "");
    let t = std::time::Instant::now();
    let (ok, _, err) = run(&mut report(1));
    let span = t.elapsed();
    assert!(ok, "{err}");
    let new = snapshot(&rep, "");
    assert_ne!(old, new);
    let t0 = std::time::Instant::now();
    let (a, b) = kill_at_random(&rep, &|| report(1), &old, &new, span, report_kills, &mut rng);
    eprintln!("report: {report_kills} kills over a {span:?} run: {a} old sets, {b} new sets ({:?})", t0.elapsed());
}

#[test]
fn killed_train_and_report_leave_an_old_or_a_new_set() {
    kills_leave_an_old_or_a_new_set(16, 8, 28);
}

/// The long run of the kill test (≥ 200 kills): `cargo test --release -p fbg-trainer --test
/// outputs -- --ignored`.
#[test]
#[ignore]
fn killed_train_and_report_leave_an_old_or_a_new_set_many_times() {
    kills_leave_an_old_or_a_new_set(200, 100, 2028);
}

/// A fleet group is one output set: a group that cannot write its coefficients keeps its old
/// blobs and its old record (which still matches them), and the other groups go on.
#[test]
fn a_fleet_group_that_fails_partway_keeps_its_old_set() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    tiny_csv(p, "a.csv", 2);
    tiny_csv(p, "b.csv", 4);
    std::fs::write(
        p.join("f.toml"),
        "[defaults]\nmax_centres = 4\n".to_string()
            + &group("a", "a.csv", "ma/m.fbgm")
            + &group("b", "b.csv", "mb/m.fbgm"),
    )
    .unwrap();
    let fleet = || run(bin().arg("fleet").arg("--manifest").arg(p.join("f.toml")));
    let (ok, _, err) = fleet();
    assert!(ok, "{err}");
    let old = snapshot(&p.join("ma"), "");
    assert!(old.contains_key("m.fleet.json") && old.contains_key("m-p.fbgm"));
    // New data for both groups; group a's coefficients are blocked by a directory.
    tiny_csv(p, "a.csv", 3);
    tiny_csv(p, "b.csv", 5);
    std::fs::remove_file(p.join("ma/m.coefficients.json")).unwrap();
    std::fs::create_dir(p.join("ma/m.coefficients.json")).unwrap();
    let (ok, _, err) = fleet();
    assert!(!ok && err.contains("1 of 2 groups failed"), "{err}");
    let mut still = old.clone();
    still.remove("m.coefficients.json");
    let now: std::collections::BTreeMap<_, _> =
        snapshot(&p.join("ma"), "").into_iter().filter(|(k, _)| k != "m.fleet-failed.json").collect();
    assert_eq!(now, still, "group a keeps its old blobs and record");
    assert!(temporaries(&p.join("ma")).is_empty() && temporaries(&p.join("mb")).is_empty());
    let (ok, _, err) = run(bin().args(["fleet", "status", "--manifest"]).arg(p.join("f.toml")));
    assert!(!ok && err.contains("FAILED"), "{err}");
}

/// `simulate` writes the record and its sidecar as one set: a sidecar that cannot be written
/// leaves the old record (never a new record beside the old sidecar).
#[test]
fn simulate_that_cannot_write_its_sidecar_keeps_the_old_record() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path();
    let csv = tiny_csv(p, "rec.csv", 2);
    let old_csv = std::fs::read(&csv).unwrap();
    let side = p.join("rec.meta.json");
    let old_side = std::fs::read(&side).unwrap();
    // Another seed, with a directory standing where the sidecar goes: refused, nothing moved.
    std::fs::remove_file(&side).unwrap();
    std::fs::create_dir(&side).unwrap();
    let cfg = p.join("tiny.toml");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "3", "--config"]).arg(&cfg).arg("--out").arg(&csv));
    assert!(!ok, "simulate over a blocked sidecar must fail");
    assert!(err.contains("rec.meta.json"), "{err}");
    assert_eq!(std::fs::read(&csv).unwrap(), old_csv, "the old record is kept");
    // Unblocked: both files are replaced together, and no temporaries stay.
    std::fs::remove_dir(&side).unwrap();
    std::fs::write(&side, &old_side).unwrap();
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "3", "--config"]).arg(&cfg).arg("--out").arg(&csv));
    assert!(ok, "{err}");
    assert_ne!(std::fs::read(&csv).unwrap(), old_csv);
    assert_ne!(std::fs::read(&side).unwrap(), old_side);
    let litter: Vec<_> = std::fs::read_dir(p)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".fbg-"))
        .collect();
    assert!(litter.is_empty(), "{litter:?}");
}
