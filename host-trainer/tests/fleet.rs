//! `fbg-trainer fleet`: manifest errors name the key, finished groups are not redone, a corrupt
//! or stale output is, and a failing group does not stop the others.

use std::path::{Path, PathBuf};
use std::process::Command;

use fbg_trainer::fleet::{self, Manifest, Outcome};
use fbg_trainer::sim;
use fbg_trainer::sim::scenario::Preset;

/// A short scenario (one day at 60 s: 1 440 samples) as `dir/<name>.csv`.
fn short_csv(dir: &Path, name: &str, seed: u64) -> PathBuf {
    let mut cfg = Preset::Paper.config();
    cfg.clock.days = 1.0;
    let s = sim::simulate(&cfg, seed);
    let p = dir.join(format!("{name}.csv"));
    s.data.write_csv(&p).unwrap();
    p
}

/// A manifest of `n` good groups (small grid: paper features, K <= 8) plus `extra` TOML.
fn manifest(dir: &Path, n: usize, extra: &str) -> PathBuf {
    let mut text = String::from("[defaults]\nfeatures = \"paper\"\nmax_centres = 8\n");
    for i in 0..n {
        short_csv(dir, &format!("g{i}"), 10 + i as u64);
        text.push_str(&format!("\n[[group]]\nname = \"g{i}\"\ndata = \"g{i}.csv\"\nout = \"models/g{i}.fbgm\"\n"));
    }
    text.push_str(extra);
    let p = dir.join("fleet.toml");
    std::fs::write(&p, text).unwrap();
    p
}

fn status(r: &fleet::FleetReport, name: &str) -> Outcome {
    r.groups.iter().find(|g| g.name == name).unwrap().outcome.clone()
}

fn err_of(text: &str) -> String {
    let d = tempfile::tempdir().unwrap();
    Manifest::from_str_at(text, &d.path().join("m.toml")).unwrap_err().to_string()
}

#[test]
fn manifest_errors_name_the_key() {
    let g = "[[group]]\nname = \"a\"\ndata = \"a.csv\"\nout = \"a.fbgm\"\n";
    let e = err_of("");
    assert!(e.contains("m.toml") && e.contains("group"), "{e}");
    let e = err_of("[[group]]\nname = \"a\"\nout = \"a.fbgm\"\n");
    assert!(e.contains("m.toml") && e.contains("data") && e.contains("line"), "{e}");
    let e = err_of(&format!("{g}colour = \"red\"\n"));
    assert!(e.contains("colour"), "{e}");
    let e = err_of(&format!("{g}features = \"magic\"\n"));
    assert!(e.contains("group[0].features") && e.contains("magic"), "{e}");
    let e = err_of(&format!("{g}max_centres = 0\n"));
    assert!(e.contains("group[0].max_centres"), "{e}");
    let e = err_of(&format!("[defaults]\nmax_centres = 1000\n{g}"));
    assert!(e.contains("defaults.max_centres"), "{e}");
    let e = err_of(&format!("{g}{}", g.replace("a.fbgm", "b.fbgm")));
    assert!(e.contains("group[1].name") && e.contains("group[0]"), "{e}");
    let e = err_of(&format!("{g}{}", g.replace("name = \"a\"", "name = \"b\"")));
    assert!(e.contains("group[1].out"), "{e}");
    let e = err_of("[[group]]\nname = \"\"\ndata = \"a.csv\"\nout = \"a.fbgm\"\n");
    assert!(e.contains("group[0].name"), "{e}");
}

#[test]
fn paths_resolve_against_the_manifest_and_defaults_apply() {
    let d = tempfile::tempdir().unwrap();
    let text = "[defaults]\nfeatures = \"paper\"\n\n[[group]]\nname = \"a\"\ndata = \"in/a.csv\"\nout = \"/abs/a.fbgm\"\nmax_centres = 16\n\n[[group]]\nname = \"b\"\ndata = \"b.csv\"\nout = \"b.fbgm\"\nfeatures = \"all\"\n";
    let m = Manifest::from_str_at(text, &d.path().join("m.toml")).unwrap();
    assert_eq!(m.groups[0].data, d.path().join("in/a.csv"));
    assert_eq!(m.groups[0].out, PathBuf::from("/abs/a.fbgm"));
    assert_eq!((m.groups[0].features.name(), m.groups[0].max_centres), ("paper", 16));
    assert_eq!((m.groups[1].features.name(), m.groups[1].max_centres), ("all", fleet::DEFAULT_MAX_CENTRES));
    assert_eq!(m.groups[1].baseline_path(), d.path().join("b-p.fbgm"));
}

#[test]
fn resume_skips_finished_groups_and_redoes_corrupt_or_changed_ones() {
    let d = tempfile::tempdir().unwrap();
    let m = Manifest::from_file(&manifest(d.path(), 4, "")).unwrap();
    let r1 = fleet::run(&m, 2, false).unwrap();
    assert_eq!((r1.trained, r1.skipped, r1.failed), (4, 0, 0), "{}", r1.text());
    for g in &m.groups {
        assert!(fbg_trainer::export::read_blob(&g.out).is_ok());
        assert!(fbg_trainer::export::read_blob(&g.baseline_path()).is_ok());
        assert!(g.coefficients_path().exists() && g.sidecar_path().exists());
    }
    let before: Vec<Vec<u8>> = m.groups.iter().map(|g| std::fs::read(&g.out).unwrap()).collect();

    // Nothing changed: nothing is redone and no output is touched.
    let r2 = fleet::run(&m, 2, false).unwrap();
    assert_eq!((r2.trained, r2.skipped, r2.failed), (0, 4, 0), "{}", r2.text());
    let after: Vec<Vec<u8>> = m.groups.iter().map(|g| std::fs::read(&g.out).unwrap()).collect();
    assert_eq!(before, after);

    // A corrupt blob (one flipped byte), a run interrupted before its record was written, and
    // changed input data are each redone; the rest is skipped.
    let mut bytes = before[0].clone();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x40;
    std::fs::write(&m.groups[0].out, &bytes).unwrap();
    std::fs::remove_file(m.groups[1].sidecar_path()).unwrap();
    short_csv(d.path(), "g2", 99);
    let r3 = fleet::run(&m, 1, false).unwrap();
    assert_eq!((r3.trained, r3.skipped, r3.failed), (3, 1, 0), "{}", r3.text());
    assert_eq!(status(&r3, "g3"), Outcome::Skipped);
    let reasons: Vec<_> = r3.groups.iter().map(|g| g.reason.clone().unwrap_or_default()).collect();
    assert!(reasons[0].contains("corrupt"), "{reasons:?}");
    assert!(reasons[1].contains("no record"), "{reasons:?}");
    assert!(reasons[2].contains("input changed"), "{reasons:?}");
    assert_eq!(std::fs::read(&m.groups[0].out).unwrap(), before[0], "the redone fit is deterministic");
    assert!(fbg_trainer::export::read_blob(&m.groups[0].out).is_ok());

    // Options are part of the input: a different K limit retrains that group.
    let path = d.path().join("fleet.toml");
    let text = std::fs::read_to_string(&path).unwrap().replacen(
        "out = \"models/g3.fbgm\"",
        "out = \"models/g3.fbgm\"\nmax_centres = 16",
        1,
    );
    std::fs::write(&path, text).unwrap();
    let m = Manifest::from_file(&path).unwrap();
    let r4 = fleet::run(&m, 2, false).unwrap();
    assert_eq!((r4.trained, r4.skipped), (1, 3), "{}", r4.text());
    assert!(matches!(status(&r4, "g3"), Outcome::Trained { .. }));
}

#[test]
fn a_failing_group_does_not_stop_the_others() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("bad.csv"), "t_s,T_amb_C,dl1_pm,dl2_pm,dl3_pm\n0,20,1,2,oops\n").unwrap();
    let extra = "\n[[group]]\nname = \"missing\"\ndata = \"nowhere.csv\"\nout = \"models/missing.fbgm\"\n\
                 \n[[group]]\nname = \"bad\"\ndata = \"bad.csv\"\nout = \"models/bad.fbgm\"\n";
    let path = manifest(d.path(), 3, extra);
    let m = Manifest::from_file(&path).unwrap();
    let r = fleet::run(&m, 2, false).unwrap();
    assert_eq!((r.trained, r.failed), (3, 2), "{}", r.text());
    match status(&r, "missing") {
        Outcome::Failed { error } => assert!(error.contains("nowhere.csv"), "{error}"),
        o => panic!("{o:?}"),
    }
    match status(&r, "bad") {
        Outcome::Failed { error } => assert!(error.contains("bad.csv") && error.contains("line 2"), "{error}"),
        o => panic!("{o:?}"),
    }
    assert!(!d.path().join("models/bad.fbgm").exists() && !d.path().join("models/bad.fleet.json").exists());

    // The CLI reports every group and fails; a rerun redoes only the failures.
    let o = Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
        .args(["fleet", "--jobs", "2", "--json", "--manifest"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        (j["trained"].as_u64(), j["skipped"].as_u64(), j["failed"].as_u64()),
        (Some(0), Some(3), Some(2)),
        "{j}"
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("2 of 5 groups failed"), "{err}");
}

/// Shards of one manifest run at once as separate processes into one directory: each trains
/// only its groups, writes its own summary, and together they write exactly the bytes of one
/// unsharded run; `fleet status` then reports every group done and exits 0.
#[test]
fn concurrent_shards_share_a_directory_without_clobbering() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path(), 6, "");
    let n = 3;
    let children: Vec<_> = (0..n)
        .map(|i| {
            Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
                .args(["fleet", "--json", "--jobs", "1", "--shard", &format!("{i}/{n}"), "--manifest"])
                .arg(&m)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let mut trained = 0;
    for (i, c) in children.into_iter().enumerate() {
        let out = c.wait_with_output().unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(r["shard"]["index"], i);
        let summary = d.path().join(format!("fleet.toml.shard-{i}-of-{n}.json"));
        let on_disk: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
        assert_eq!(on_disk["groups"], r["groups"]);
        for g in r["groups"].as_array().unwrap() {
            assert_eq!(fbg_trainer::fleet::shard::shard_of(g["name"].as_str().unwrap(), n), i);
        }
        trained += r["trained"].as_u64().unwrap();
    }
    assert_eq!(trained, 6, "every group trained by exactly one shard");
    let st = fleet::status(&Manifest::from_file(&m).unwrap(), Some(n));
    assert!(st.all_done, "{st:?}");
    // The same manifest unsharded, in another directory: the same bytes.
    let d2 = tempfile::tempdir().unwrap();
    for i in 0..6 {
        // A record is its CSV and its sidecar (the zero and clock the blob carries).
        for f in [format!("g{i}.csv"), format!("g{i}.record.json")] {
            std::fs::copy(d.path().join(&f), d2.path().join(&f)).unwrap();
        }
    }
    std::fs::copy(&m, d2.path().join("fleet.toml")).unwrap();
    let r = fleet::run(&Manifest::from_file(&d2.path().join("fleet.toml")).unwrap(), 2, false).unwrap();
    assert_eq!(r.trained, 6);
    for i in 0..6 {
        for f in [format!("models/g{i}.fbgm"), format!("models/g{i}-p.fbgm")] {
            assert_eq!(std::fs::read(d.path().join(&f)).unwrap(), std::fs::read(d2.path().join(&f)).unwrap(), "{f}");
        }
    }
}

/// `fleet status` tells done, failed (with the error), stale (inputs changed) and missing
/// apart, and exits non-zero unless every group is done.
#[test]
fn status_reports_done_failed_stale_and_missing() {
    let d = tempfile::tempdir().unwrap();
    let m = manifest(d.path(), 4, "\n[[group]]\nname = \"bad\"\ndata = \"bad.csv\"\nout = \"models/bad.fbgm\"\n");
    std::fs::write(d.path().join("bad.csv"), "not,a,dataset\n1,2,3\n").unwrap();
    let man = Manifest::from_file(&m).unwrap();
    // Before any run: everything missing.
    let st = fleet::status(&man, None);
    assert_eq!(st.counts["missing"], 5, "{st:?}");
    let r = fleet::run(&man, 2, false).unwrap();
    assert_eq!((r.trained, r.failed), (4, 1));
    // g1's data changes (stale); g2's blob is deleted (missing); g0 and g3 stay done.
    short_csv(d.path(), "g1", 99);
    std::fs::remove_file(d.path().join("models/g2.fbgm")).unwrap();
    let st = fleet::status(&man, Some(2));
    let state = |n: &str| st.groups.iter().find(|g| g.name == n).unwrap().clone();
    assert_eq!(state("g0").state, fleet::GroupState::Done);
    assert_eq!(state("g3").state, fleet::GroupState::Done);
    assert_eq!(state("g1").state, fleet::GroupState::Stale);
    assert_eq!(state("g2").state, fleet::GroupState::Missing);
    assert!(state("g2").reason.unwrap().contains("output missing"));
    let bad = state("bad");
    assert_eq!(bad.state, fleet::GroupState::Failed);
    assert!(bad.reason.as_deref().unwrap_or("").contains("bad.csv"), "{bad:?}");
    assert_eq!(bad.shard, Some(fbg_trainer::fleet::shard::shard_of("bad", 2)));
    assert_eq!((st.counts["done"], st.counts["failed"], st.counts["stale"], st.counts["missing"]), (2, 1, 1, 1));
    // The command exits non-zero and names the count; JSON on stdout.
    let out = Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
        .args(["fleet", "status", "--json", "--manifest"])
        .arg(&m)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("3 of 5 groups are not done"));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["counts"]["stale"], 1);
    // A rerun redoes only what is not done; a fixed bad group then succeeds and its failure
    // record goes away.
    std::fs::copy(d.path().join("g0.csv"), d.path().join("bad.csv")).unwrap();
    let r = fleet::run(&man, 2, false).unwrap();
    assert_eq!((r.trained, r.skipped, r.failed), (3, 2, 0));
    assert!(!d.path().join("models/bad.fleet-failed.json").exists());
    assert!(fleet::status(&man, None).all_done);
}

/// `[defaults] sign`: every blob signed with its own serial of the key (issued under the key's
/// lock), the signatures in `coefficients.json`, the key id in the input digest (a run that
/// signs redoes groups finished unsigned; the same key again skips them).
#[test]
fn a_signing_manifest_signs_every_blob_with_its_own_serial() {
    use fbg_shared::{container::Envelope, signature};
    let d = tempfile::tempdir().unwrap();
    let key = d.path().join("keys/lab.key");
    fbg_trainer::sign::keygen(&key).unwrap();
    let unsigned = manifest(d.path(), 2, "");
    let r = fleet::run(&Manifest::from_file(&unsigned).unwrap(), 2, false).unwrap();
    assert_eq!(r.trained, 2);
    let text = std::fs::read_to_string(&unsigned)
        .unwrap()
        .replace("[defaults]\n", "[defaults]\nsign = \"keys/lab.key\"\nserial_state = \"state\"\n");
    std::fs::write(&unsigned, text).unwrap();
    let m = Manifest::from_file(&unsigned).unwrap();
    assert_eq!(m.sign.as_deref(), Some(key.as_path()));
    let r = fleet::run(&m, 2, false).unwrap();
    assert_eq!(r.trained, 2, "signing redoes the groups finished unsigned");
    let public = fbg_trainer::sign::read_public_key(&d.path().join("keys/lab.pub")).unwrap();
    let trusted = [signature::TrustedKey { id: signature::key_id(&public), public }];
    let mut serials = Vec::new();
    for g in &m.groups {
        for blob in [g.out.clone(), g.baseline_path()] {
            let bytes = std::fs::read(&blob).unwrap();
            let Envelope::Signed(s) = fbg_shared::container::open(&bytes).unwrap() else {
                panic!("{} unsigned", blob.display())
            };
            assert_eq!(signature::verify(&s, &trusted), Ok(()), "{}", blob.display());
            serials.push(s.head.serial);
        }
        let coef: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(g.coefficients_path()).unwrap()).unwrap();
        assert_eq!(coef["signatures"]["model_h"]["key_id"], trusted[0].id.to_string());
    }
    serials.sort();
    assert_eq!(serials, [1, 2, 3, 4], "one serial per blob");
    let r = fleet::run(&m, 2, false).unwrap();
    assert_eq!(r.skipped, 2, "signed with the same key: finished");
    assert!(fleet::status(&m, None).all_done, "fleet status reads the signed groups as done");
}

/// `drift_spec_pm_per_sqrt_day` in `[defaults]` or a group: a number from 0 to 1000
/// pm/√day, as `train --drift-spec`; anything else is refused naming the file and the key
/// (checked in `[defaults]` even when every group gives its own), and each group's job is
/// trained with its own value or the default.
#[test]
fn a_stated_drift_in_the_manifest_is_checked_naming_its_key() {
    let g = |name: &str, extra: &str| {
        format!("\n[[group]]\nname = \"{name}\"\ndata = \"a.csv\"\nout = \"{name}.fbgm\"\n{extra}")
    };
    let key = "drift_spec_pm_per_sqrt_day";
    for (bad, what) in
        [("-1", "stated drift is -1"), ("1000.5", "stated drift is 1000.5"), ("nan", "NaN"), ("\"2\"", "number")]
    {
        let e = err_of(&format!("[defaults]\n{key} = {bad}\n{}", g("a", "")));
        assert!(e.contains("m.toml") && e.contains(&format!("defaults.{key}")) && e.contains(what), "{bad}: {e}");
        let e = err_of(&format!("[defaults]\n{key} = {bad}\n{}", g("a", &format!("{key} = 1\n"))));
        assert!(e.contains(&format!("defaults.{key}")), "{bad}, overridden: {e}");
        let e = err_of(&format!("{}{}", g("a", ""), g("b", &format!("{key} = {bad}\n"))));
        assert!(e.contains("m.toml") && e.contains(&format!("group[1].{key}")) && e.contains(what), "{bad}: {e}");
        // Named once, with no `fit: ` before the message.
        assert_eq!(e.matches(key).count(), 1, "{e}");
        assert!(!e.contains("fit:"), "{e}");
    }
    // The bounds themselves, an integer, the default and a group's own value.
    let d = tempfile::tempdir().unwrap();
    let text = format!(
        "[defaults]\n{key} = 1000\n{}{}{}",
        g("a", ""),
        g("b", &format!("{key} = 0\n")),
        g("c", &format!("{key} = 2.5\n"))
    );
    let m = Manifest::from_str_at(&text, &d.path().join("m.toml")).unwrap();
    let specs: Vec<Option<f64>> =
        m.groups.iter().map(|g| g.train_options().unwrap().drift_spec_pm_per_sqrt_day()).collect();
    assert_eq!(specs, [Some(1000.0), Some(0.0), Some(2.5)]);
    let m = Manifest::from_str_at(&g("a", ""), &d.path().join("m.toml")).unwrap();
    assert_eq!(m.groups[0].train_options().unwrap().drift_spec_pm_per_sqrt_day(), None);
}

/// `drift_gains` in `[defaults]` or a group: an array of numbers in -10 ..= 10, as
/// `train --drift-gains`; anything else is refused naming the file and the key, and each
/// group's job is trained with its own gains or the default's.
#[test]
fn drift_gains_in_the_manifest_are_checked_naming_their_key() {
    let g = |name: &str, extra: &str| {
        format!("\n[[group]]\nname = \"{name}\"\ndata = \"a.csv\"\nout = \"{name}.fbgm\"\n{extra}")
    };
    let key = "drift_gains";
    for (bad, what) in [
        ("1.1", "array of numbers"),
        ("[1.0, \"x\"]", "array of numbers"),
        ("[1.0, 11]", "drift gain 2 is 11"),
        ("[]", "0 drift gains"),
        ("[1.0, nan]", "NaN"),
    ] {
        let e = err_of(&format!("[defaults]\n{key} = {bad}\n{}", g("a", "")));
        assert!(e.contains("m.toml") && e.contains(&format!("defaults.{key}")) && e.contains(what), "{bad}: {e}");
        let e = err_of(&format!("{}{}", g("a", ""), g("b", &format!("{key} = {bad}\n"))));
        assert!(e.contains(&format!("group[1].{key}")) && e.contains(what), "{bad}: {e}");
    }
    let d = tempfile::tempdir().unwrap();
    let text =
        format!("[defaults]\n{key} = [1, 1.1]\n{}{}", g("a", ""), g("b", &format!("{key} = [1.0, -2.0, 1.5]\n")));
    let m = Manifest::from_str_at(&text, &d.path().join("m.toml")).unwrap();
    let gains: Vec<Option<Vec<f64>>> =
        m.groups.iter().map(|g| g.train_options().unwrap().drift_gains().map(<[f64]>::to_vec)).collect();
    assert_eq!(gains, [Some(vec![1.0, 1.1]), Some(vec![1.0, -2.0, 1.5])]);
    let m = Manifest::from_str_at(&g("a", ""), &d.path().join("m.toml")).unwrap();
    assert_eq!(m.groups[0].train_options().unwrap().drift_gains(), None);
}

/// A stated drift reaches each group's fit: on the same record the band's growth is exactly
/// what `train --drift-spec` fits; on temperature and pressure (the outputs a common-mode
/// drift moves) the band adds the walk s_c²·q with q = spec²/86 400 s [pm²/s], far above the
/// fitted growth, four times as much for twice the stated drift (the walk is nearly all of
/// it); and nothing but the band changes. A day's record
/// is too short to read the walk from the errors (`selection.drift_rate_pm2_per_s`, the rate
/// from the errors, stays null), so without a stated drift the growth is the
/// fitted one. Adding the stated drift to `[defaults]` redoes only the group that takes it.
#[test]
fn a_stated_drift_in_the_manifest_reaches_each_groups_band_growth() {
    let d = tempfile::tempdir().unwrap();
    short_csv(d.path(), "g", 10);
    let group = |name: &str, extra: &str| {
        format!("\n[[group]]\nname = \"{name}\"\ndata = \"g.csv\"\nout = \"models/{name}.fbgm\"\n{extra}")
    };
    let head = "[defaults]\nfeatures = \"paper\"\nmax_centres = 8\n";
    let groups = [
        group("plain", ""),
        group("stated", "drift_spec_pm_per_sqrt_day = 200.0\n"),
        group("doubled", "drift_spec_pm_per_sqrt_day = 400\n"),
    ]
    .concat();
    let path = d.path().join("fleet.toml");
    std::fs::write(&path, format!("{head}{groups}")).unwrap();
    let m = Manifest::from_file(&path).unwrap();
    let r = fleet::run(&m, 2, false).unwrap();
    assert_eq!((r.trained, r.failed), (3, 0), "{}", r.text());
    let coef = |name: &str| -> serde_json::Value {
        let p = d.path().join(format!("models/{name}.coefficients.json"));
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let growth = |c: &serde_json::Value| -> Vec<f64> {
        c["model_h"]["band"]["resid_var_growth_per_s"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect()
    };
    let (plain, stated, doubled) = (coef("plain"), coef("stated"), coef("doubled"));
    let g1 = growth(&stated);
    // Exactly what `train --features paper --max-centres 8 --drift-spec 200` fits on this record.
    let record = fbg_trainer::data::Dataset::read_csv(&d.path().join("g.csv")).unwrap();
    let opts = fbg_trainer::fit::FeatureChoice::Paper
        .train_options(8)
        .unwrap()
        .to_builder()
        .drift_spec_pm_per_sqrt_day(Some(200.0))
        .check()
        .unwrap();
    let alone = fbg_trainer::fit::train(&record, &opts, &fbg_trainer::fit::Origin::default()).unwrap();
    let b: Vec<f64> = alone.selection.var_model_h.iter().map(|v| v.b).collect();
    assert_eq!(g1, b, "the group's band grows as `train --drift-spec 200` makes it");
    // The band's half-width² grows by k95²·b per second.
    let band_growth = |c: &serde_json::Value| -> Vec<f64> {
        let k = c["model_h"]["band"]["k95"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap());
        k.zip(growth(c)).map(|(k, b)| k * k * b).collect()
    };
    let (h0, h1, h2) = (band_growth(&plain), band_growth(&stated), band_growth(&doubled));
    for c in [0, 2] {
        assert!(h1[c] > 10.0 * h0[c], "the stated walk widens output {c}: {h0:?} → {h1:?}");
        let r = h2[c] / h1[c];
        assert!((r - 4.0).abs() < 0.04, "output {c}: twice the stated drift, four times the growth: {h1:?} → {h2:?}");
    }
    for c in [&plain, &stated, &doubled] {
        assert!(c["selection"]["drift_rate_pm2_per_s"].is_null(), "{}", c["selection"]);
        assert_eq!(c["model_h"]["poly_B_physical_units"], plain["model_h"]["poly_B_physical_units"]);
        assert_eq!(c["model_h"]["rbf_centres"], plain["model_h"]["rbf_centres"]);
    }

    // The default applies to the group without its own: that group alone is redone, and its
    // band now grows as the group that stated the same drift.
    std::fs::write(&path, format!("{head}drift_spec_pm_per_sqrt_day = 400\n{groups}")).unwrap();
    let m = Manifest::from_file(&path).unwrap();
    let r = fleet::run(&m, 2, false).unwrap();
    assert_eq!((r.trained, r.skipped), (1, 2), "{}", r.text());
    assert!(matches!(status(&r, "plain"), Outcome::Trained { .. }));
    assert_eq!(growth(&coef("plain")), growth(&coef("doubled")));
}
