//! A field reading you can trust: the calibration's zero and clock travel with the model.
//!
//! A single-grating installation (the `temperature-1` preset) is recorded for four days; the
//! first two calibrate (their own hold-out is the last 30 %), the last two are the "field"
//! record, exported as absolute wavelengths with plain-second times as an interrogator would.
//! Nothing here was tuned: seed 5 and the preset's defaults were taken as they came.

use crate::common;

use std::path::Path;

use common::{bin, run};
use fbg_trainer::data::Dataset;
use fbg_trainer::sim::{self, scenario::Preset};

const SEED: u64 = 5;

/// The record split in a calibration dataset and a field dataset (t_s from 0, its clock and
/// zero shifted with it).
fn record() -> (Dataset, Dataset) {
    let mut cfg = Preset::Temperature1.config();
    cfg.clock.days = 4.0;
    let d = sim::simulate(&cfg, SEED).data;
    let n = d.len();
    let mut cal = d.select(&(0..n / 2).collect::<Vec<_>>());
    cal.split_at_fraction(0.7);
    let mut field = d.select(&(n / 2..n).collect::<Vec<_>>());
    let t0 = field.t_s[0];
    field.t_s.iter_mut().for_each(|t| *t -= t0);
    field.meta = field.meta.shifted(t0);
    (cal, field)
}

/// The field record as an interrogator export: plain seconds, the ambient thermometer and the
/// grating's absolute wavelength in nm (no reference), and its map.
fn export(field: &Dataset, dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let nominal = field.meta.lambda_ref(0).unwrap();
    let mut text = String::from("t;Tamb;FBG1 [nm]\n");
    for i in 0..field.len() {
        text.push_str(&format!(
            "{:.3};{:.4};{:.7}\n",
            field.t_s[i],
            field.t_amb_c.as_ref().unwrap()[i],
            nominal + field.dl_pm[0][i] * 1e-3
        ));
    }
    let csv = dir.join("field_export.csv");
    std::fs::write(&csv, text).unwrap();
    let map = dir.join("field_map.toml");
    std::fs::write(
        &map,
        "delimiter = \";\"\n[time]\ncolumn = \"t\"\n[ambient]\ncolumn = \"Tamb\"\n[[grating]]\ncolumn = \"FBG1 [nm]\"\nunit = \"nm\"\n",
    )
    .unwrap();
    (csv, map)
}

/// RMSE of the `T_C` column of a `compensate` output against the truth.
fn rmse_of(out: &Path, truth: &[f64]) -> f64 {
    let text = std::fs::read_to_string(out).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let c = head.iter().position(|h| *h == "T_C").unwrap();
    let (mut s, mut n) = (0.0, 0usize);
    for (l, &y) in lines.zip(truth) {
        if let Ok(v) = l.split(',').nth(c).unwrap().parse::<f64>() {
            s += (v - y).powi(2);
            n += 1;
        }
    }
    assert!(n > truth.len() / 2, "{n} of {} rows compensated", truth.len());
    (s / n as f64).sqrt()
}

#[test]
fn the_zero_and_the_clock_travel_with_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let (cal, field) = record();
    let cal_csv = dir.path().join("cal.csv");
    cal.write_csv(&cal_csv).unwrap();
    let model = dir.path().join("cal.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&cal_csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let (ok, out, err) =
        run(bin().args(["evaluate", "--quick", "--json", "--data"]).arg(&cal_csv).arg("--model").arg(&model));
    assert!(ok, "{err}");
    let ev: serde_json::Value = serde_json::from_str(&out).unwrap();
    let holdout_rmse =
        ev.pointer("/table2/model_h/channels/0/rmse").and_then(|v| v.as_f64()).unwrap_or_else(|| panic!("{ev}"));
    let truth = field.refs[0].values.clone();
    let (export_csv, map) = export(&field, dir.path());

    // Imported on its own, the field record is zeroed on its first reading: compensate
    // refuses it, naming both zeros.
    let own = dir.path().join("field_own.csv");
    let (ok, _, err) = run(bin()
        .args(["import", "--format", "csv", "--cal-fraction", "1", "--map"])
        .arg(&map)
        .arg(&export_csv)
        .arg("--out")
        .arg(&own));
    assert!(ok, "{err}");
    let out = dir.path().join("out_own.csv");
    let (ok, _, err) =
        run(bin().args(["compensate", "--model"]).arg(&model).arg("--data").arg(&own).arg("--out").arg(&out));
    assert!(!ok && err.contains("λ_ref") && err.contains("first reading") && err.contains("--model"), "{err}");
    assert!(!out.exists());

    // Imported against the model's zero, with its start time, the field reads as well as
    // the calibration's own hold-out did, and its band runs on the absolute clock.
    let zeroed = dir.path().join("field_model.csv");
    let (ok, _, err) = run(bin()
        .args(["import", "--format", "csv", "--cal-fraction", "1", "--start", "2026-01-07T00:00:00", "--map"])
        .arg(&map)
        .arg(&export_csv)
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(&zeroed));
    assert!(ok, "{err}");
    let text = std::fs::read_to_string(&zeroed).unwrap();
    assert!(text.starts_with("t_s,"), "a plain table: {text:.200}");
    let side = fbg_trainer::data::record_meta::sidecar_path(&zeroed);
    let side: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(side).unwrap()).unwrap();
    assert_eq!(side["zero"][0]["lambda_ref_nm"], 1550.0, "{side}");
    assert_eq!(side["zero"][0]["source"], "model", "{side}");
    assert_eq!(side["t0_utc"], "2026-01-07T00:00:00.000Z", "{side}");
    let (ok, out, err) = run(bin()
        .args(["compensate", "--json", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&zeroed)
        .arg("--out")
        .arg(dir.path().join("out_model.csv")));
    assert!(ok, "{err}");
    let s: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(s["clock"], "absolute", "{s}");
    assert_eq!(s["flag_rows"][3], 0, "{s}");
    let rmse = rmse_of(&dir.path().join("out_model.csv"), &truth);
    // The same rows as the simulator's own shifts (its nominal zero), compensated directly:
    // the export's round trip through absolute wavelengths and the model's zero changes
    // nothing but rounding (1e-7 nm in the export).
    let direct = dir.path().join("field_direct.csv");
    field.write_csv(&direct).unwrap();
    let (ok, _, err) = run(bin()
        .args(["compensate", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&direct)
        .arg("--out")
        .arg(dir.path().join("out_direct.csv")));
    assert!(ok, "{err}");
    let rmse_direct = rmse_of(&dir.path().join("out_direct.csv"), &truth);
    assert!((rmse - rmse_direct).abs() < 1e-3, "imported {rmse} °C, direct {rmse_direct} °C");
    // The field half runs two to four days after a calibration of 1.4 days, so drift has
    // grown: within twice the calibration's own hold-out RMSE (the zeroed-on-first-reading
    // error of the example was 3.7 °C).
    assert!(rmse <= 2.0 * holdout_rmse, "field RMSE {rmse} °C against the calibration's hold-out {holdout_rmse} °C");

    // Without a start time the lead is unknown: said, flagged on every row, not a fault.
    let bare = dir.path().join("field_bare.csv");
    let (ok, _, err) = run(bin()
        .args(["import", "--format", "csv", "--cal-fraction", "1", "--map"])
        .arg(&map)
        .arg(&export_csv)
        .arg("--model")
        .arg(&model)
        .arg("--out")
        .arg(&bare));
    assert!(ok, "{err}");
    let (ok, out, err) = run(bin()
        .args(["compensate", "--json", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&bare)
        .arg("--out")
        .arg(dir.path().join("out_bare.csv")));
    assert!(ok, "{err}");
    let s: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(s["clock"], "unknown", "{s}");
    let rows = s["rows"].as_u64().unwrap();
    let grows = s["flag_rows"][3].as_u64().unwrap();
    assert!(grows == rows || grows == 0, "{s}");
    if grows > 0 {
        assert!(s["warnings"].as_array().unwrap().iter().any(|w| w["code"] == "lead_unknown"), "{s}");
    }
}

#[test]
fn compensate_checks_units_and_counts_gaps_by_the_models_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let (cal, field) = record();
    // A model without a thermometer.
    let mut cal = cal;
    cal.t_amb_c = None;
    let cal_csv = dir.path().join("cal.csv");
    cal.write_csv(&cal_csv).unwrap();
    let model = dir.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&cal_csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    // The field record keeps its thermometer column with gaps: no gap for this model.
    let mut f = field.clone();
    if let Some(a) = f.t_amb_c.as_mut() {
        a.iter_mut().step_by(3).for_each(|v| *v = f64::NAN);
    }
    let f_csv = dir.path().join("f.csv");
    f.write_csv(&f_csv).unwrap();
    let (ok, out, err) = run(bin()
        .args(["compensate", "--json", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&f_csv)
        .arg("--out")
        .arg(dir.path().join("o.csv")));
    assert!(ok, "{err}");
    let s: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(s["gap_rows"], 0, "{s}");
    // The same shifts in nm written in the pm column: refused, naming the column and the unit.
    let mut nm = field.clone();
    nm.dl_pm[0].iter_mut().for_each(|v| *v *= 1e-3);
    let nm_csv = dir.path().join("nm.csv");
    nm.write_csv(&nm_csv).unwrap();
    let out = dir.path().join("o2.csv");
    let (ok, _, err) =
        run(bin().args(["compensate", "--model"]).arg(&model).arg("--data").arg(&nm_csv).arg("--out").arg(&out));
    assert!(!ok && err.contains("dl1_pm") && err.contains("nm"), "{err}");
    assert!(!out.exists());
}

/// A two-hour calibration: the band at the end of calibration is never below the error the
/// cross-validation saw at its shortest leads, so it covers the model's own calibration rows
/// and its cross-validation errors (before the floor a steep fitted growth left s² at the end
/// of calibration at 1e-6 °C², a band that covered under 1 % of the calibration rows).
#[test]
fn a_short_calibration_has_an_honest_band() {
    use fbg_trainer::fit::{run, train, Origin, TrainOptions};
    for seed in [3u64, 8, 13] {
        let mut cfg = Preset::Temperature1.config();
        cfg.clock.days = 2.0 / 24.0 / 0.7;
        cfg.clock.dt_s = 10.0;
        cfg.clock.cal_fraction = 0.7;
        let d = sim::simulate(&cfg, seed).data;
        let t = train(&d, &TrainOptions::default().with_progress(false), &Origin { scenario: "short".into(), seed })
            .unwrap();
        for (name, model, var) in
            [("Model-P", &t.model_p, &t.selection.var_model_p), ("Model-H", &t.model_h, &t.selection.var_model_h)]
        {
            let v = &var[0];
            assert!(v.cv_coverage >= 0.9, "seed {seed} {name}: CV coverage {}", v.cv_coverage);
            assert!(v.a >= v.a_floor, "seed {seed} {name}: {v:?}");
            let cal = d.cal_indices();
            let est = run(model, &d, &cal).unwrap();
            let truth = d.refs[0].values.clone();
            let inside = cal.iter().zip(&est).filter(|&(&i, e)| (e.values[0] - truth[i]).abs() <= e.band95[0]).count();
            let frac = inside as f64 / cal.len() as f64;
            // In-sample rows at lead 0 against a band calibrated on out-of-sample errors at
            // growing leads: not 95 % (measured 61.1 to 100 % over seeds 3, 8, 13 and both
            // models), but nowhere near the failure this guards against (under 1 %).
            assert!(frac >= 0.5, "seed {seed} {name}: the band covers {:.1} % of the calibration rows", 100.0 * frac);
            assert!(model.field.lead_max_s > 0.0 && model.field.cal_end_unix_s.is_some());
        }
    }
}

/// A week after calibration, an interrogator that drifts four times the DESIGN rate (σ_d 0.2 pm
/// per minute): the temperature error is mostly the drift's walk, which the lead regression
/// of a week's cross-validation mostly reads as no growth. The band grows at least as the walk
/// read from the validation errors, and adds the interrogator's stated stability when given.
/// Seeds 41–43, none of them among the seeds the structure function's lags were chosen on.
#[test]
fn a_week_after_calibration_the_band_grows_with_the_drift() {
    use fbg_trainer::fit::{run, train, Origin, TrainOptions};
    let sigma_pm = 0.2;
    let spec_pm_per_sqrt_day = sigma_pm * (86_400.0f64 / 60.0).sqrt();
    for seed in [41u64, 42, 43] {
        let mut cfg = Preset::Temperature1.config();
        cfg.drift.sigma_pm = sigma_pm;
        let d = sim::simulate(&cfg, seed).data;
        let origin = Origin { scenario: "drifting".into(), seed };
        let coverage = |opts: &TrainOptions| {
            let t = train(&d, opts, &origin).unwrap();
            let hold = d.holdout_indices();
            let est = run(&t.model_h, &d, &hold).unwrap();
            let truth = &d.refs[0].values;
            let inside = hold.iter().zip(&est).filter(|&(&i, e)| (e.values[0] - truth[i]).abs() <= e.band95[0]).count();
            (inside as f64 / hold.len() as f64, t.selection)
        };
        let (read, s_read) = coverage(&TrainOptions::default().with_progress(false));
        let q = s_read.drift_rate_pm2_per_s.expect("a week of calibration shows the walk");
        let stated = TrainOptions::builder().drift_spec_pm_per_sqrt_day(Some(spec_pm_per_sqrt_day)).check().unwrap();
        let (with_spec, s_spec) = coverage(&stated.with_progress(false));
        // One week holds one path of the walk: the rate read is rough (measured 0.7 to 13 ×
        // the truth on these seeds), but neither zero nor blown up by a sensitivity near zero
        // (before the last fold's s_c served every fold: 800 × on seed 42).
        let truth = sigma_pm * sigma_pm / 60.0;
        assert!((0.3 * truth..30.0 * truth).contains(&q), "seed {seed}: walk {q:e} pm²/s against {truth:e}");
        // The stated walk enters the band's growth with the normal multiplier (k95²·b per
        // second, at least z₉₅² times its s_c²·q); without it, there is none.
        let (vs, vr) = (&s_spec.var_model_h[0], &s_read.var_model_h[0]);
        assert!(vs.stated_walk_rate > 0.0 && vr.stated_walk_rate.is_nan(), "{vs:?} {vr:?}");
        let z2 = fbg_shared::layout::Z95 * fbg_shared::layout::Z95;
        assert!(vs.k95 * vs.k95 * vs.b >= 0.999_999 * z2 * vs.stated_walk_rate, "{vs:?}");
        // Before the band read the walk: 86.2 % on seed 41 (now 98.2, 98.5, 98.8 %).
        for (how, c) in [("read", read), ("stated", with_spec)] {
            assert!(c >= 0.9, "seed {seed}: the band covers {:.1} % of the week after calibration ({how})", 100.0 * c);
        }
    }
}

/// The drift's gains carry the stated walk to each output as Σᵢ gᵢ·∂y/∂λᵢ: gains of g on
/// every grating scale it by g² (the plain sum times g), a gain on one grating alone gives
/// that grating's sensitivity, and a count other than the record's gratings is refused naming
/// the gains. Paper preset, two days, seed 11.
#[test]
fn drift_gains_scale_the_stated_walk_through_each_output() {
    use fbg_trainer::fit::{train, Origin, TrainOptions};
    let mut cfg = Preset::Paper.config();
    cfg.clock.days = 2.0;
    let d = sim::simulate(&cfg, 11).data;
    let origin = Origin { scenario: "paper".into(), seed: 11 };
    let opts = |gains: Option<Vec<f64>>| {
        TrainOptions::builder()
            .centres(vec![4])
            .sigma_mults(vec![1.0])
            .alpha_rels(vec![1e-4])
            .drift_spec_pm_per_sqrt_day(Some(2.0))
            .drift_gains(gains)
            .check()
            .unwrap()
    };
    let rates = |gains: Option<Vec<f64>>| -> Vec<f64> {
        let t = train(&d, &opts(gains.clone()), &origin).unwrap();
        // What the bands were told travels with the model, for the audit.
        assert_eq!((t.selection.stated_drift_pm_per_sqrt_day, &t.selection.stated_drift_gains), (Some(2.0), &gains));
        t.selection.var_model_h.iter().map(|v| v.stated_walk_rate).collect()
    };
    let (alike, doubled) = (rates(None), rates(Some(vec![2.0; 3])));
    assert_eq!(alike.len(), 3);
    for (a, b) in alike.iter().zip(&doubled) {
        assert!(*a > 0.0 && (b / a - 4.0).abs() < 1e-9, "{alike:?} {doubled:?}");
    }
    let e = train(&d, &opts(Some(vec![1.0, 1.1])), &origin).err().unwrap().to_string();
    assert!(e.contains("--drift-gains: 2 drift gains given for the 3 gratings"), "{e}");
    // Each gain reaches its own grating: the gain of one grating alone gives that grating's
    // sensitivity, s_c = |∂y_c/∂λᵢ| of the last fold's Model-P (the final Model-P's differ by
    // up to a fifth on this short record). Strain hardly reads grating 3 and pressure hardly
    // grating 1 (the final model's sensitivities say so too); a gain paired with another
    // grating would move those small values to it.
    let t = train(&d, &opts(None), &origin).unwrap();
    let jac = fbg_trainer::fit::sensitivity::core_jacobian(&t.model_p, &[0.0; fbg_shared::layout::MAX_OUTPUTS]);
    let q = 4.0 / 86_400.0;
    let s: Vec<Vec<f64>> = (0..3)
        .map(|i| {
            let mut g = vec![0.0; 3];
            g[i] = 1.0;
            rates(Some(g)).iter().map(|r| (r / q).sqrt()).collect()
        })
        .collect();
    for (c, small) in [(1, 2), (2, 0)] {
        let others = (0..3).filter(|&i| i != small);
        let least = |v: &dyn Fn(usize) -> f64| others.clone().map(v).fold(f64::INFINITY, f64::min);
        assert!(jac[c][small].abs() < 0.3 * least(&|i| jac[c][i].abs()), "{jac:?}");
        assert!(s[small][c] < 0.3 * least(&|i| s[i][c]), "output {c}: {s:?} ({jac:?})");
    }
    // The statement is in coefficients.json for the audit; the gains only when given.
    let coef = |t: &fbg_trainer::fit::Trained| -> serde_json::Value {
        serde_json::from_str(&fbg_trainer::export::ModelFiles::of(t, None).unwrap().coefficients).unwrap()
    };
    let sel = coef(&t)["selection"].clone();
    assert_eq!((sel["stated_drift_pm_per_sqrt_day"].as_f64(), sel.get("stated_drift_gains")), (Some(2.0), None));
    let t = train(&d, &opts(Some(vec![1.0, 1.1, 1.2])), &origin).unwrap();
    assert_eq!(coef(&t)["selection"]["stated_drift_gains"], serde_json::json!([1.0, 1.1, 1.2]));
}
