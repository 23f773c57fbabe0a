//! The checks a new user relies on, the same in every command — a cap on what
//! `--on-error skip` may drop, the unit checks of `import` in `train` and `evaluate`, a
//! truncated last line, and help texts.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;
use common::{bin, run, short_csv};

/// `csv` with the ambient cell of every `every`-th data row replaced by `x`.
fn spoil_ambient(csv: &Path, out: &Path, every: usize) -> usize {
    let text = common::read_csv_body(csv);
    let mut n = 0;
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i > 0 && i % every == 0 {
                n += 1;
                let mut cells: Vec<&str> = l.split(',').collect();
                cells[4] = "x";
                cells.join(",")
            } else {
                l.to_string()
            }
        })
        .collect();
    std::fs::write(out, lines.join("\n") + "\n").unwrap();
    n
}

#[test]
fn on_error_skip_fails_above_the_skipped_fraction_with_counts_by_reason() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    // One row in 4 is bad: 25 % > the default 5 %.
    let bad = d.path().join("bad.csv");
    let n_bad = spoil_ambient(&csv, &bad, 4);
    let out = d.path().join("out.csv");
    let (ok, _, err) =
        run(bin().args(["import", "--format", "csv", "--on-error", "skip"]).arg(&bad).arg("--out").arg(&out));
    assert!(!ok, "a 25 % loss must not pass silently");
    assert!(err.contains("bad.csv") && err.contains(&format!("{n_bad} of 4320 rows")), "{err}");
    assert!(err.contains("non_numeric") && err.contains("5 %"), "{err}");
    assert!(!out.exists(), "nothing written");
    // The cap is configurable ...
    let (ok, _, err) = run(bin()
        .args(["import", "--format", "csv", "--on-error", "skip", "--max-skipped", "30"])
        .arg(&bad)
        .arg("--out")
        .arg(&out));
    assert!(ok && err.contains(&format!("skipped {n_bad} × non_numeric")), "{err}");
    // ... and a few bad rows (1 in 100) pass under the default.
    let few = d.path().join("few.csv");
    let n_few = spoil_ambient(&csv, &few, 100);
    let (ok, _, err) =
        run(bin().args(["import", "--format", "csv", "--on-error", "skip"]).arg(&few).arg("--out").arg(&out));
    assert!(ok && err.contains(&format!("{n_few} skipped as bad")), "{err}");
}

/// `csv` with column `col` rewritten by `f`.
fn map_column(csv: &Path, out: &Path, col: usize, f: impl Fn(f64) -> f64) {
    let text = common::read_csv_body(csv);
    let mut lines = text.lines();
    let mut s = lines.next().unwrap().to_string() + "\n";
    for l in lines {
        let mut cells: Vec<String> = l.split(',').map(str::to_string).collect();
        cells[col] = format!("{:.6}", f(cells[col].parse::<f64>().unwrap()));
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    std::fs::write(out, s).unwrap();
}

#[test]
fn train_and_evaluate_run_the_unit_checks_of_import_with_its_messages() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    // Ambient in kelvin; a shift column holding absolute wavelengths in nm.
    let kelvin = d.path().join("kelvin.csv");
    map_column(&csv, &kelvin, 4, |v| v + 273.15);
    let nm = d.path().join("nm.csv");
    map_column(&csv, &nm, 5, |v| 1545.0 + v * 1e-3);
    for (bad, column, says) in
        [(&kelvin, "T_amb_C", "looks like kelvin"), (&nm, "dl1_pm", "like absolute wavelengths in nm")]
    {
        let out = d.path().join("imported.csv");
        let (ok, _, import_err) = run(bin().args(["import", "--format", "csv"]).arg(bad).arg("--out").arg(&out));
        assert!(!ok && import_err.contains(says), "import: {import_err}");
        let (ok, _, train_err) = run(bin()
            .args(["train", "--max-centres", "8", "--data"])
            .arg(bad)
            .arg("--out")
            .arg(d.path().join("x.fbgm")));
        assert!(!ok, "train accepted {}", bad.display());
        assert!(
            train_err.contains(says) && train_err.contains(column) && train_err.contains("line 2"),
            "train: {train_err}"
        );
        let (ok, _, eval_err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(bad).arg("--model").arg(&model));
        assert!(!ok && eval_err.contains(says) && eval_err.contains(column), "evaluate: {eval_err}");
        // The same words as import's message (up to its own file name and line).
        let core = |e: &str| e.split(": ").skip(2).collect::<Vec<_>>().join(": ");
        let i = core(&import_err);
        let key_advice = i.split(';').nth(1).unwrap_or_default().trim().to_string();
        assert!(
            !key_advice.is_empty() && train_err.contains(&key_advice),
            "import says `{key_advice}`; train: {train_err}"
        );
    }
}

fn import_data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/import").join(name)
}

/// `src` cut `cut` bytes before its end (inside the last number, no final line end).
fn cut_copy(src: &Path, dst: &Path, cut: usize) {
    let b = std::fs::read(src).unwrap();
    std::fs::write(dst, &b[..b.len() - cut]).unwrap();
}

#[test]
fn a_last_line_without_a_line_end_is_a_truncated_ragged_row() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out.csv");
    // ENLIGHT peaks cut inside the last wavelength: `…1550.5019\t\n` -> `…1550.50`.
    let peaks = d.path().join("cut.txt");
    cut_copy(&import_data("enlight_tab.txt"), &peaks, 4);
    let enlight = |extra: &[&str]| {
        run(bin()
            .args(["import", "--format", "enlight"])
            .arg(&peaks)
            .arg("--map")
            .arg(import_data("enlight_map.toml"))
            .arg("--refs")
            .arg(import_data("refs.csv"))
            .arg("--out")
            .arg(&out)
            .args(extra))
    };
    let (ok, _, err) = enlight(&[]);
    assert!(!ok, "a cut last row must not import silently: {err}");
    assert!(err.contains("cut.txt") && err.contains("truncated last row") && err.contains("1550.50"), "{err}");
    assert!(!out.exists());
    let (ok, _, err) = enlight(&["--on-error", "skip", "--max-skipped", "100"]);
    assert!(ok && err.contains("skipped 1 × ragged_row"), "{err}");
    // A logger CSV cut inside its last number.
    std::fs::remove_file(&out).unwrap();
    let logger = d.path().join("cut.csv");
    cut_copy(&import_data("logger.csv"), &logger, 3);
    let (ok, _, err) = run(bin()
        .args(["import", "--format", "csv", "--map"])
        .arg(import_data("logger_map.toml"))
        .arg(&logger)
        .arg("--out")
        .arg(&out));
    assert!(!ok && err.contains("cut.csv") && err.contains("truncated last row"), "{err}");
    assert!(!out.exists());
}

#[test]
fn train_refuses_a_dataset_csv_cut_inside_its_last_row() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let cut = d.path().join("cut.csv");
    // `…,3.760623,holdout\n` -> `…,3.760623,hold`: the split cell cut short.
    cut_copy(&csv, &cut, 4);
    let (ok, _, err) =
        run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&cut).arg("--out").arg(d.path().join("m.fbgm")));
    assert!(!ok);
    // 4320 rows after the header (λ_ref and the start time are in the sidecar).
    assert!(err.contains("cut.csv") && err.contains("line 4321") && err.contains("truncated last row"), "{err}");
    // Cut inside the last number instead (the split column removed, so dl3_pm is last).
    let text = common::read_csv_body(&csv);
    let no_split: String = text.lines().map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n").collect();
    let nosplit = d.path().join("nosplit.csv");
    std::fs::write(&nosplit, &no_split[..no_split.len() - 4]).unwrap();
    let (ok, _, err) = run(bin()
        .args(["train", "--max-centres", "8", "--data"])
        .arg(&nosplit)
        .arg("--out")
        .arg(d.path().join("m.fbgm")));
    assert!(!ok && err.contains("dl3_pm") && err.contains("truncated last row"), "{err}");
}

/// Every `--data`, `--out`, `--json` (and every other option) of every
/// subcommand has a description, and no help text names a file that does not exist.
#[test]
fn every_option_of_every_subcommand_is_described() {
    let subcommands = [
        "simulate",
        "train",
        "evaluate",
        "recalibrate",
        "inspect",
        "golden",
        "report",
        "demo",
        "import",
        "peaks",
        "bench-fit",
        "bench-spectrum",
        "fleet",
        "stream",
        "compensate",
    ];
    for sub in subcommands {
        // `--help` (long help) puts each description on the lines below its option.
        let (ok, help, err) = run(bin().args([sub, "--help"]));
        assert!(ok, "{sub}: {err}");
        assert!(!help.contains("README-import.md"), "{sub} --help names README-import.md:\n{help}");
        let lines: Vec<&str> = help.lines().collect();
        for (i, l) in lines.iter().enumerate() {
            let t = l.trim_start();
            let is_option =
                (t.starts_with("--") || (t.starts_with('<') && l.starts_with("  "))) && !t.starts_with("--help");
            if !is_option || t.starts_with("-h") {
                continue;
            }
            // Short form: `--out <OUT>   Output …` on one line; long form: description below.
            let head_end = t.find("  ").unwrap_or(t.len());
            let inline = t[head_end..].trim();
            let inline_doc = !inline.is_empty() && !inline.starts_with("[default") && !inline.starts_with("[possible");
            let next = lines.get(i + 1).map(|n| n.trim()).unwrap_or("");
            let below_doc = inline.is_empty() && !next.is_empty() && !next.starts_with('[') && !next.starts_with("--");
            assert!(
                inline_doc || below_doc,
                "`fbg-trainer {sub}`: `{}` has no description:\n{help}",
                t[..head_end].trim()
            );
        }
    }
}

/// On recorded data with gaps, `evaluate` says how many hold-out samples it
/// scored (not only how many there were), and nothing calls the record "seed 0".
#[test]
fn evaluate_on_recorded_data_with_gaps_labels_what_it_scored() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    // A recorded file: no .meta.json sidecar, and 30 hold-out rows with a gap in dl2_pm.
    let text = common::read_csv_body(&csv);
    let mut gaps = 0;
    let rec: String = text
        .lines()
        .map(|l| {
            if l.ends_with(",holdout") && gaps < 30 && l.len() % 3 == 0 {
                gaps += 1;
                let mut c: Vec<&str> = l.split(',').collect();
                c[6] = "";
                c.join(",") + "\n"
            } else {
                l.to_string() + "\n"
            }
        })
        .collect();
    assert_eq!(gaps, 30);
    let site = d.path().join("site3.csv");
    std::fs::write(&site, rec).unwrap();
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&site).arg("--out").arg(&model));
    assert!(ok, "{err}");
    let (ok, out, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&site).arg("--model").arg(&model));
    assert!(ok, "{err}");
    let holdout = text.lines().filter(|l| l.ends_with(",holdout")).count();
    assert!(
        out.contains(&format!("{holdout} hold-out samples, {} scored: 30 with gaps skipped", holdout - 30)),
        "{out}"
    );
    assert!(out.contains("recorded data") && !out.contains("seed 0"), "{out}");
}

/// `evaluate` prints the flagged fraction per flag, and a warning with a
/// recommendation exactly when Model-H is worse than Model-P on some channel; `train` reports
/// where cross-validation already scores it worse (harsh seeds 2, 1 and 42).
#[test]
fn evaluate_prints_flags_per_flag_and_warns_when_model_h_is_worse() {
    let d = tempfile::tempdir().unwrap();
    let (mut warned, mut cv_warned) = (0, 0);
    for seed in ["2", "1", "42"] {
        let csv = d.path().join(format!("h{seed}.csv"));
        let model = d.path().join(format!("h{seed}.fbgm"));
        assert!(run(bin().args(["simulate", "--preset", "harsh", "--seed", seed, "--out"]).arg(&csv)).0);
        // The `latch` variant (no memory terms) is the one that loses to Model-P on `harsh`, so
        // it exercises both warnings; the checks hold for any model. Trained once, with
        // `--json`: its warnings are the report's (`warnings`), the same sentences the text
        // output prints (`evaluate`'s, below, are read from stderr).
        let (ok, js, err) =
            run(bin().args(["train", "--features", "latch", "--json", "--data"]).arg(&csv).arg("--out").arg(&model));
        assert!(ok, "{err}");
        // train warns when cross-validation already scores Model-H worse on some channel.
        let j: serde_json::Value = serde_json::from_str(&js).unwrap();
        let cv_worse = (0..3).any(|c| j["cv_rmse_h"][c].as_f64().unwrap() > j["cv_rmse_p"][c].as_f64().unwrap());
        let cv_warning = j["warnings"].as_array().unwrap().iter().any(|w| {
            w["code"] == "model_h_worse_cv"
                && w["message"].as_str().unwrap().starts_with("in cross-validation Model-H is worse than Model-P")
        });
        assert_eq!(cv_warning, cv_worse, "{js}");
        cv_warned += usize::from(cv_worse);
        let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(&model));
        assert!(ok, "{err}");
        assert!(
            err.contains("Model-H flags on the hold-out")
                && err.contains("% outside the calibration envelope")
                && err.contains("% weak RBF support"),
            "{err}"
        );
        let m: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(d.path().join(format!("h{seed}.metrics.json"))).unwrap())
                .unwrap();
        let worse: Vec<usize> = (0..3).filter(|&c| m["table2"]["gain_pct"][c].as_f64().unwrap() < 0.0).collect();
        let warning = err.lines().find(|l| l.starts_with("warning: Model-H is worse than Model-P"));
        assert_eq!(warning.is_some(), !worse.is_empty(), "seed {seed}: gains {} but: {err}", m["table2"]["gain_pct"]);
        if let Some(w) = warning {
            warned += 1;
            assert!(w.contains("use Model-P for"), "a recommendation: {w}");
        }
        let short: Vec<usize> =
            (0..3).filter(|&c| m["table2"]["model_h"]["channels"][c]["coverage"].as_f64().unwrap() < 0.90).collect();
        let band = err.lines().find(|l| l.starts_with("warning: Model-H's 95 % band covered less than 90 %"));
        assert_eq!(band.is_some(), !short.is_empty(), "seed {seed}: {err}");
    }
    assert!(warned > 0 && cv_warned > 0, "no seed exercised a warning ({warned} evaluate, {cv_warned} train)");
}

/// A model with a temperature output and no ambient thermometer has no drift
/// observer; `train` says what that means for its band, and `evaluate` warns when the band
/// under-covers the hold-out (`paper --no-ambient`, seed 7: T covered 61.9 %).
#[test]
fn without_a_thermometer_train_and_evaluate_warn_about_the_temperature_band() {
    let d = tempfile::tempdir().unwrap();
    let csv = d.path().join("na.csv");
    let model = d.path().join("na.fbgm");
    assert!(run(bin().args(["simulate", "--preset", "paper", "--no-ambient", "--seed", "7", "--out"]).arg(&csv)).0);
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    assert!(
        err.contains("warning: no ambient thermometer: the temperature output cannot tell interrogator drift"),
        "{err}"
    );
    let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(&model));
    assert!(ok, "{err}");
    let w = err.lines().find(|l| l.starts_with("warning: Model-H's 95 % band covered less than 90 %"));
    assert!(w.is_some_and(|w| w.contains("T (") && !w.contains("strain (")), "{err}");
    // With the thermometer, train has nothing to say about it.
    let csv = d.path().join("a.csv");
    assert!(run(bin().args(["simulate", "--preset", "paper", "--seed", "7", "--out"]).arg(&csv)).0);
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(&csv).arg("--out").arg(d.path().join("a.fbgm")));
    assert!(ok, "{err}");
    assert!(!err.contains("no ambient thermometer"), "{err}");
}

/// A flipped bit in the header's version field is corruption (the CRC over
/// the whole blob fails), not a version mismatch; `inspect` shows the CRC and prints the f32
/// values at f32 precision.
#[test]
fn a_flipped_header_bit_is_corruption_and_inspect_prints_f32_values_as_f32() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("m.fbgm");
    assert!(run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model)).0);
    let (ok, out, err) = run(bin().arg("inspect").arg(&model));
    assert!(ok, "{err}");
    assert!(out.contains("CRC-32 "), "{out}");
    assert!(out.contains("envelope margin 0.1,"), "{out}");
    // The static gains `train` recorded beside the blob.
    assert!(out.contains("static gain (truth on the settled reading") && out.contains("Model-H T_C "), "{out}");
    // No f32 widened to f64 digits such as 0.10000000149011612.
    let long_digits = out
        .split(|c: char| !(c.is_ascii_digit() || c == '.'))
        .any(|w| w.split('.').nth(1).is_some_and(|f| f.len() > 9));
    assert!(!long_digits, "{out}");
    let mut b = std::fs::read(&model).unwrap();
    b[4] ^= 0x02; // format version 2 -> 0
    let flipped = d.path().join("flipped.fbgm");
    std::fs::write(&flipped, &b).unwrap();
    for cmd in [vec!["inspect"], vec!["evaluate", "--quick", "--data", csv.to_str().unwrap(), "--model"]] {
        let (ok, _, err) = run(bin().args(&cmd).arg(&flipped));
        assert!(!ok);
        assert!(err.contains("flipped.fbgm") && err.contains("corrupt") && err.contains("CRC"), "{cmd:?}: {err}");
        assert!(!err.contains("not readable by this build"), "{cmd:?}: {err}");
    }
}

/// The default demo's directory (`demo --json`), run once per test run for the tests that only
/// read what it wrote (under the target's directory for test files, written anew each run).
fn shared_demo() -> &'static Path {
    static DEMO: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DEMO.get_or_init(|| {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("checks-demo");
        let (ok, _, err) = run(bin().args(["demo", "--json", "--out"]).arg(&out));
        assert!(ok, "{err}");
        out
    })
}

/// The report judges coverage on the value it shows, so a
/// coverage printed as 93.0 % is not called "too narrow" under its own 93–97 % rule (the demo's
/// Model-P temperature band covers 92.98 %).
#[test]
fn the_summary_judges_coverage_as_shown() {
    let out = shared_demo();
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("model.metrics.json")).unwrap()).unwrap();
    let names = ["temperature", "strain", "pressure"];
    let start = html.find("Counting 93–97 % as on target:").expect("coverage sentence");
    let sentence = &html[start..start + html[start..].find('.').unwrap()];
    for (model, key) in [("Model-P", "model_p"), ("Model-H", "model_h")] {
        let clause = |what: &str| -> String {
            let tag = format!("{model}'s bands are {what} for ");
            match sentence.find(&tag) {
                Some(i) => {
                    let rest = &sentence[i + tag.len()..];
                    rest[..rest.find("Model-").unwrap_or(rest.len())].to_string()
                }
                None => String::new(),
            }
        };
        let (narrow, wide) = (clause("too narrow"), clause("wider than needed"));
        for (c, name) in names.iter().enumerate() {
            let shown = (1000.0 * m["table2"][key]["channels"][c]["coverage"].as_f64().unwrap()).round() / 10.0;
            assert_eq!(narrow.contains(name), shown < 93.0, "{model} {name} shown as {shown:.1} %: {sentence}");
            assert_eq!(wide.contains(name), shown > 97.0, "{model} {name} shown as {shown:.1} %: {sentence}");
        }
    }
}

/// `report` names every missing input at once.
#[test]
fn report_names_every_missing_input_at_once() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    assert!(csv.ends_with("data.csv"));
    let (ok, _, err) = run(bin().args(["report", "--out"]).arg(d.path()));
    assert!(!ok);
    for f in ["model.fbgm", "model-p.fbgm", "model.metrics.json"] {
        assert!(err.contains(f), "{f} not named: {err}");
    }
    assert!(!err.contains("missing data.csv"), "{err}");
}

/// The demo's model is rebuilt byte for byte by `train` from the demo's own
/// CSV (same data, same options ⇒ same bytes, whichever command trained it).
#[test]
fn train_on_the_demo_csv_rebuilds_the_demo_model() {
    let d = tempfile::tempdir().unwrap();
    let out = shared_demo();
    std::fs::create_dir(d.path().join("again")).unwrap();
    let again = d.path().join("again").join("model.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--data"]).arg(out.join("data.csv")).arg("--out").arg(&again));
    assert!(ok, "{err}");
    for (a, b) in [("model.fbgm", "model.fbgm"), ("model-p.fbgm", "model-p.fbgm")] {
        let (x, y) = (std::fs::read(out.join(a)).unwrap(), std::fs::read(again.with_file_name(b)).unwrap());
        let diff = x.iter().zip(&y).filter(|(p, q)| p != q).count() + x.len().abs_diff(y.len());
        assert_eq!(diff, 0, "{a}: {diff} bytes differ");
    }
}

/// Runs `args` of the built binary on a pseudo-terminal (util-linux `script`), returning what
/// the terminal showed; `None` where `script` is not installed.
fn on_a_terminal(args: &[&std::ffi::OsStr]) -> Option<String> {
    let mut line = String::new();
    for a in std::iter::once(std::ffi::OsStr::new(env!("CARGO_BIN_EXE_fbg-trainer"))).chain(args.iter().copied()) {
        line.push_str(&format!("'{}' ", a.to_str().unwrap().replace('\'', "'\\''")));
    }
    let o = Command::new("script").args(["-qec", &line, "/dev/null"]).env("COLUMNS", "100").output().ok()?;
    Some(String::from_utf8_lossy(&o.stdout).into_owned())
}

#[test]
fn evaluate_shows_a_progress_bar_on_a_terminal_only() {
    let d = tempfile::tempdir().unwrap();
    let csv = short_csv(d.path());
    let model = d.path().join("m.fbgm");
    let (ok, _, err) = run(bin().args(["train", "--max-centres", "8", "--data"]).arg(&csv).arg("--out").arg(&model));
    assert!(ok, "{err}");
    // Captured (not a terminal): no bar, no escape codes, the usual lines.
    let (ok, _, err) = run(bin().args(["evaluate", "--quick", "--data"]).arg(&csv).arg("--model").arg(&model));
    assert!(ok, "{err}");
    assert!(!err.contains('\u{1b}') && !err.contains("hold-out (Table 2)"), "{err:?}");
    assert!(err.contains("wrote "), "{err}");
    // On a terminal: the bar is drawn (and cleared).
    let args = [
        "evaluate".as_ref(),
        "--quick".as_ref(),
        "--data".as_ref(),
        csv.as_os_str(),
        "--model".as_ref(),
        model.as_os_str(),
    ];
    if let Some(tty) = on_a_terminal(&args) {
        assert!(tty.contains("hold-out (Table 2)") && tty.contains('\u{1b}'), "{tty:?}");
    }
}

/// The `points` of every `<polyline>` of `svg` drawn in `stroke` at `width`.
fn polylines(svg: &str, stroke: &str, width: u32) -> Vec<Vec<(i64, i64)>> {
    let tag = format!("stroke=\"{stroke}\" stroke-width=\"{width}\" points=\"");
    svg.lines()
        .filter(|l| l.starts_with("<polyline") && l.contains(&tag))
        .map(|l| {
            let p = &l[l.find(&tag).unwrap() + tag.len()..];
            p[..p.find('"').unwrap()]
                .split_whitespace()
                .map(|xy| {
                    let (x, y) = xy.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect()
        })
        .collect()
}

/// Dashed lines are dashed in the legends of Figs. 6 and 8; the
/// bands of Figs. 3–5 are hatched (no blended fill where they overlap) and the zoom window is
/// tinted, not grey; Fig. 2a zooms so the measured and true traces can be told apart.
#[test]
fn figure_legends_bands_and_zoom_windows_show_what_is_drawn() {
    let out = shared_demo();
    let svg = |stem: &str| std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
    // Legend strokes are 3 px wide (data lines of these figures are 1-2 px): a dashed entry is
    // several short horizontal dashes on one row, a solid one a single 24 px stroke.
    let dashes = |s: &str, stroke: &str| {
        let short: Vec<i64> = polylines(s, stroke, 3)
            .into_iter()
            .filter(|p| p.len() == 2 && p[0].1 == p[1].1 && (p[1].0 - p[0].0).abs() < 12)
            .map(|p| p[0].1)
            .collect();
        short.iter().map(|y| short.iter().filter(|v| *v == y).count()).max().unwrap_or(0)
    };
    let f8 = svg("fig8_drift_sensitivity");
    assert!(f8.contains("Model-P fit: slope"));
    assert!(
        dashes(&f8, "#D55E00") >= 3 && dashes(&f8, "#0072B2") >= 3,
        "Fig. 8: the fit lines' legend entries are not dashed"
    );
    let f6 = svg("fig6_parity");
    assert!(f6.contains("ideal (estimate = truth)"));
    assert!(dashes(&f6, "#141414") >= 3, "Fig. 6: the ideal line's legend entry is not dashed");
    for stem in ["fig3_temperature", "fig4_strain", "fig5_pressure"] {
        let s = svg(stem);
        let filled_band =
            s.lines().any(|l| l.starts_with("<polygon") && (l.contains("#D55E00") || l.contains("#0072B2")));
        assert!(!filled_band, "{stem}: a band is a blended fill");
        assert!(s.contains("95 % band (hatched)"), "{stem}: the legend does not say how bands are drawn");
        assert!(s.contains("fill=\"#F0E442\""), "{stem}: no tinted zoom window");
        assert!(!s.contains("opacity=\"0.12\" fill=\"#000000\""), "{stem}: the zoom window is grey");
    }
    let f2 = svg("fig2_wavelength_fbg1");
    assert!(f2.contains("measured and true, zoomed on t ="), "Fig. 2a does not zoom");
    assert!(f2.contains("fill=\"#F0E442\"") && !f2.contains("opacity=\"0.18\" fill=\"#000000\""));
    for stem in [
        "fig2_wavelength_fbg1",
        "fig3_temperature",
        "fig4_strain",
        "fig5_pressure",
        "fig6_parity",
        "fig8_drift_sensitivity",
    ] {
        let png = std::fs::read(out.join(format!("{stem}.png"))).unwrap();
        assert!(png.len() > 10_000 && png.starts_with(b"\x89PNG\r\n\x1a\n"), "{stem}.png");
    }
}

/// `report` reads inputs named by --data, --model,
/// --model-p and --metrics (the fixed names in DIR stay the default) and names a missing one.
#[test]
fn report_reads_the_inputs_named_by_its_options() {
    let d = tempfile::tempdir().unwrap();
    let demo = shared_demo();
    // The same inputs under other names, in another directory.
    let inp = d.path().join("inputs");
    std::fs::create_dir(&inp).unwrap();
    for (from, to) in [
        ("data.csv", "rec.csv"),
        ("data.meta.json", "rec.meta.json"),
        ("model.fbgm", "h.fbgm"),
        ("model-p.fbgm", "h-p.fbgm"),
        ("model.metrics.json", "h.metrics.json"),
    ] {
        std::fs::copy(demo.join(from), inp.join(to)).unwrap();
    }
    assert!(inp.join("rec.meta.json").exists());
    let out = d.path().join("out");
    let (ok, stdout, err) = run(bin()
        .args(["report", "--json", "--out"])
        .arg(&out)
        .arg("--data")
        .arg(inp.join("rec.csv"))
        .arg("--model")
        .arg(inp.join("h.fbgm")));
    assert!(ok, "{err}");
    let o: serde_json::Value = serde_json::from_str(&stdout).unwrap();
    assert_eq!(o["warnings"].as_array().map(Vec::len), Some(0), "{stdout}");
    assert!(out.join("index.html").is_file() && out.join("fig3_temperature.png").is_file());
    // A named input that is missing is named, with its path.
    let (ok, _, err) = run(bin()
        .args(["report", "--out"])
        .arg(&out)
        .arg("--model-p")
        .arg(inp.join("nope-p.fbgm"))
        .arg("--data")
        .arg(inp.join("rec.csv")));
    assert!(!ok && err.contains("nope-p.fbgm"), "{err}");
}
