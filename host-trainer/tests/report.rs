//! The audit report. Every file the page references exists and is not
//! trivial, each PNG decodes at its size and carries rendered text, a changed metric changes
//! the tables and the page (no stale text), a missing data.meta.json is said, not hidden,
//! and a million samples are plotted in seconds.

use std::path::Path;
use std::sync::OnceLock;

use fbg_shared::{Estimate, FeatureSet, Flags};
use fbg_trainer::data::{Dataset, Measurand, Reference, Split};
use fbg_trainer::eval::studies::{self, Studies};
use fbg_trainer::export;
use fbg_trainer::fit::{Config, TrainOptions};
use fbg_trainer::report::{self, figures, load};
use fbg_trainer::sim::meta::SimMeta;
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;

/// A demo-like directory for a 2-day scenario trained with fixed hyper-parameters (fast),
/// built once; tests that change it work on a copy.
fn fixture() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let mut cfg = Preset::Paper.config();
        cfg.clock.days = 2.0;
        let s = simulate(&cfg, 11);
        let csv = dir.path().join("data.csv");
        s.data.write_csv(&csv).unwrap();
        SimMeta::of(&s).write(&csv).unwrap();
        let opts = TrainOptions::fixed(&Config {
            feature_set: FeatureSet::HysteresisAware,
            dead_band_pm: 4.0,
            k: 12,
            sigma_mult: 2.0,
            alpha_rel: 1e-4,
            cross_terms: true,
        });
        let (tr, m) = studies::run_all(&s, &opts, Studies::ALL, &|_| {}).unwrap();
        export::write_blob(&dir.path().join("model.fbgm"), &tr.model_h).unwrap();
        export::write_blob(&dir.path().join("model-p.fbgm"), &tr.model_p).unwrap();
        std::fs::write(dir.path().join(report::METRICS_JSON), serde_json::to_string_pretty(&m).unwrap()).unwrap();
        dir
    })
    .path()
}

/// A copy of the fixture's inputs in a fresh directory.
fn copy_inputs() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for f in ["data.csv", "data.meta.json", "model.fbgm", "model-p.fbgm", report::METRICS_JSON] {
        std::fs::copy(fixture().join(f), dir.path().join(f)).unwrap();
    }
    dir
}

/// Every `href`/`src` target of the page (anchors excluded).
fn references(html: &str) -> Vec<String> {
    let mut out = Vec::new();
    for key in ["href=\"", "src=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(key) {
            rest = &rest[i + key.len()..];
            let j = rest.find('"').unwrap();
            let target = &rest[..j];
            if !target.starts_with('#') {
                out.push(target.to_string());
            }
        }
    }
    out.sort();
    out.dedup();
    out
}

fn built() -> (&'static Path, &'static report::Outcome) {
    static OUT: OnceLock<(tempfile::TempDir, report::Outcome)> = OnceLock::new();
    let (dir, o) = OUT.get_or_init(|| {
        let dir = copy_inputs();
        let o = report::build(dir.path()).unwrap();
        (dir, o)
    });
    (dir.path(), o)
}

#[test]
fn the_page_references_only_files_that_exist_and_are_not_trivial() {
    let (dir, o) = built();
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    assert!(o.warnings.is_empty(), "a consistent directory raised warnings: {:?}", o.warnings);
    let refs = references(&html);
    assert!(refs.len() > 40, "{refs:?}");
    for r in &refs {
        assert!(!r.contains("://"), "the page must not reach the network: {r}");
        let p = dir.join(r);
        let len = std::fs::metadata(&p).unwrap_or_else(|_| panic!("{r} is referenced but missing")).len();
        let min = match Path::new(r).extension().and_then(|e| e.to_str()) {
            Some("png") => 20_000,
            Some("svg") => 5_000,
            _ => 100,
        };
        assert!(len >= min, "{r} has only {len} bytes");
    }
    // All eight figures are there, as PNG and SVG, and shown on the page.
    for stem in [
        "fig1_inputs",
        "fig2_wavelength_fbg1",
        "fig3_temperature",
        "fig4_strain",
        "fig5_pressure",
        "fig6_parity",
        "fig7_error_histograms",
        "fig8_drift_sensitivity",
    ] {
        assert!(refs.contains(&format!("{stem}.png")) && refs.contains(&format!("{stem}.svg")), "{stem}");
        assert!(html.contains(&format!("<img src=\"{stem}.svg\"")), "{stem} is not shown");
    }
    // The tables, as Markdown and CSV, and the coefficient tables.
    // Model-H with memory terms has its own B (fitted jointly with Γ): its core tables carry a
    // `_h` suffix beside Model-P's `_p`.
    let core = if refs.contains(&"coef_poly_physical_h.md".to_string()) { "_h" } else { "" };
    let (poly, stage1) = (format!("coef_poly_physical{core}"), format!("coef_stage1{core}"));
    assert!(core.is_empty() || refs.contains(&"coef_memory.md".to_string()), "a memory model shows its Γ");
    for t in [
        "table2",
        "table3",
        "error_budget",
        "drift_sweep",
        poly.as_str(),
        "coef_rbf_physical",
        "coef_rbf_standardised",
        "coef_scalers",
        "coef_hyper",
        "coef_band",
        stage1.as_str(),
    ] {
        assert!(refs.contains(&format!("{t}.md")) && refs.contains(&format!("{t}.csv")), "{t}");
    }
    // Everything the outcome lists exists.
    for f in &o.files {
        assert!(dir.join(f).is_file(), "{f}");
    }
    // Provenance and the legend names.
    assert!(html.contains("seed") && html.contains("11") && html.contains("trainer version"));
    let svg = std::fs::read_to_string(dir.join("fig3_temperature.svg")).unwrap();
    assert!(svg.contains("Model-P") && svg.contains("Model-H") && svg.contains("°C"));
}

#[test]
fn every_png_decodes_at_its_size_and_shows_text() {
    let (dir, o) = built();
    let pngs: Vec<&String> = o.files.iter().filter(|f| f.ends_with(".png")).collect();
    assert_eq!(pngs.len(), 10, "Figs. 1–10");
    for f in pngs {
        let file = std::fs::File::open(dir.join(f)).unwrap();
        let mut dec = png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap();
        let mut buf = vec![0; dec.output_buffer_size()];
        let info = dec.next_frame(&mut buf).unwrap();
        assert_eq!(info.width, figures::WIDTH, "{f}");
        assert!((1000..=1800).contains(&info.height), "{f}: height {}", info.height);
        assert_eq!(info.color_type, png::ColorType::Rgb);
        // The title band (top 70 rows) holds dark text pixels: the bundled font rendered.
        let row = info.width as usize * 3;
        let dark = buf[..70 * row].chunks(3).filter(|p| p.iter().all(|&c| c < 100)).count();
        assert!(dark > 500, "{f}: no title text ({dark} dark pixels)");
        // And the figure is not blank.
        let ink = buf.chunks(3).filter(|p| p.iter().any(|&c| c < 200)).count();
        assert!(ink > 20_000, "{f}: only {ink} inked pixels");
    }
}

fn set(v: &mut serde_json::Value, path: &[&str], x: f64) {
    let mut cur = v;
    for k in path {
        cur = match k.parse::<usize>() {
            Ok(i) => &mut cur[i],
            Err(_) => &mut cur[*k],
        };
    }
    *cur = serde_json::json!(x);
}

#[test]
fn a_changed_metric_changes_the_tables_and_the_page() {
    let dir = copy_inputs();
    report::build(dir.path()).unwrap();
    let before = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    let before_md = std::fs::read_to_string(dir.path().join("table2.md")).unwrap();
    assert!(!before.contains("Check failed"));

    let path = dir.path().join(report::METRICS_JSON);
    let mut v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    set(&mut v, &["table2", "model_h", "channels", "1", "rmse"], 1.2345);
    set(&mut v, &["table2", "gain_pct", "1"], 41.76);
    // Pin the other gains too, so the verdict sentence does not depend on the trained models.
    set(&mut v, &["table2", "gain_pct", "0"], 60.0);
    set(&mut v, &["table2", "gain_pct", "2"], 10.0);
    set(&mut v, &["table2", "model_h", "channels", "0", "coverage"], 0.5);
    std::fs::write(&path, serde_json::to_string_pretty(&v).unwrap()).unwrap();
    let o = report::build(dir.path()).unwrap();
    let after = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    let md = std::fs::read_to_string(dir.path().join("table2.md")).unwrap();
    let csv = std::fs::read_to_string(dir.path().join("table2.csv")).unwrap();

    // Tables show the new numbers.
    assert_ne!(md, before_md);
    assert!(md.contains("| 1.23 |") && csv.contains(",1.23,"), "{md}");
    assert!(md.contains("| 41.8 |") && md.contains("| 50.0 |"), "{md}");
    // The summary is regenerated from them...
    assert!(after.contains("41.8 % lower for strain"), "summary not regenerated");
    assert!(after.contains("within it for strain"));
    assert!(after.contains("Model-H's bands are too narrow for temperature"));
    assert!(after.contains("50.0 %"));
    // ...and the page says that metrics.json no longer matches the models and data.
    assert!(after.contains("Check failed") && after.contains("does not match the models and data"));
    assert!(o.warnings.iter().any(|w| w.contains("strain RMSE")), "{:?}", o.warnings);
    assert!(o.warnings.iter().any(|w| w.contains("gains disagree")), "{:?}", o.warnings);
    // The old gain is gone from the summary.
    let old: f64 = serde_json::from_str::<serde_json::Value>(
        &std::fs::read_to_string(fixture().join(report::METRICS_JSON)).unwrap(),
    )
    .unwrap()["table2"]["gain_pct"][1]
        .as_f64()
        .unwrap();
    let stale = format!("{} % lower for strain", figures::num(old, 1));
    assert!(before.contains(&stale), "the first page should state the original gain: {stale}");
    assert!(!after.contains(&stale), "stale gain {stale}");
}

#[test]
fn without_the_sidecar_figure_2_and_the_oracle_floor_are_omitted_visibly() {
    let dir = copy_inputs();
    std::fs::remove_file(dir.path().join("data.meta.json")).unwrap();
    let o = report::build(dir.path()).unwrap();
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(!o.files.iter().any(|f| f.starts_with("fig2")));
    assert!(!dir.path().join("fig2_wavelength_fbg1.png").exists());
    assert!(html.contains("Figure 2 (measured vs true wavelength) is omitted"));
    assert!(html.contains("data.meta.json is absent"));
    assert!(o.notes.iter().any(|n| n.contains("data.meta.json is absent")));
    // Every other figure is still there (Fig. 10 from the pace study in metrics.json), and
    // every reference still resolves.
    assert_eq!(o.files.iter().filter(|f| f.ends_with(".png")).count(), 9);
    for r in references(&html) {
        assert!(dir.path().join(&r).is_file(), "{r}");
    }
}

#[test]
fn an_edited_csv_is_not_passed_off_as_the_simulation() {
    let dir = copy_inputs();
    let p = dir.path().join("data.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    // Shift dl1 of one calibration sample by 1 pm.
    let mut cells: Vec<String> = lines[5].split(',').map(String::from).collect();
    cells[5] = format!("{:.6}", cells[5].parse::<f64>().unwrap() + 1.0);
    lines[5] = cells.join(",");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let o = report::build(dir.path()).unwrap();
    assert!(o.warnings.iter().any(|w| w.contains("differs from a re-simulation")), "{:?}", o.warnings);
    assert!(!o.files.iter().any(|f| f.starts_with("fig2")));
}

#[test]
fn hold_out_rows_with_gaps_are_skipped_and_said() {
    let dir = copy_inputs();
    let p = dir.path().join("data.csv");
    let text = std::fs::read_to_string(&p).unwrap();
    let mut gaps = 0;
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i > 0 && i % 97 == 0 && l.ends_with("holdout") {
                gaps += 1;
                let mut c: Vec<&str> = l.split(',').collect();
                c[6] = ""; // dl2 missing
                c.join(",")
            } else {
                l.to_string()
            }
        })
        .collect();
    assert!(gaps > 5);
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let o = report::build(dir.path()).unwrap();
    assert!(o.notes.iter().any(|n| n.contains(&format!("{gaps} of the")) && n.contains("have a gap")), "{:?}", o.notes);
    assert_eq!(
        o.files.iter().filter(|f| f.ends_with(".png")).count(),
        9,
        "Figure 2 needs the CSV to match the simulation"
    );
}

#[test]
fn metrics_json_round_trips_through_the_report_reader() {
    let text = std::fs::read_to_string(fixture().join(report::METRICS_JSON)).unwrap();
    let m = load::metrics_from_str(&text, "metrics.json").unwrap();
    let again = serde_json::to_value(&m).unwrap();
    let orig: serde_json::Value = serde_json::from_str(&text).unwrap();
    same(&again, &orig, "metrics");
}

/// Structural equality with numbers equal to 1e-14 (relative).
fn same(a: &serde_json::Value, b: &serde_json::Value, at: &str) {
    use serde_json::Value::*;
    match (a, b) {
        (Number(x), Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!((x - y).abs() <= 1e-14 * x.abs().max(y.abs()), "{at}: {x} vs {y}");
        }
        (Array(x), Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}");
            for (i, (p, q)) in x.iter().zip(y).enumerate() {
                same(p, q, &format!("{at}[{i}]"));
            }
        }
        (Object(x), Object(y)) => {
            assert_eq!(x.keys().collect::<Vec<_>>(), y.keys().collect::<Vec<_>>(), "{at}");
            for (k, p) in x {
                same(p, &y[k], &format!("{at}.{k}"));
            }
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

/// A million-sample record with synthetic estimates: building and drawing the time-series
/// figures (min/max decimation) stays in seconds.
#[test]
fn a_million_samples_plot_in_seconds() {
    let n: usize = 1_000_000;
    let dt = 1.2;
    let (mut temp, mut strain, mut p) = (Vec::new(), Vec::new(), Vec::new());
    let mut d = Dataset { t_amb_c: Some(Vec::new()), dl_pm: vec![Vec::new(); 3], ..Dataset::default() };
    for i in 0..n {
        let t = i as f64 * dt;
        d.t_s.push(t);
        temp.push(20.0 + 4.0 * (t / 86_400.0 * std::f64::consts::TAU).sin() + 0.1 * ((i * 7919) % 101) as f64 / 101.0);
        strain.push(100.0 * (t / 10_800.0 * std::f64::consts::TAU).sin());
        p.push(150.0 + 25.0 * (t / 43_200.0 * std::f64::consts::TAU).sin());
        d.t_amb_c.as_mut().unwrap().push(20.5);
        for g in 0..3 {
            d.dl_pm[g].push(0.0);
        }
        d.split.push(if i < n / 2 { Split::Cal } else { Split::Holdout });
    }
    d.refs = [(Measurand::T, temp), (Measurand::STRAIN, strain), (Measurand::P, p)]
        .into_iter()
        .map(|(measurand, values)| Reference { measurand, values })
        .collect();
    let hold = d.holdout_indices();
    let est = |bias: f64| -> Vec<Estimate<f64>> {
        hold.iter()
            .enumerate()
            .map(|(k, &i)| {
                let w = ((k * 2_654_435_761) % 1000) as f64 / 1000.0 - 0.5;
                Estimate {
                    values: std::array::from_fn(|c| d.truth(i).get(c).map_or(0.0, |t| t + bias + w)),
                    band95: [1.0, 1.0, 1.0, 0.0],
                    outputs: 3,
                    flags: Flags::OK,
                }
            })
            .collect()
    };
    let (ep, eh) = (est(0.2), est(0.0));
    let m =
        load::metrics_from_str(&std::fs::read_to_string(fixture().join(report::METRICS_JSON)).unwrap(), "metrics.json")
            .unwrap();
    let ctx = figures::Ctx {
        data: &d,
        sim: None,
        hold: &hold,
        est_p: &ep,
        est_h: &eh,
        metrics: &m,
        time: figures::TimeUnit::for_span(n as f64 * dt),
        parts_h: &[],
        dims: fbg_shared::layout::Dims::PAPER,
    };
    let out = tempfile::tempdir().unwrap();
    let t = std::time::Instant::now();
    let specs = vec![
        figures::fig1_inputs(&ctx),
        figures::fig_channel(&ctx, 0),
        figures::fig6_parity(&ctx),
        figures::fig7_errors(&ctx),
    ];
    for s in &specs {
        s.grid.write(out.path(), &s.stem).unwrap();
        // Each time-series trace is reduced to at most two points per pixel column.
        for p in &s.grid.panels {
            for l in &p.lines {
                assert!(l.pts.len() <= 2 * figures::COLUMNS + 2, "{}: {} points", s.stem, l.pts.len());
            }
        }
    }
    let secs = t.elapsed().as_secs_f64();
    assert!(specs[0].caption.contains("no extreme is lost"), "{}", specs[0].caption);
    assert!(specs[0].caption.contains("1\u{2009}000\u{2009}000 samples"), "{}", specs[0].caption);
    // Release builds take well under a second here; the bound leaves room for busy machines.
    assert!(secs < 20.0, "plotting 1e6 samples took {secs:.1} s");
    let png = std::fs::read(out.path().join("fig3_temperature.png")).unwrap();
    assert!(png.len() > 20_000);
}

/// The whole report (CSV read, re-simulation, both models over the record, figures, page) for a
/// directory of 1e6 samples. Slow to set up (simulation, CSV, a fixed-grid fit on 5e5
/// calibration samples), so not run by default:
/// `cargo test --release -p fbg-trainer --test trainer report:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn report_of_a_million_sample_directory() {
    let dir = tempfile::tempdir().unwrap();
    let mut cfg = Preset::Paper.config();
    cfg.name = "paper-1e6".into();
    cfg.clock.dt_s = 14.0 * 86_400.0 / 1e6;
    let t = std::time::Instant::now();
    let s = simulate(&cfg, 7);
    assert_eq!(s.data.len(), 1_000_000);
    let csv = dir.path().join("data.csv");
    s.data.write_csv(&csv).unwrap();
    SimMeta::of(&s).write(&csv).unwrap();
    let opts = TrainOptions::fixed(&Config {
        feature_set: FeatureSet::HysteresisAware,
        dead_band_pm: 4.0,
        k: 32,
        sigma_mult: 2.0,
        alpha_rel: 1e-5,
        cross_terms: true,
    });
    let studies = Studies { parity: true, ..Studies::NONE };
    let (tr, m) = studies::run_all(&s, &opts, studies, &|_| {}).unwrap();
    export::write_blob(&dir.path().join("model.fbgm"), &tr.model_h).unwrap();
    export::write_blob(&dir.path().join("model-p.fbgm"), &tr.model_p).unwrap();
    std::fs::write(dir.path().join(report::METRICS_JSON), serde_json::to_string_pretty(&m).unwrap()).unwrap();
    eprintln!("set-up (simulate, CSV, fit, evaluate) took {:.1} s", t.elapsed().as_secs_f64());
    let t = std::time::Instant::now();
    let o = report::build(dir.path()).unwrap();
    let secs = t.elapsed().as_secs_f64();
    eprintln!("report of 1e6 samples: {secs:.1} s, {} files, warnings {:?}", o.files.len(), o.warnings);
    assert!(o.warnings.is_empty(), "{:?}", o.warnings);
    let html = std::fs::read_to_string(dir.path().join("index.html")).unwrap();
    assert!(html.contains("no extreme is lost"));
    assert!(secs < 60.0, "{secs:.1} s");
}
