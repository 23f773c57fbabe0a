//! Every installation end to end through the command line — simulate (the preset's
//! record, seed 7), train, evaluate, report — and the blob decoded by `fbg-shared` and
//! run in f32 on golden vectors against the trainer's f64 answers. The model's dimensions are
//! the data's: its gratings, the ambient input when the record has one, its measurands.

use std::path::{Path, PathBuf};

use crate::common;
use common::{bin, run};

use fbg_link::golden;
use fbg_link::parity::{compare, REL_TOL};
use fbg_shared::protocol::DeviceEstimate;
use fbg_shared::{blob, Compensator};
use fbg_trainer::compensate::output_columns;
use fbg_trainer::data::{Dataset, Measurand};
use fbg_trainer::eval::score;
use fbg_trainer::export;
use fbg_trainer::sim::scenario::Preset;

/// The record of `preset` (seed 7) in `dir`, with or without the ambient thermometer. The
/// preset's 14 days: a record of a few days leaves much of the hold-out outside the
/// calibration envelope, where Model-H extrapolates (on the paper preset too).
fn record(dir: &Path, preset: Preset, ambient: bool) -> PathBuf {
    let mut cfg = preset.config();
    cfg.ambient.thermometer = ambient;
    let toml_path = dir.join("scenario.toml");
    std::fs::write(&toml_path, toml::to_string(&cfg).unwrap()).unwrap();
    let csv = dir.join("data.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "7", "--config"]).arg(&toml_path).arg("--out").arg(&csv));
    assert!(ok, "{err}");
    csv
}

/// Simulate, train, evaluate, report, decode and replay the golden vectors on the device path.
fn end_to_end(preset: Preset, ambient: bool, gratings: usize, measurands: &[&str]) {
    let name = format!("{}{}", preset.name(), if ambient { "" } else { " --no-ambient" });
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let csv = record(dir, preset, ambient);
    let model = dir.join("model.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{name}: {err}");
    // The CV summary names the data's measurands.
    let want: Vec<String> = measurands.iter().map(|m| m.parse::<Measurand>().unwrap().short_name()).collect();
    assert!(err.contains(&format!("CV RMSE Model-P: {} ", want[0])), "{name}: {err}");

    // The blob, decoded by fbg-shared, carries the data's dims.
    let bytes = std::fs::read(&model).unwrap();
    let p32 = blob::decode::<32>(&bytes).unwrap();
    assert_eq!((p32.dims.gratings(), p32.dims.ambient()), (gratings, ambient), "{name}");
    let h = export::read_blob(&model).unwrap();
    assert_eq!(output_columns(&h), measurands, "{name}");
    let coef: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("model.coefficients.json")).unwrap()).unwrap();
    assert_eq!(coef["model_h"]["model_dims"]["measurands"], serde_json::json!(measurands), "{name}");
    assert_eq!(
        coef["model_h"]["poly_B_standardised_guesses"].as_object().unwrap().len(),
        measurands.len(),
        "{name}: one B row per measurand"
    );
    // The memory bank follows the dims: the drift observer only with ambient and a
    // temperature output.
    assert_eq!(h.dims.has_observer(), ambient && measurands.contains(&"T_C"), "{name}");

    // evaluate: one channel per measurand, Model-H ahead of Model-P on the whole.
    let metrics = dir.join("model.metrics.json");
    let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(&model));
    assert!(ok, "{name}: {err}");
    let m: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&metrics).unwrap()).unwrap();
    let chans = m["table2"]["model_h"]["channels"].as_array().unwrap();
    assert_eq!(chans.len(), measurands.len(), "{name}");
    assert_eq!(m["channels"].as_array().unwrap().len(), measurands.len(), "{name}");
    let rmse = |model: &str| -> Vec<f64> {
        m["table2"][model]["channels"].as_array().unwrap().iter().map(|c| c["rmse"].as_f64().unwrap()).collect()
    };
    let (rp, rh) = (rmse("model_p"), rmse("model_h"));
    assert!(rh.iter().all(|r| r.is_finite() && *r > 0.0), "{name}: {rh:?}");
    assert!(rh.iter().zip(&rp).map(|(h, p)| h / p).sum::<f64>() < rp.len() as f64, "{name}: {rp:?} -> {rh:?}");
    // The simulator's sidecar gives the per-sample oracle for every measurand.
    assert_eq!(m["table2"]["oracle_floor"].as_array().unwrap().len(), measurands.len(), "{name}");

    // report: one hold-out figure per measurand, no empty panels, names from the measurands.
    let rep = dir.join("report");
    let (ok, _, err) = run(bin()
        .args(["report", "--out"])
        .arg(&rep)
        .arg("--data")
        .arg(&csv)
        .arg("--model")
        .arg(&model)
        .arg("--metrics")
        .arg(&metrics));
    assert!(ok, "{name}: {err}");
    let html = std::fs::read_to_string(rep.join("index.html")).unwrap();
    for c in 0..measurands.len() {
        let stem = fbg_trainer::report::figures::channel_stem(&h.dims, c);
        assert!(rep.join(format!("{stem}.svg")).is_file(), "{name}: {stem}");
        assert!(html.contains(&stem), "{name}: {stem}");
    }
    for stem in ["fig1_inputs", "fig6_parity", "fig7_error_histograms"] {
        let svg = std::fs::read_to_string(rep.join(format!("{stem}.svg"))).unwrap();
        assert!(!svg.contains("no reference for this channel"), "{name}: {stem} has an empty panel");
    }
    let t2 = std::fs::read_to_string(rep.join("table2.md")).unwrap();
    for (ch, unit) in h.dims.outputs().iter().map(|o| (o.channel(), o.unit())) {
        assert!(t2.contains(&format!("{ch} [{unit}]")), "{name}: {t2}");
    }
    if measurands.len() < 3 {
        assert!(!t2.contains("p [kPa]") && !html.contains("fig5_pressure"), "{name}");
    }

    // Golden vectors: the f64 reference on f32 inputs, replayed through Compensator<f32> on
    // the decoded blob, within the device tolerance.
    let gold = dir.join("golden");
    let (ok, _, err) = run(bin()
        .args(["golden", "--samples", "200", "--data"])
        .arg(&csv)
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(&gold));
    assert!(ok, "{name}: {err}");
    let inputs = golden::parse_inputs(&std::fs::read(gold.join("golden_inputs.bin")).unwrap()).unwrap();
    let expected = golden::parse_expected(&std::fs::read_to_string(gold.join("golden_expected.csv")).unwrap()).unwrap();
    assert_eq!((inputs.len(), expected.len()), (200, 200), "{name}");
    assert!(inputs.iter().all(|s| usize::from(s.gratings) == gratings), "{name}");
    let tol: Vec<f64> = rh.iter().map(|r| REL_TOL * r).collect();
    let mut device = Compensator::<f32, 32>::new(&p32).unwrap();
    for (k, (x, want)) in inputs.iter().zip(&expected).enumerate() {
        let e = device.step(x);
        let got = DeviceEstimate::new(0, &e);
        compare(&got, want, &tol).unwrap_or_else(|m| panic!("{name}: golden sample {k}: {m}"));
    }
}

#[test]
fn temperature_1_end_to_end() {
    end_to_end(Preset::Temperature1, true, 1, &["T_C"]);
}

#[test]
fn strain_pair_end_to_end() {
    end_to_end(Preset::StrainPair, true, 2, &["T_C", "strain_ue"]);
}

#[test]
fn array_8_end_to_end() {
    end_to_end(Preset::Array8, true, 8, &["T_C", "strain_ue", "strain2_ue", "p_kPa"]);
}

#[test]
fn paper_without_ambient_end_to_end() {
    end_to_end(Preset::Paper, false, 3, &["T_C", "strain_ue", "p_kPa"]);
}

/// `compensate` writes `evaluate`'s estimates bit for bit for a strain pair (the paper's case
/// is in `compensate.rs`): its columns are the model's measurands.
#[test]
fn compensate_matches_evaluate_bit_for_bit_on_a_strain_pair() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = record(tmp.path(), Preset::StrainPair, true);
    let model = tmp.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let out = tmp.path().join("comp.csv");
    let (ok, js, err) =
        run(bin().args(["compensate", "--json", "--model"]).arg(&model).arg("--data").arg(&csv).arg("--out").arg(&out));
    assert!(ok, "{err}");
    let summary: serde_json::Value = serde_json::from_str(&js).unwrap();
    assert_eq!(summary["reference_errors"]["channels"], serde_json::json!(["T", "strain"]));
    let text = std::fs::read_to_string(&out).unwrap();
    assert_eq!(text.lines().next().unwrap(), "t_s,T_C,T_C_band95,strain_ue,strain_ue_band95,flags,flag_names");
    let data = Dataset::read_csv(&csv).unwrap();
    let params = export::read_blob(&model).unwrap();
    let hold: Vec<usize> = data.holdout_indices().into_iter().filter(|&i| data.usable(i)).collect();
    let want = score::estimates(&params, &data, &hold).unwrap();
    let got: Vec<Vec<String>> = text.lines().skip(1).map(|l| l.split(',').map(str::to_string).collect()).collect();
    assert_eq!(got.len(), data.len());
    for (e, &i) in want.iter().zip(&hold) {
        for c in 0..2 {
            let v: f64 = got[i][1 + 2 * c].parse().unwrap();
            let b: f64 = got[i][2 + 2 * c].parse().unwrap();
            assert_eq!(v.to_bits(), e.values[c].to_bits(), "row {i} channel {c}");
            assert_eq!(b.to_bits(), e.band95[c].to_bits(), "row {i} band {c}");
        }
        assert_eq!(got[i][5], e.flags.0.to_string());
    }
}

/// `demo` runs every study on other installations: the drift sweep, Table 3, the error budget
/// and the recalibration study carry one value per measurand, their tables name the
/// measurands, and an error-budget row the scenario cannot support (array-8 with every
/// artefact off: its temperature-only gratings are then exactly collinear) is a row marked
/// "not fitted", not a failed demo.
///
/// On 5 days of each preset (its scenario written as a `--config`), not its 14: what is
/// checked is the studies' shapes, which do not depend on the record's length.
#[test]
fn demo_runs_every_study_for_any_installation() {
    for (p, measurands) in [(Preset::StrainPair, 2usize), (Preset::Array8, 4)] {
        let preset = p.name();
        let tmp = tempfile::tempdir().unwrap();
        let mut config = p.config();
        config.clock.days = 5.0;
        let toml_path = tmp.path().join("scenario.toml");
        std::fs::write(&toml_path, toml::to_string(&config).unwrap()).unwrap();
        let out = tmp.path().join("demo");
        let (ok, _, err) = run(bin().args(["demo", "--config"]).arg(&toml_path).arg("--out").arg(&out));
        assert!(ok, "{preset}: {err}");
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("model.metrics.json")).unwrap()).unwrap();
        let len = |v: &serde_json::Value| v.as_array().map(|a| a.len()).unwrap_or(0);
        assert_eq!(len(&m["drift_sweep"]["slope_h"]), measurands, "{preset}");
        assert!(m["drift_sweep"]["rmse_h"].as_array().unwrap().iter().all(|r| len(r) == measurands), "{preset}");
        assert!(m["ablation"].as_array().unwrap().iter().all(|r| len(&r["channels"]) == measurands), "{preset}");
        assert!(m["error_budget"].as_array().unwrap().iter().all(|r| len(&r["rmse_h"]) == measurands), "{preset}");
        assert!(m["recalibration"].as_array().unwrap().iter().all(|r| len(&r["h_short"]) == measurands), "{preset}");
        let t3 = std::fs::read_to_string(out.join("table3.md")).unwrap();
        assert!(t3.contains("strain [µε]") && t3.contains("T [°C]"), "{preset}: {t3}");
        assert_eq!(t3.contains("p [kPa]"), measurands == 4, "{preset}: {t3}");
        let budget = std::fs::read_to_string(out.join("error_budget.md")).unwrap();
        if preset == "array-8" {
            assert!(budget.contains("all (not fitted)") && budget.contains("ε2 H"), "{budget}");
        } else {
            assert!(!budget.contains("not fitted") && !budget.contains("p H"), "{budget}");
        }
    }
}
