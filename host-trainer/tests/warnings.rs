//! Every warning is data. `metrics.json` carries a `warnings` list (code,
//! channel, message, numbers) — `train`'s from the model's `coefficients.json`, then the
//! evaluation's; `evaluate` prints exactly that list; the report opens with it; and the
//! summary, tables and captions name only the measurands and inputs the model has.

use std::path::Path;
use std::sync::OnceLock;

use fbg_trainer::eval::warnings;
use fbg_trainer::report::load;
use fbg_trainer::sim::meta::SimMeta;
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;
use fbg_trainer::warning::Warning;

use crate::common;
use common::{bin, run};

/// A train-time warning as `train` records it in `coefficients.json` (its `warnings` array).
fn train_warning() -> Warning {
    Warning::new("outlier_rows_skipped", "3 calibration rows with a reference outlier were left out").with("rows", 3.0)
}

/// `temperature-1` without a thermometer (4 days), trained, evaluated (every study) and
/// reported with the CLI in one directory, a train-time warning added to its
/// `coefficients.json` before `evaluate`; with `evaluate`'s stderr.
fn one_output_no_thermometer() -> &'static (tempfile::TempDir, String) {
    static DIR: OnceLock<(tempfile::TempDir, String)> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path();
        let mut cfg = Preset::Temperature1.config();
        cfg.ambient.thermometer = false;
        cfg.clock.days = 4.0;
        let s = simulate(&cfg, 5);
        let csv = p.join("data.csv");
        s.data.write_csv(&csv).unwrap();
        SimMeta::of(&s).write(&csv).unwrap();
        let model = p.join("model.fbgm");
        let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(&model));
        assert!(ok, "{err}");
        let coef = p.join("model.coefficients.json");
        let mut c: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&coef).unwrap()).unwrap();
        c["warnings"] = serde_json::json!([train_warning()]);
        std::fs::write(&coef, c.to_string()).unwrap();
        let (ok, _, eval_err) = run(bin().args(["evaluate", "--data"]).arg(&csv).arg("--model").arg(&model));
        assert!(ok, "{eval_err}");
        let (ok, _, err) = run(bin().args(["report", "--out"]).arg(p));
        assert!(ok, "{err}");
        (dir, eval_err)
    })
}

fn read(p: &Path) -> String {
    std::fs::read_to_string(p).unwrap()
}

/// `html` with the block between `<tag…id="id"` and its closing `</tag>` cut out.
fn without(html: &str, open: &str, close: &str) -> String {
    match html.find(open) {
        Some(i) => {
            let j = i + html[i..].find(close).unwrap() + close.len();
            format!("{}{}", &html[..i], &html[j..])
        }
        None => html.to_string(),
    }
}

/// The text of the page (tags and inline SVG removed, entities for `<`, `>`, `&` decoded).
fn text(html: &str) -> String {
    let mut out = String::new();
    let mut rest = html;
    while let Some(i) = rest.find('<') {
        out.push_str(&rest[..i]);
        let j = rest[i..].find('>').map_or(rest.len(), |j| i + j + 1);
        out.push(' ');
        rest = &rest[j..];
    }
    out.push_str(rest);
    out.replace("&lt;", "<").replace("&gt;", ">").replace("&amp;", "&")
}

#[test]
fn metrics_json_carries_train_and_evaluate_warnings_and_evaluate_prints_that_list() {
    let (dir, err) = one_output_no_thermometer();
    let m = load::read_metrics(&dir.path().join("model.metrics.json")).unwrap();
    let codes: Vec<&str> = m.warnings.iter().map(|w| w.code.as_str()).collect();
    // train's first, as recorded.
    assert_eq!(m.warnings.first(), Some(&train_warning()), "{codes:?}");
    let thermo = m.warnings.iter().find(|w| w.code == "no_ambient_thermometer").expect("no_ambient_thermometer");
    assert_eq!(thermo.channel.as_deref(), Some("T"));
    // Every evaluation warning the numbers call for, and none they do not.
    let t = &m.table2;
    assert_eq!(codes.contains(&"model_h_worse_holdout"), t.gain_pct[0] < 0.0, "{codes:?}");
    assert_eq!(codes.contains(&"model_h_band_coverage_low"), t.model_h.channels[0].coverage < 0.9, "{codes:?}");
    assert_eq!(codes.contains(&"model_p_band_coverage_low"), t.model_p.channels[0].coverage < 0.9, "{codes:?}");
    // The terminal says exactly the list, in order: one source.
    let printed: Vec<&str> = err.lines().filter_map(|l| l.strip_prefix("warning: ")).collect();
    let listed: Vec<&str> = m.warnings.iter().map(|w| w.message.as_str()).collect();
    assert_eq!(printed, listed, "{err}");
    // The JSON has the four fields of a warning.
    let raw: serde_json::Value = serde_json::from_str(&read(&dir.path().join("model.metrics.json"))).unwrap();
    let w = raw["warnings"].as_array().unwrap().iter().find(|w| w["code"] == "no_ambient_thermometer").unwrap();
    assert_eq!((w["channel"].as_str(), w["message"].as_str().is_some()), (Some("T"), true), "{w}");
}

#[test]
fn the_report_opens_with_the_warnings() {
    let (dir, _) = one_output_no_thermometer();
    let html = read(&dir.path().join("index.html"));
    let m = load::read_metrics(&dir.path().join("model.metrics.json")).unwrap();
    let block = html.find("id=\"warnings\"").expect("a warnings block");
    let summary = html.find("<section id=\"summary\"").unwrap();
    assert!(block < summary && block < html.find("<nav>").unwrap(), "the warnings come first");
    let shown = text(&html[block..summary]);
    assert!(shown.contains(&format!("{} warnings", m.warnings.len())), "{shown}");
    for w in &m.warnings {
        assert!(shown.contains(&w.message) && shown.contains(&w.code), "{} not shown in: {shown}", w.code);
    }
}

#[test]
fn a_one_output_report_without_a_thermometer_names_no_absent_measurand_or_input() {
    let (dir, _) = one_output_no_thermometer();
    let html = read(&dir.path().join("index.html"));
    // Left out: the warnings (which say what is missing: "no ambient thermometer", "no drift
    // observer") and the scenario's verbatim TOML (every parameter of the simulator, usable
    // with --config, which keeps the sections of absent measurands as their defaults).
    let page = without(&without(&html, "<div class=\"warn\" id=\"warnings\">", "</div>"), "<details>", "</details>");
    let page = text(&page);
    assert!(page.contains("temperature"), "the model's own measurand is named");
    for absent in ["pressure", "strain", "T_amb", "drift observer", "drift-observer", "ambient-high-pass", "kPa", "µε"]
    {
        let at: Vec<String> = page
            .match_indices(absent)
            .map(|(i, _)| page[i.saturating_sub(80)..(i + 80).min(page.len())].replace('\n', " "))
            .collect();
        assert!(at.is_empty(), "the page names “{absent}”: {at:#?}");
    }
    // So do the table files.
    for f in ["table3.txt", "table2.txt", "error_budget.txt"] {
        let t = read(&dir.path().join(f));
        for absent in ["T_amb", "drift-observer", "ambient-high-pass", "pressure", "strain"] {
            assert!(!t.contains(absent), "{f} names {absent}:\n{t}");
        }
    }
}

/// Each evaluation warning follows its numbers: the fixture's metrics edited to make Model-H
/// worse, both bands short and the static gains disagree, with and without a thermometer.
#[test]
fn each_evaluation_warning_follows_its_numbers() {
    let (dir, _) = one_output_no_thermometer();
    let text = read(&dir.path().join("model.metrics.json"));
    let model = fbg_trainer::export::read_blob(&dir.path().join("model.fbgm")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["table2"]["model_p"]["channels"][0]["rmse"] = 0.25.into();
    v["table2"]["model_h"]["channels"][0]["rmse"] = 0.30.into();
    v["table2"]["gain_pct"][0] = (-20.0).into();
    v["table2"]["model_h"]["channels"][0]["coverage"] = 0.132.into();
    v["table2"]["model_p"]["channels"][0]["coverage"] = 0.95.into();
    v["static_fidelity"]["gain_p"][0] = 1.0.into();
    v["static_fidelity"]["gain_h"][0] = 0.9.into();
    let m = load::metrics_from_str(&v.to_string(), "edited").unwrap();
    let ws = warnings::evaluation(&m, &model.dims);
    let codes: Vec<&str> = ws.iter().map(|w| w.code.as_str()).collect();
    assert_eq!(
        codes,
        ["model_h_worse_holdout", "model_h_band_coverage_low", "static_gain_disagreement", "no_ambient_thermometer"]
    );
    assert!(ws.iter().all(|w| w.channel.as_deref() == Some("T")));
    assert_eq!(ws[0].numbers["rmse_h_c"], 0.30);
    assert_eq!(ws[0].numbers["gain_pct"], -20.0);
    assert!(ws[0].message.contains("use Model-P for T"), "{}", ws[0].message);
    assert!((ws[1].numbers["coverage_pct"] - 13.2).abs() < 1e-9);
    assert!(ws[1].message.contains("(13.2 %)"), "{}", ws[1].message);
    assert!((ws[2].numbers["difference_pct"] + 10.0).abs() < 1e-9);
    // All well: no warning but the missing thermometer; with one, none at all.
    v["table2"]["gain_pct"][0] = 10.0.into();
    v["table2"]["model_h"]["channels"][0]["coverage"] = 0.95.into();
    v["static_fidelity"]["gain_h"][0] = 1.001.into();
    let m = load::metrics_from_str(&v.to_string(), "edited").unwrap();
    let codes: Vec<String> = warnings::evaluation(&m, &model.dims).into_iter().map(|w| w.code).collect();
    assert_eq!(codes, ["no_ambient_thermometer"]);
    let with_thermometer = fbg_shared::layout::Dims::new(1, true, model.dims.outputs()).unwrap();
    assert!(warnings::evaluation(&m, &with_thermometer).is_empty());
}
