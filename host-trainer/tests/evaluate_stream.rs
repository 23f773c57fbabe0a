//! `evaluate --quick` on a record without a simulation sidecar streams its rows: the same metrics.json as the in-memory path, bit for bit apart from the timings,
//! on the paper's layout and on one whose hysteresis grating is found by correlation, and a
//! peak memory that does not grow with the record.

use std::path::{Path, PathBuf};

use crate::common;
#[cfg(target_os = "linux")]
use common::run_peak_rss;
use common::{bin, run};

use fbg_trainer::data::Dataset;
use fbg_trainer::eval::metrics::Metrics;
use fbg_trainer::eval::studies::{evaluate_models, Studies};
use fbg_trainer::eval::{streamed, warnings};
use fbg_trainer::export;
use fbg_trainer::sim::scenario::Preset;

/// A 3-day record of `preset` (sidecar beside it), a model trained on it, and a copy of the
/// record without sidecar with gaps in an input and in a reference: (record, model).
fn setup(dir: &Path, preset: Preset) -> (PathBuf, PathBuf) {
    let mut cfg = preset.config();
    cfg.clock.days = 3.0;
    let toml_path = dir.join("short.toml");
    std::fs::write(&toml_path, toml::to_string(&cfg).unwrap()).unwrap();
    let csv = dir.join("sim.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "2", "--config"]).arg(&toml_path).arg("--out").arg(&csv));
    assert!(ok, "{err}");
    let model = dir.join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let mut rec = String::new();
    let mut n = 0;
    for l in std::fs::read_to_string(&csv).unwrap().lines() {
        if l.starts_with('#') || l.starts_with("t_s") {
            rec.push_str(l);
        } else {
            n += 1;
            let mut cells: Vec<&str> = l.split(',').collect();
            let last_input = cells.len() - 2;
            if n % 17 == 0 {
                cells[last_input] = "";
            }
            if n % 23 == 0 {
                cells[1] = "";
            }
            rec.push_str(&cells.join(","));
        }
        rec.push('\n');
    }
    let path = dir.join("real.csv");
    std::fs::write(&path, rec).unwrap();
    assert!(!fbg_trainer::sim::meta::meta_path(&path).exists());
    (path, model)
}

fn baseline(model: &Path) -> PathBuf {
    model.with_file_name("m-p.fbgm")
}

/// The in-memory path's metrics (the whole record read, every estimate kept), with `train`'s
/// warnings merged in as the CLI does.
fn in_memory(rec: &Path, model: &Path) -> Metrics {
    let (p, h) = (export::read_blob(&baseline(model)).unwrap(), export::read_blob(model).unwrap());
    let d = Dataset::read_csv(rec).unwrap();
    let studies = Studies { pace: true, ..Studies::NONE };
    let mut m = evaluate_models(&p, &h, &d, None, studies, false, &|_| {}).unwrap();
    m.warnings = warnings::merge(warnings::from_coefficients(&export::coefficients_path(model)), m.warnings);
    m
}

fn without_timings(text: &str) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
    assert!(v.as_object_mut().unwrap().remove("timings_s").is_some());
    v
}

fn same_metrics_as_in_memory(preset: Preset) {
    let d = tempfile::tempdir().unwrap();
    let (rec, model) = setup(d.path(), preset);
    let old = in_memory(&rec, &model);
    // The library: every float to the bit (the shortest text of two different f64 differs).
    let (p, h) = (export::read_blob(&baseline(&model)).unwrap(), export::read_blob(&model).unwrap());
    let mut new = streamed::evaluate_quick(&p, &h, &rec, false).unwrap();
    new.warnings = warnings::merge(warnings::from_coefficients(&export::coefficients_path(&model)), new.warnings);
    let text = |m: &Metrics| {
        let mut m = m.clone();
        m.timings_s.clear();
        serde_json::to_string(&m).unwrap()
    };
    assert_eq!(text(&new), text(&old));
    // The case has what the sums must get right: gaps skipped, a hysteresis index, an audit.
    assert!(old.table2.model_h.channels.iter().all(|c| c.n > 0 && c.n < old.holdout_samples));
    assert!(old.table2.model_h.channels.iter().any(|c| c.hysteresis_index != 0.0 && c.r2.is_finite()));
    assert!(old.static_fidelity.is_some());
    // The CLI's metrics.json.
    let out = d.path().join("metrics.json");
    let (ok, _, err) = run(bin()
        .args(["evaluate", "--quick", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&rec)
        .arg("--metrics")
        .arg(&out));
    assert!(ok, "{err}");
    let written = std::fs::read_to_string(&out).unwrap();
    assert_eq!(without_timings(&written), without_timings(&serde_json::to_string_pretty(&old).unwrap()));
}

#[test]
fn quick_evaluate_of_a_real_record_is_the_in_memory_one_on_the_paper_layout() {
    same_metrics_as_in_memory(Preset::Paper);
}

#[test]
fn quick_evaluate_of_a_real_record_is_the_in_memory_one_where_the_grating_is_found_by_correlation() {
    same_metrics_as_in_memory(Preset::StrainPair);
}

#[cfg(target_os = "linux")]
#[test]
fn quick_evaluate_memory_does_not_grow_with_the_record() {
    let d = tempfile::tempdir().unwrap();
    let small = d.path().join("small.csv");
    let (ok, _, err) = run(bin().args(["simulate", "--seed", "3", "--out"]).arg(&small));
    assert!(ok, "{err}");
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&small).arg("--out").arg(&model));
    assert!(ok, "{err}");
    // The same 14 days sampled 10 and 20 times finer: both past the calibration rows the
    // static audit reads (the one part of the record held, bounded), real records (no sidecar).
    let record = |name: &str, dt_s: f64| {
        let cfg = d.path().join(format!("{name}.toml"));
        std::fs::write(&cfg, format!("[clock]\ndt_s = {dt_s}\n")).unwrap();
        let csv = d.path().join(format!("{name}.csv"));
        let (ok, _, err) = run(bin().args(["simulate", "--seed", "3", "--config"]).arg(&cfg).arg("--out").arg(&csv));
        assert!(ok, "{err}");
        std::fs::remove_file(fbg_trainer::sim::meta::meta_path(&csv)).unwrap();
        csv
    };
    let (a_csv, b_csv) = (record("a", 6.048), record("b", 3.024));
    let peak = |data: &Path| {
        let out = d.path().join("metrics.json");
        let (ok, err, rss) = run_peak_rss(
            bin()
                .args(["evaluate", "--quick", "--model"])
                .arg(&model)
                .arg("--data")
                .arg(data)
                .arg("--metrics")
                .arg(&out),
        );
        assert!(ok, "{err}");
        rss
    };
    let (a, b) = (peak(&a_csv), peak(&b_csv));
    eprintln!("evaluate --quick peak RSS: {} kB on 201 600 rows, {} kB on 403 200 rows", a >> 10, b >> 10);
    // Before it streamed, the record and both models' hold-out estimates were held: tens of
    // MB more for the longer record here.
    assert!(b < a + (4 << 20), "{} kB vs {} kB", b >> 10, a >> 10);
}

#[test]
fn a_bad_cell_late_in_a_real_record_is_named_and_nothing_is_written() {
    let d = tempfile::tempdir().unwrap();
    let (rec, model) = setup(d.path(), Preset::Paper);
    // A bad cell in the hold-out, far past what the first rows decide.
    let text = std::fs::read_to_string(&rec).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let at = lines.len() - 10;
    let mut bad = String::new();
    for (i, l) in lines.iter().enumerate() {
        if i == at {
            let (_, rest) = l.split_once(',').unwrap();
            bad.push_str(&format!("x1e,{rest}"));
        } else {
            bad.push_str(l);
        }
        bad.push('\n');
    }
    let bad_csv = d.path().join("bad.csv");
    std::fs::write(&bad_csv, bad).unwrap();
    let out = d.path().join("metrics.json");
    let (ok, _, err) = run(bin()
        .args(["evaluate", "--quick", "--model"])
        .arg(&model)
        .arg("--data")
        .arg(&bad_csv)
        .arg("--metrics")
        .arg(&out));
    assert!(!ok);
    assert!(err.contains("bad.csv") && err.contains(&format!("line {}", at + 1)) && err.contains("t_s"), "{err}");
    assert!(!out.exists());
}
