//! The command line end to end: bad input names the place and leaves no output behind.

use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
}

fn run(cmd: &mut Command) -> (bool, String, String) {
    let o = cmd.output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

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
    assert!(err.contains("old.fbgm") && err.contains("version 1") && err.contains("version 3"), "{err}");
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
    assert_eq!(j["header"]["format_version"], 3);
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
