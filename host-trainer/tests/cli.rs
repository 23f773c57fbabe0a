//! The command line end to end: bad input names the place and leaves no output behind.

use crate::common;
use common::{bin, run};

#[test]
fn simulate_twice_gives_identical_bytes_and_a_meta_sidecar() {
    let d = tempfile::tempdir().unwrap();
    let (a, b) = (d.path().join("a.csv"), d.path().join("b.csv"));
    for p in [&a, &b] {
        let (ok, _, err) = run(bin().args(["simulate", "--preset", "paper", "--seed", "7", "--out"]).arg(p));
        assert!(ok, "{err}");
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("a.meta.json")).unwrap()).unwrap();
    assert_eq!(meta["seed"], 7);
    let (ok, out, _) = run(bin().args(["simulate", "--seed", "7", "--json", "--out"]).arg(&a));
    assert!(ok);
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["samples"], 20160);
    assert!(j["oracle_floor_rmse_holdout"]["T_C"].as_f64().unwrap() > 0.0);
}

#[test]
fn bad_config_names_file_and_key() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("s.toml");
    std::fs::write(&cfg, "[noise]\npink_sigma = 1.0\n").unwrap();
    let out = d.path().join("x.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--config"]).arg(&cfg).arg("--out").arg(&out));
    assert!(!ok);
    assert!(err.contains("s.toml") && err.contains("pink_sigma"), "{err}");
    assert!(!out.exists(), "no output on error");
    std::fs::write(&cfg, "[hysteresis]\nplay_half_width_pm = -2\n").unwrap();
    let (ok, _, err) = run(bin().args(["simulate", "--config"]).arg(&cfg).arg("--out").arg(&out));
    assert!(!ok && err.contains("hysteresis.play_half_width_pm"), "{err}");
}

#[test]
fn train_on_a_bad_csv_names_line_and_column_and_writes_nothing() {
    let d = tempfile::tempdir().unwrap();
    let csv = d.path().join("bad.csv");
    std::fs::write(
        &csv,
        "t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split\n0,20,0,150,20,1,2,3,cal\n60,20,0,150,NaN,1,2,3,cal\n",
    )
    .unwrap();
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(!ok);
    assert!(err.contains("bad.csv") && err.contains("line 3") && err.contains("T_amb_C"), "{err}");
    assert!(!model.exists());
    let entries: Vec<_> = std::fs::read_dir(d.path()).unwrap().collect();
    assert_eq!(entries.len(), 1, "only the input remains");
}

/// An option out of its range is refused before any file is read, naming the flag once and
/// without the `fit: ` of a fit that failed (`--drift-spec: fit: …` before); a negative
/// number is read as the option's value, not as an unknown flag. `bench-fit --fixed`'s
/// hyper-parameters are held to the ranges the model blob accepts (they failed after the whole
/// fit, as `fit: assembled model is invalid: model parameter hyper.alpha …`).
#[test]
fn option_errors_name_the_flag_once() {
    let d = tempfile::tempdir().unwrap();
    let (csv, model) = (d.path().join("none.csv"), d.path().join("m.fbgm"));
    let holdout = d.path().join("holdout.csv");
    let drift = "--drift-spec: the stated drift is -1 pm/√day; give 0 to 1000 pm/√day";
    let sigma = "--sigma-mult must be above 0 and at most 1e6";
    let cases: [(&[&str], &str, &str); 13] = [
        (&["train", "--drift-spec", "-1"], "--drift-spec", drift),
        (
            &["train", "--drift-spec=5000"],
            "--drift-spec",
            "--drift-spec: the stated drift is 5000 pm/√day; give 0 to 1000 pm/√day",
        ),
        (
            &["train", "--max-centres", "0"],
            "--max-centres",
            "--features/--max-centres: max centres must be in 1..=128 (got 0)",
        ),
        (&["bench-fit", "--drift-spec", "-1"], "--drift-spec", drift),
        (
            &["bench-fit", "--max-centres", "0"],
            "--max-centres",
            "--max-centres: max centres must be in 1..=128 (got 0)",
        ),
        (&["bench-fit", "--fixed", "--k", "0"], "--k", "--k must be in 1..=128"),
        (&["bench-fit", "--fixed", "--alpha-rel", "-1"], "--alpha-rel", "--alpha-rel must be in 0..=1e12 (got -1)"),
        (&["bench-fit", "--fixed", "--alpha-rel=-1"], "--alpha-rel", "--alpha-rel must be in 0..=1e12 (got -1)"),
        (
            &["bench-fit", "--fixed", "--alpha-rel", "1e13"],
            "--alpha-rel",
            "--alpha-rel must be in 0..=1e12 (got 10000000000000)",
        ),
        (&["bench-fit", "--fixed", "--sigma-mult", "0"], "--sigma-mult", &format!("{sigma} (got 0)")),
        (&["bench-fit", "--fixed", "--sigma-mult", "-2"], "--sigma-mult", &format!("{sigma} (got -2)")),
        // With the memory terms the options went to the fit unchecked.
        (&["bench-fit", "--fixed", "--memory", "--sigma-mult=inf"], "--sigma-mult", &format!("{sigma} (got inf)")),
        (
            &["bench-fit", "--fixed", "--dead-band-pm", "-4"],
            "--dead-band-pm",
            "--dead-band-pm must be in 0..=1e6 (got -4)",
        ),
    ];
    for (args, flag, message) in cases {
        let mut cmd = bin();
        cmd.args(args).arg("--data").arg(&csv);
        if args[0] == "train" {
            cmd.arg("--out").arg(&model);
        } else {
            cmd.arg("--holdout-errors").arg(&holdout);
        }
        refused_naming_once(&mut cmd, args, flag, message);
        assert!(!model.exists() && !holdout.exists());
    }
    let dead_band = ["bench-fit", "--fixed", "--dead-band-pm", "nan", "--data"];
    let (ok, _, err) = run(bin().args(dead_band).arg(&csv));
    assert!(!ok && err.trim_end() == "error: --dead-band-pm must be in 0..=1e6 (got NaN)", "{err}");
}

/// Run `cmd` (`args` for messages): it fails with exactly `error: {message}`, naming `flag`
/// once.
fn refused_naming_once(cmd: &mut std::process::Command, args: &[&str], flag: &str, message: &str) {
    let (ok, _, err) = run(cmd);
    assert!(!ok, "{args:?}");
    assert_eq!(err.trim_end(), format!("error: {message}"), "{args:?}");
    assert_eq!(err.matches(flag).count(), 1, "{args:?}: {err}");
}

/// The other commands' options the same way: `fleet --shard` names the option once (it was
/// `fleet: shard: --shard: shard index …`), and a negative number given to a numeric option
/// is its value (clap said "unexpected argument '-1'"), refused by the option's range. Every
/// input is missing, so each error comes before any file is read; nothing is written.
#[test]
fn option_errors_of_other_commands_name_the_flag_once() {
    let d = tempfile::tempdir().unwrap();
    let p = |name: &str| d.path().join(name).display().to_string();
    let (manifest, none, out, model) = (p("fleet.toml"), p("none.csv"), p("out.csv"), p("m.fbgm"));
    let not_below = "--shard 5/2: the index 5 is not below the count 2 (shards count from 0)";
    let timeout = "--timeout must be a positive number of seconds up to 1e9";
    let cases: Vec<(Vec<&str>, &str, String)> = vec![
        (vec!["fleet", "--shard", "5/2", "--manifest", &manifest], "--shard", not_below.into()),
        (
            vec!["fleet", "--shard", "0/0", "--manifest", &manifest],
            "--shard",
            "--shard 0/0: the count must be at least 1".into(),
        ),
        (
            vec!["fleet", "--shard", "1of2", "--manifest", &manifest],
            "--shard",
            "--shard 1of2: not I/N (e.g. 0/4)".into(),
        ),
        (vec!["fleet", "--shards", "0", "--manifest", &manifest], "--shards", "--shards must be at least 1".into()),
        (
            vec!["fleet", "status", "--manifest", &manifest, "--shards", "0"],
            "--shards",
            "--shards must be at least 1 (got 0)".into(),
        ),
        (vec!["simulate", "--pace", "-1", "--out", &out], "--pace", "--pace: -1 is out of range [0.001, 1000]".into()),
        (vec!["simulate", "--pace", "0", "--out", &out], "--pace", "--pace: 0 is out of range [0.001, 1000]".into()),
        (
            vec!["simulate", "--spectra", &none, "--snr-db", "nan", "--out", &out],
            "--snr-db",
            "--snr-db: NaN is not a number of dB".into(),
        ),
        // The demo's spectrum flags: clap said "unexpected argument '-0'", and the range error
        // came from the grating design without the flag's name.
        (
            vec!["demo", "--spectra", "--snr-db", "nan", "--out", &out],
            "--snr-db",
            "--snr-db: NaN is not a number of dB".into(),
        ),
        (
            vec!["demo", "--spectra", "--reflectivity", "-0.5", "--out", &out],
            "--reflectivity",
            "--reflectivity: -0.5 is out of range (0, 0.9999)".into(),
        ),
        (
            vec!["demo", "--spectra", "--reflectivity", "1", "--out", &out],
            "--reflectivity",
            "--reflectivity: 1 is out of range (0, 0.9999)".into(),
        ),
        (
            vec!["import", "--format", "csv", &none, "--cal-fraction", "-0.5", "--out", &out],
            "--cal-fraction",
            "--cal-fraction: -0.5 is not a fraction in (0, 1]".into(),
        ),
        (
            vec!["import", "--format", "csv", &none, "--max-skipped", "-1", "--out", &out],
            "--max-skipped",
            "--max-skipped must be a percentage from 0 to 100 (got -1)".into(),
        ),
        (
            vec!["peaks", "--format", "spectra-csv", &none, "--max-skipped", "-1", "--out", &out],
            "--max-skipped",
            "--max-skipped must be a percentage from 0 to 100 (got -1)".into(),
        ),
        (
            vec!["recalibrate", "--model", &model, "--data", &none, "--batch-hours", "-1", "--out", &out],
            "--batch-hours",
            "--batch-hours must be positive (got -1)".into(),
        ),
        (
            vec!["stream", "--model", &model, "--data", &none, "--port", "1", "--timeout", "-5"],
            "--timeout",
            format!("{timeout} (got -5)"),
        ),
        (vec!["device", "status", "--port", "1", "--timeout", "-1"], "--timeout", format!("{timeout} (got -1)")),
        // Beyond what a duration holds: this panicked in `Duration::from_secs_f64`.
        (vec!["device", "status", "--port", "1", "--timeout", "1e300"], "--timeout", format!("{timeout} (got 1e300)")),
    ];
    for (args, flag, message) in cases {
        refused_naming_once(bin().args(&args), &args, flag, &message);
        let written: Vec<_> = std::fs::read_dir(d.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert!(written.is_empty(), "{args:?}: nothing written, found {written:?}");
    }
}

/// A negative number where one makes sense is taken as the option's value, as with `=`: an SNR
/// below 0 dB (noise above the peak), a calibration split before the first row (no calibration
/// rows: a field record).
#[test]
fn negative_values_that_make_sense_are_accepted() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("tiny.toml");
    std::fs::write(&cfg, "name = \"tiny\"\n[clock]\ndays = 0.1\n").unwrap();
    let (csv, spectra) = (d.path().join("t.csv"), d.path().join("s.csv"));
    let (ok, _, err) = run(bin()
        .args(["simulate", "--snr-db", "-3", "--config"])
        .arg(&cfg)
        .arg("--spectra")
        .arg(&spectra)
        .arg("--out")
        .arg(&csv));
    assert!(ok, "{err}");
    assert!(spectra.exists());
    let logger = d.path().join("logger.csv");
    std::fs::write(&logger, "t_s,T_C,T_amb_C,dl1_pm\n0,20.0,19.5,1.5\n10,20.5,19.6,6.5\n20,21.0,19.7,11.5\n").unwrap();
    let out = d.path().join("field.csv");
    let (ok, _, err) =
        run(bin().args(["import", "--format", "csv", "--cal-until", "-1", "--out"]).arg(&out).arg(&logger));
    assert!(ok, "{err}");
    assert!(err.contains("split (until -1): cal up to t_s = -1.000 s: 0 cal rows, 3 hold-out rows"), "{err}");
}

#[test]
fn inspect_rejects_a_corrupt_blob_by_name() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("junk.fbgm");
    std::fs::write(&p, b"FBGM\x02\x00\x05\x00\x03\x00\x0a\x00\x20\x00\x02\x00junkjunk").unwrap();
    let (ok, _, err) = run(bin().arg("inspect").arg(&p));
    assert!(!ok);
    assert!(err.contains("junk.fbgm") && (err.contains("CRC") || err.contains("truncated")), "{err}");
}

#[test]
fn inspect_refuses_an_old_format_naming_both_versions() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("old.fbgm");
    // A genuine old blob has a valid CRC (a header with a bad CRC is reported as corruption).
    let mut b = b"FBGM\x01\x00\x05\x00\x03\x00\x0a\x00\x02\x00junkjunk".to_vec();
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(&b);
    b.extend_from_slice(&crc.to_le_bytes());
    std::fs::write(&p, b).unwrap();
    let (ok, _, err) = run(bin().arg("inspect").arg(&p));
    assert!(!ok);
    assert!(err.contains("old.fbgm") && err.contains("version 1") && err.contains("version 7"), "{err}");
}

#[test]
fn train_evaluate_inspect_round_trip_on_a_short_scenario() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("short.toml");
    std::fs::write(&cfg, "name = \"short\"\n[clock]\ndays = 3.0\n").unwrap();
    let csv = d.path().join("data.csv");
    assert!(run(bin().args(["simulate", "--seed", "2", "--config"]).arg(&cfg).arg("--out").arg(&csv)).0);
    let model = d.path().join("model.fbgm");
    let (ok, out, err) =
        run(bin().args(["train", "--json", "--max-centres", "16", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert!(j["chosen"]["k"].as_u64().unwrap() <= 16);
    assert!(d.path().join("model-p.fbgm").exists() && d.path().join("model.coefficients.json").exists());
    let (ok, out, err) = run(bin().args(["inspect", "--json"]).arg(&model));
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["header"]["format_version"], 7);
    assert_eq!((j["header"]["gratings"].as_u64(), j["header"]["measurands"].as_u64()), (Some(3), Some(3)));
    assert_eq!(j["header"]["ambient"], true);
    assert_eq!(j["model"]["model_dims"]["measurands"], serde_json::json!(["T_C", "strain_ue", "p_kPa"]));
    assert_eq!(j["model"]["provenance"]["scenario"], "short");
    assert_eq!(j["model"]["provenance"]["seed"], 2);
    let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(&model));
    assert!(ok, "{err}");
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("model.metrics.json")).unwrap()).unwrap();
    assert!(m["table2"]["model_h"]["channels"][1]["rmse"].as_f64().unwrap() > 0.0);
    assert!(m["table2"]["oracle_floor"].is_array(), "the sidecar gives the oracle floor");
}

/// A reference outlier in the calibration rows is refused naming file, line
/// and column (nothing written); `--on-error skip` leaves its row out and says so on the
/// terminal, in `--json` and in `coefficients.json`'s `warnings`; train prints what it chose,
/// memory groups and λ included.
#[test]
fn train_refuses_a_reference_outlier_by_line_or_skips_it_and_says_what_it_chose() {
    let d = tempfile::tempdir().unwrap();
    let cfg = d.path().join("short.toml");
    std::fs::write(&cfg, "name = \"short\"\n[clock]\ndays = 3.0\n").unwrap();
    let sim = d.path().join("sim.csv");
    assert!(run(bin().args(["simulate", "--seed", "23", "--config"]).arg(&cfg).arg("--out").arg(&sim)).0);
    // Line 1002 (the header is line 1) is a calibration row: its T_C (second column) becomes 1e6.
    let text = std::fs::read_to_string(&sim).unwrap();
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(k, l)| {
            if k + 1 == 1002 {
                assert!(l.ends_with(",cal"), "{l}");
                let mut cells: Vec<&str> = l.split(',').collect();
                cells[1] = "1000000";
                cells.join(",")
            } else {
                l.to_string()
            }
        })
        .collect();
    let csv = d.path().join("cal.csv");
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();

    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(!ok);
    assert!(
        err.contains("cal.csv: line 1002, column T_C: reference outlier: 1000000 °C where the running median is "),
        "{err}"
    );
    assert!(err.contains("--on-error skip"), "{err}");
    assert!(!model.exists() && !d.path().join("m.coefficients.json").exists());

    let (ok, _, err) = run(bin().args(["train", "--on-error", "skip", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    assert!(
        err.contains("warning: left out 1 calibration row with a reference outlier in T_C (line 1002: 1000000 °C"),
        "{err}"
    );
    assert!(err.contains("chose hysteresis-aware features, K = ") && err.contains("dead band"), "{err}");
    assert!(err.contains("memory terms: T ") && err.contains("λ = "), "{err}");
    let coef: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.path().join("m.coefficients.json")).unwrap()).unwrap();
    let w = coef["warnings"].as_array().unwrap();
    let skipped =
        w.iter().find(|w| w["code"] == "reference_outliers_skipped").expect("the warning in coefficients.json");
    assert_eq!(skipped["channel"], "T");
    assert_eq!(skipped["numbers"]["first_line"], 1002.0);

    let (ok, out, err) = run(bin()
        .args(["train", "--json", "--on-error", "skip", "--data"])
        .arg(&csv)
        .arg("--out")
        .arg(d.path().join("j.fbgm")));
    assert!(ok, "{err}");
    let j: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(j["outliers_skipped"]["rows"], 1);
    assert_eq!(j["outliers_skipped"]["lines"], serde_json::json!([1002]));
    assert_eq!(j["warnings"], coef["warnings"]);
    let memory = j["chosen"]["memory"].as_array().unwrap();
    let outputs: Vec<&str> = memory.iter().map(|m| m["output"].as_str().unwrap()).collect();
    assert_eq!(outputs, ["T", "strain", "p"]);
    assert!(memory.iter().all(|m| m["groups"].is_array()));
    assert!(j["chosen"]["sigma"].as_f64().unwrap() > 0.0 && j["chosen"]["alpha"].as_f64().unwrap() > 0.0);
    assert!(j["chosen"]["k"].as_u64().is_some() && j["chosen"]["dead_band_pm"].as_f64().is_some());
}
