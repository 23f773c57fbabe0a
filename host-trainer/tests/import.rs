//! Issue 8, import: ENLIGHT / Hyperion peaks exports and logger CSVs into the dataset CSV.
//! Every bad case is an error naming file, line and column under `--on-error fail`, and a
//! counted skip under `--on-error skip`; nothing is written when the import fails.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use fbg_trainer::data::import::{
    import, import_to_csv, Format, ImportOptions, ImportSummary, OnError, Purpose, Reason, SplitChoice,
    DEFAULT_MAX_SKIPPED,
};
use fbg_trainer::data::{Dataset, Measurand, Split};
use fbg_trainer::fit::{train, Origin, TrainOptions};
use fbg_trainer::sim::scenario::Preset;
use fbg_trainer::sim::simulate;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/import").join(name)
}

fn enlight(file: &str, map: Option<&str>, refs: Option<&str>) -> ImportOptions {
    ImportOptions {
        format: Format::Enlight,
        input: data(file),
        map: map.map(data),
        refs: refs.map(data),
        split: SplitChoice::default(),
        on_error: OnError::Fail,
        max_skipped: DEFAULT_MAX_SKIPPED,
        zero_from: None,
        start_unix_s: None,
    }
}

fn logger(file: &str, map: Option<&str>) -> ImportOptions {
    ImportOptions {
        format: Format::Csv,
        input: data(file),
        map: map.map(data),
        refs: None,
        split: SplitChoice::default(),
        on_error: OnError::Fail,
        max_skipped: DEFAULT_MAX_SKIPPED,
        zero_from: None,
        start_unix_s: None,
    }
}

/// `--on-error skip` with no cap on the skipped share (the bad-case files are a dozen rows).
fn skipping(mut o: ImportOptions) -> ImportOptions {
    o.on_error = OnError::Skip;
    o.max_skipped = 1.0;
    o
}

/// The error of a failing import; also checks that no output was left behind.
fn failure(o: &ImportOptions) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("data.csv");
    let e = import_to_csv(o, &out).expect_err("the import should fail").to_string();
    assert!(!out.exists(), "a failed import left {}", out.display());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0, "temporary files left behind");
    e
}

/// `e` names `file`, `line` and `column`.
fn assert_place(e: &str, file: &str, line: u64, column: &str) {
    assert!(e.contains(file), "file `{file}` not named: {e}");
    assert!(e.contains(&format!("line {line},")), "line {line} not named: {e}");
    assert!(e.contains(&format!("column {column}")), "column `{column}` not named: {e}");
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

// ---------------------------------------------------------------------------------------------
// Good files

#[test]
fn enlight_tab_export_with_a_map_finds_each_grating_by_window_despite_a_dropped_peak() {
    let (d, s) = import(&enlight("enlight_tab.txt", Some("enlight_map.toml"), Some("refs.csv"))).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.rows_skipped), (20, 20, 0));
    let e = s.enlight.as_ref().unwrap();
    assert_eq!((e.channels, e.delimiter.as_str(), e.metadata_lines), (4, "tab", 10));
    // Shifts from the map's ref_nm: (λ − λ_ref) × 1000.
    assert!(close(d.dl_pm[0][0], 12.0, 1e-9) && close(d.dl_pm[1][0], 23.0, 1e-9) && close(d.dl_pm[2][0], 34.0, 1e-9));
    // Line 18: FBG1's peak dropped out. It is a gap; FBG2 (the only peak left on channel 1) is
    // still FBG2, not shifted into FBG1's column.
    assert!(d.dl_pm[0][7].is_nan());
    assert!(close(d.dl_pm[1][7], 19.5, 1e-9), "{}", d.dl_pm[1][7]);
    assert!(close(d.dl_pm[2][7], 48.0, 1e-9));
    assert_eq!(s.gaps, [1, 0, 0]);
    assert!(s.gratings.iter().all(|g| g.ref_source == "map"));
    // References interpolated from 5 s readings: at 10:00:02, 40 % of the way from 10:00:00 to
    // 10:00:05; the load cell through its gain (0.5 µε/N).
    assert!(close(d.ambient()[2], 21.514, 1e-9), "{}", d.ambient()[2]);
    assert!(close(d.target(0).as_slice()[2], 20.14, 1e-9));
    assert!(close(d.target(1).as_slice()[2], 0.5 * 140.0, 1e-9));
    assert!(close(d.target(2).as_slice()[2], 151.4, 1e-9));
    assert_eq!(d.measurands(), Measurand::PAPER);
    let j = s.join.as_ref().unwrap();
    assert_eq!((j.max_gap_s, j.max_gap_source.as_str()), (12.0, "map"));
    assert_eq!(s.time.start.as_deref(), Some("2024-03-01T10:00:00.000"));
    assert_eq!(s.time.span_s, 19.0);
    // Default split: the first half of the duration.
    assert_eq!((s.split.cal_until_s, s.split.cal_rows, s.split.holdout_rows), (9.5, 10, 10));

    // Written atomically, read back by the trainer's reader, gap as an empty cell.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("data.csv");
    let s2 = import_to_csv(&enlight("enlight_tab.txt", Some("enlight_map.toml"), Some("refs.csv")), &out).unwrap();
    assert_eq!(s2.out.as_deref(), Some(out.to_str().unwrap()));
    let text = common::read_csv_body(&out);
    assert!(text.starts_with("t_s,T_C,strain_ue,p_kPa,T_amb_C,dl1_pm,dl2_pm,dl3_pm,split\n"));
    assert!(text.lines().nth(8).unwrap().starts_with("7.000000,"), "{text}");
    let back = Dataset::read_csv(&out).unwrap();
    assert_eq!(back.len(), 20);
    assert!(back.dl_pm[0][7].is_nan() && close(back.dl_pm[1][7], 19.5, 1e-6));
    assert_eq!(back.split[9], Split::Cal);
    assert_eq!(back.split[10], Split::Holdout);
}

#[test]
fn enlight_comma_export_without_a_map_takes_channels_in_order_and_the_first_reading_as_reference() {
    let (d, s) = import(&enlight("enlight_comma.csv", None, Some("refs_plain.csv"))).unwrap();
    assert_eq!((s.rows_read, s.rows_written), (10, 10));
    let e = s.enlight.as_ref().unwrap();
    assert_eq!((e.channels, e.delimiter.as_str(), e.metadata_lines, e.unassigned_rows), (3, ",", 3, 1));
    assert_eq!(s.gratings[0].ref_nm, Some(1535.012));
    assert_eq!(s.gratings[0].ref_source, "first reading (line 4)");
    assert!(s.gratings[2].source.contains("channel 3"));
    for k in 0..10 {
        assert!(close(d.dl_pm[0][k], k as f64, 1e-6), "row {k}: {}", d.dl_pm[0][k]);
    }
    // Line 8: channel 2 reported no peak.
    assert!(d.dl_pm[1][4].is_nan());
    assert_eq!(s.gaps, [0, 1, 0]);
    // Refs in the dataset's own column names, no map: 5 s spacing, so max gap 15 s.
    let j = s.join.as_ref().unwrap();
    assert_eq!((j.max_gap_s, j.max_gap_source.as_str()), (15.0, "3 × median refs spacing"));
    assert!(close(d.ambient()[1], 22.044, 1e-9));
    assert!(close(d.target(1).as_slice()[1], 22.0, 1e-9));
    assert_eq!(s.references.get(Measurand::T).unwrap().column, "T_C");
}

#[test]
fn logger_csv_with_iso_timestamps_and_pm_shifts() {
    let (d, s) = import(&logger("logger.csv", Some("logger_map.toml"))).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.rows_skipped), (12, 12, 0));
    assert_eq!(d.t_s, (0..12).map(|k| 60.0 * k as f64).collect::<Vec<_>>());
    assert!(close(d.dl_pm[0][3], 4.5, 1e-12) && close(d.dl_pm[1][3], -2.4, 1e-12) && close(d.dl_pm[2][3], 2.25, 1e-12));
    // An empty cell and a `NaN` cell are gaps.
    assert!(d.dl_pm[1][5].is_nan() && d.dl_pm[2][9].is_nan());
    assert_eq!(s.gaps, [0, 1, 1]);
    assert!(s.gratings.iter().all(|g| g.ref_nm.is_none() && g.ref_source == "shifts in the file"));
    // Load cell × gain.
    assert!(close(d.target(1).as_slice()[2], 20.0, 1e-12));
    assert_eq!(d.measurands(), Measurand::PAPER);
    assert_eq!(s.time.start.as_deref(), Some("2024-03-01T10:00:00.000"));
    assert_eq!((s.split.cal_rows, s.split.holdout_rows), (6, 6));
}

#[test]
fn split_by_time_seconds_or_timestamp() {
    let mut o = logger("logger.csv", Some("logger_map.toml"));
    o.split = SplitChoice::Until("2024-03-01 10:04:00".into());
    let (d, s) = import(&o).unwrap();
    assert_eq!((s.split.cal_until_s, s.split.cal_rows), (240.0, 5));
    assert_eq!(d.split[4], Split::Cal);
    assert_eq!(d.split[5], Split::Holdout);
    o.split = SplitChoice::Until("120".into());
    assert_eq!(import(&o).unwrap().1.split.cal_rows, 3);
    o.split = SplitChoice::Fraction(0.25);
    assert_eq!(import(&o).unwrap().1.split.cal_rows, 3);
    o.split = SplitChoice::Until("yesterday".into());
    let e = failure(&o);
    assert!(e.contains("--cal-until") && e.contains("yesterday"), "{e}");
    o.split = SplitChoice::Fraction(0.0);
    assert!(failure(&o).contains("--cal-fraction"));
}

// ---------------------------------------------------------------------------------------------
// Refusals that do not depend on rows

#[test]
fn enlight_without_refs_is_a_field_record_kept_row_for_row() {
    let (d, s) = import(&enlight("enlight_tab.txt", Some("enlight_map.toml"), None)).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.dropped_no_ambient.count), (20, 20, 0));
    assert_eq!(s.purpose, Purpose::Compensation);
    assert!(d.refs.is_empty() && d.t_amb_c.is_none() && d.n_gratings() == 3);
    let text = s.text();
    assert!(
        text.contains("every row kept") && text.contains("compensate") && text.contains("not for training"),
        "{text}"
    );
    // Training refuses it, naming the file and saying what it is for.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("field.csv");
    import_to_csv(&enlight("enlight_tab.txt", Some("enlight_map.toml"), None), &out).unwrap();
    let e = Dataset::read_csv(&out).unwrap_err().to_string();
    assert!(e.contains("field.csv") && e.contains("no reference column") && e.contains("compensate"), "{e}");
}

#[test]
fn enlight_without_a_map_takes_each_channels_peaks_as_gratings() {
    let (d, s) = import(&enlight("enlight_tab.txt", None, None)).unwrap();
    // 2 + 1 + 1 + 0 peaks: four gratings, dl1..dl4, in channel order; the row whose channel 1
    // lost a peak is a gap on both of its gratings.
    assert_eq!(d.n_gratings(), 4);
    assert_eq!(
        s.gratings.iter().map(|g| g.output.as_str()).collect::<Vec<_>>(),
        ["dl1_pm", "dl2_pm", "dl3_pm", "dl4_pm"]
    );
    assert!(s.gratings[3].source.contains("channel 3"), "{}", s.gratings[3].source);
    assert_eq!(s.gaps, [1, 1, 0, 0]);
    assert_eq!(s.purpose, Purpose::Compensation);
}

#[test]
fn refs_in_seconds_cannot_be_joined_onto_timestamps() {
    let e = failure(&enlight("enlight_comma.csv", None, Some("bad/refs_seconds.csv")));
    assert_place(&e, "refs_seconds.csv", 1, "t_s");
    assert!(e.contains("time.start"), "{e}");
}

#[test]
fn refs_time_going_backwards_fails_or_is_skipped_in_the_refs() {
    let o = enlight("enlight_comma.csv", None, Some("bad/refs_backwards.csv"));
    let e = failure(&o);
    assert_place(&e, "refs_backwards.csv", 5, "time");
    let (_, s) = import(&skipping(o)).unwrap();
    assert_eq!(s.skipped.len(), 2);
    assert_eq!(s.skipped[1].count(Reason::TimeBackwards), 1);
    assert_eq!(s.skipped[1].by_reason[&Reason::TimeBackwards].first_lines, vec![5]);
    assert_eq!(s.rows_skipped, 0, "the peaks file itself is clean");
}

#[test]
fn refs_outside_the_peaks_drop_rows_and_say_so() {
    // Readings every 5 s and a 2 s max gap: only the peak rows right on a reading keep an
    // ambient temperature; the others are dropped and counted.
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("m.toml");
    std::fs::write(&map, "max_gap_s = 2.0\n").unwrap();
    let mut o = enlight("enlight_comma.csv", None, Some("refs_plain.csv"));
    o.map = Some(map);
    let (d, s) = import(&o).unwrap();
    assert_eq!(d.len(), 2, "10:00:00 and 10:00:05");
    assert_eq!(s.dropped_no_ambient.count, 8);
    assert_eq!(s.dropped_no_ambient.first_lines, vec![5, 6, 7, 8, 10]);
    assert_eq!(s.rows_read, s.rows_written + s.rows_skipped + s.dropped_no_ambient.count);
}

#[test]
fn map_mistakes_name_the_map_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        ("[time]\ncolum = \"t\"\n", "line 2"),
        (&"[[grating]]\nchannel = 1\nwindow_nm = [1533.0, 1537.0]\n".repeat(9), "9 [[grating]] entries"),
        (
            "[[grating]]\nchannel = 1\nwindow_nm = [1533.0, 1537.0]\n[[grating]]\nchannel = 1\nwindow_nm = [1536.0, 1540.0]\n[[grating]]\nchannel = 2\nwindow_nm = [1553.0, 1557.0]\n",
            "grating[2].window_nm",
        ),
        (
            "[[grating]]\nchannel = 1\nwindow_nm = [1533.0, 1537.0]\nref_nm = 1545.0\n[[grating]]\nchannel = 2\nwindow_nm = [1543.0, 1547.0]\n[[grating]]\nchannel = 3\nwindow_nm = [1553.0, 1557.0]\n",
            "grating[1].ref_nm",
        ),
        (
            "[[grating]]\nchannel = 1\nwindow_nm = [1533.0, 1537.0]\n[[grating]]\nchannel = 2\nwindow_nm = [1543.0, 1547.0]\n[[grating]]\nchannel = 7\nwindow_nm = [1553.0, 1557.0]\n",
            "grating[3].channel",
        ),
        ("[[grating]]\ncolumn = \"a\"\nunit = \"nm\"\n[[grating]]\ncolumn = \"b\"\nunit = \"nm\"\n[[grating]]\ncolumn = \"c\"\nunit = \"nm\"\n", "grating[1].column"),
        ("[enlight]\nunit = \"furlong\"\n", "furlong"),
    ];
    for (i, (text, key)) in cases.iter().enumerate() {
        let map = dir.path().join(format!("map{i}.toml"));
        std::fs::write(&map, text).unwrap();
        let mut o = enlight("enlight_comma.csv", None, Some("refs_plain.csv"));
        o.map = Some(map);
        let e = failure(&o);
        assert!(e.contains(&format!("map{i}.toml")) && e.contains(key), "case {i}: {e}");
    }
    // A CSV map must name a column that exists.
    let map = dir.path().join("csv.toml");
    std::fs::write(&map, "[ambient]\ncolumn = \"Tamb_typo\"\n").unwrap();
    let mut o = logger("bad/logger_backwards.csv", None);
    o.map = Some(map);
    let e = failure(&o);
    assert_place(&e, "logger_backwards.csv", 1, "Tamb_typo");
    assert!(e.contains("ambient.column"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Every bad case, in both modes

struct Bad {
    opts: ImportOptions,
    file: &'static str,
    reason: Reason,
    /// Line and column of the first bad row (the fail-mode error).
    line: u64,
    column: &'static str,
    /// Also in the message.
    says: &'static str,
    /// Lines skipped under `skip`.
    skipped: &'static [u64],
}

fn bad_cases() -> Vec<Bad> {
    let e = |f: &str| enlight(f, None, Some("refs_plain.csv"));
    vec![
        Bad {
            opts: e("bad/enlight_ragged.txt"),
            file: "enlight_ragged.txt",
            reason: Reason::RaggedRow,
            line: 6,
            column: "4 (peak count ch3)",
            says: "truncated",
            skipped: &[6, 11],
        },
        Bad {
            opts: e("bad/enlight_non_numeric.txt"),
            file: "enlight_non_numeric.txt",
            reason: Reason::NonNumeric,
            line: 6,
            column: "6 (ch2 peak 1)",
            says: "1545.0x1",
            skipped: &[6, 9],
        },
        Bad {
            opts: e("bad/enlight_backwards.txt"),
            file: "enlight_backwards.txt",
            reason: Reason::TimeBackwards,
            line: 8,
            column: "1 (time)",
            says: "backwards",
            skipped: &[8],
        },
        Bad {
            opts: e("bad/enlight_duplicate.txt"),
            file: "enlight_duplicate.txt",
            reason: Reason::DuplicateTime,
            line: 7,
            column: "1 (time)",
            says: "line 6",
            skipped: &[7, 10],
        },
        Bad {
            opts: e("bad/enlight_count_mismatch.txt"),
            file: "enlight_count_mismatch.txt",
            reason: Reason::PeakCountMismatch,
            line: 6,
            column: "2-4 (peak counts)",
            says: "1+1+1 = 3",
            skipped: &[6, 9],
        },
        Bad {
            opts: enlight("bad/enlight_two_peaks.txt", Some("bad/enlight_windows.toml"), Some("refs_plain.csv")),
            file: "enlight_two_peaks.txt",
            reason: Reason::AmbiguousPeak,
            line: 7,
            column: "7 (ch2 peak 2)",
            says: "grating[2].window_nm",
            skipped: &[7],
        },
        Bad {
            opts: e("bad/enlight_pm_row.txt"),
            file: "enlight_pm_row.txt",
            reason: Reason::UnitMismatch,
            line: 8,
            column: "7 (ch3 peak 1)",
            says: "enlight.unit",
            skipped: &[8],
        },
        Bad {
            opts: logger("bad/logger_ragged.csv", None),
            file: "logger_ragged.csv",
            reason: Reason::RaggedRow,
            line: 4,
            column: "dl2_pm",
            says: "4 cells where the header has 6",
            skipped: &[4, 7],
        },
        Bad {
            opts: logger("bad/logger_non_numeric.csv", None),
            file: "logger_non_numeric.csv",
            reason: Reason::NonNumeric,
            line: 4,
            column: "T_amb_C",
            says: "n/a?",
            skipped: &[4, 7],
        },
        Bad {
            opts: logger("bad/logger_backwards.csv", None),
            file: "logger_backwards.csv",
            reason: Reason::TimeBackwards,
            line: 6,
            column: "time",
            says: "line 5",
            skipped: &[6],
        },
        Bad {
            opts: logger("bad/logger_duplicate.csv", None),
            file: "logger_duplicate.csv",
            reason: Reason::DuplicateTime,
            line: 5,
            column: "time",
            says: "line 4",
            skipped: &[5],
        },
        Bad {
            opts: logger("bad/logger_nm_pm_row.csv", Some("bad/logger_nm_map.toml")),
            file: "logger_nm_pm_row.csv",
            reason: Reason::UnitMismatch,
            line: 6,
            column: "FBG2",
            says: "map key `grating[2].unit`: set it to \"pm\"",
            skipped: &[6],
        },
        Bad {
            opts: logger("bad/logger_shift_row.csv", Some("bad/logger_nm_map.toml")),
            file: "logger_shift_row.csv",
            reason: Reason::UnitMismatch,
            line: 8,
            column: "FBG3",
            says: "looks like a shift",
            skipped: &[8],
        },
    ]
}

#[test]
fn every_bad_case_fails_naming_file_line_and_column() {
    for b in bad_cases() {
        let e = failure(&b.opts);
        assert_place(&e, b.file, b.line, b.column);
        assert!(e.contains(b.says), "{}: `{}` not in: {e}", b.file, b.says);
    }
}

#[test]
fn every_bad_case_is_counted_and_reported_when_skipping() {
    for b in bad_cases() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("data.csv");
        let s: ImportSummary = import_to_csv(&skipping(b.opts), &out).unwrap_or_else(|e| panic!("{}: {e}", b.file));
        let f = &s.skipped[0];
        assert!(f.file.ends_with(b.file));
        assert_eq!(f.by_reason.len(), 1, "{}: {:?}", b.file, f.by_reason);
        let c = &f.by_reason[&b.reason];
        assert_eq!(c.count, b.skipped.len(), "{}", b.file);
        assert_eq!(c.first_lines, b.skipped, "{}", b.file);
        assert_eq!(s.rows_skipped, b.skipped.len());
        assert_eq!(s.rows_written, s.rows_read - s.rows_skipped - s.dropped_no_ambient.count, "{}", b.file);
        assert_eq!(Dataset::read_csv(&out).unwrap().len(), s.rows_written);
        // The summary text lists the reason and its lines.
        let text = s.text();
        assert!(text.contains(b.reason.as_str()), "{text}");
        let json = serde_json::to_value(&s).unwrap();
        assert_eq!(json["skipped"][0]["by_reason"][b.reason.as_str()]["count"], b.skipped.len());
    }
}

/// A whole column in the wrong unit is refused with a hint naming the map key, also under
/// `skip` (skipping every row would hide the mistake).
#[test]
fn a_column_in_the_wrong_unit_is_refused_in_both_modes() {
    let cases = [
        (
            logger("bad/logger_nm_all_pm.csv", Some("bad/logger_nm_map.toml")),
            "logger_nm_all_pm.csv",
            3,
            "FBG2",
            "`grating[2].unit`: set it to \"pm\"",
        ),
        (
            logger("bad/logger_shift_all.csv", Some("bad/logger_nm_map.toml")),
            "logger_shift_all.csv",
            3,
            "FBG3",
            "shift_pm",
        ),
        (
            logger("bad/logger_abs_as_shift.csv", None),
            "logger_abs_as_shift.csv",
            2,
            "dl2_pm",
            "`grating[2].unit`: set it to \"nm\"",
        ),
        (logger("bad/logger_kelvin.csv", None), "logger_kelvin.csv", 2, "T_amb_C", "ambient.offset"),
    ];
    for (o, file, line, column, says) in cases {
        for mode in [OnError::Fail, OnError::Skip] {
            let o = ImportOptions { on_error: mode, ..o.clone() };
            let e = failure(&o);
            assert_place(&e, file, line, column);
            assert!(e.contains(says), "{file} ({mode:?}): `{says}` not in: {e}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The command line

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_fbg-trainer"))
}

#[test]
fn cli_import_prints_a_json_summary_and_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("data.csv");
    let o = bin()
        .args(["import", "--format", "enlight"])
        .arg(data("enlight_tab.txt"))
        .arg("--map")
        .arg(data("enlight_map.toml"))
        .arg("--refs")
        .arg(data("refs.csv"))
        .arg("--out")
        .arg(&out)
        .args(["--cal-until", "2024-03-01 10:00:14", "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["rows_read"], 20);
    assert_eq!(j["rows_written"], 20);
    assert_eq!(j["gaps"], serde_json::json!([1, 0, 0]));
    assert_eq!(j["split"]["cal_rows"], 15);
    assert_eq!(j["references"]["strain_ue"]["column"], "Load (N)");
    assert_eq!(j["time"]["span_s"], 19.0);
    assert!(out.exists());

    // Without --refs: a field record, every row kept, and the summary says what it is for.
    let out2 = dir.path().join("none.csv");
    let o = bin()
        .args(["import", "--format", "enlight"])
        .arg(data("enlight_tab.txt"))
        .arg("--map")
        .arg(data("enlight_map.toml"))
        .arg("--out")
        .arg(&out2)
        .output()
        .unwrap();
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("20 written") && err.contains("for `fbg-trainer compensate`, not for training"), "{err}");
    assert!(out2.exists());
    std::fs::remove_file(&out2).unwrap();

    // A bad row under the default policy; then skipped with --on-error skip.
    let o = bin()
        .args(["import", "--format", "csv"])
        .arg(data("bad/logger_duplicate.csv"))
        .arg("--out")
        .arg(&out2)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("logger_duplicate.csv: line 5, column time"), "{err}");
    assert!(!out2.exists());
    let o = bin()
        .args(["import", "--format", "csv", "--on-error", "skip", "--max-skipped", "50"])
        .arg(data("bad/logger_duplicate.csv"))
        .arg("--out")
        .arg(&out2)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success() && err.contains("skipped 1 × duplicate_time") && err.contains("lines 5"), "{err}");
    assert!(out2.exists());
}

// ---------------------------------------------------------------------------------------------
// End to end: simulated installation → ENLIGHT export + refs CSV → import → read → train

/// `2024-03-01 00:00:00` + `t` seconds, as ENLIGHT writes it.
fn stamp(t: f64) -> String {
    let ms = (t * 1e3).round() as u64;
    let (s, ms) = (ms / 1000, ms % 1000);
    let (day, rem) = (s / 86_400, s % 86_400);
    format!("2024-03-{:02} {:02}:{:02}:{:02}.{ms:03}", 1 + day, rem / 3600, rem % 3600 / 60, rem % 60)
}

#[test]
fn simulated_enlight_export_imports_exactly_and_trains() {
    let mut cfg = Preset::Paper.config();
    cfg.clock.days = 2.0;
    cfg.clock.dt_s = 300.0;
    let sim = simulate(&cfg, 11);
    let d = &sim.data;
    let n = d.len();
    assert_eq!(n, 576);
    let nominal = cfg.gratings.nominal_nm;
    let dropped = 100; // FBG2's peak missing on this row

    let dir = tempfile::tempdir().unwrap();
    let peaks = dir.path().join("sim_peaks.txt");
    let mut text = String::from(
        "Micron Optics ENLIGHT Sensing Analysis Software\t1.7.2\nInstrument\tsi155\nChannels\t4\nStart Time\t2024/03/01 00:00:00\n\nTimestamp\t# CH 1\t# CH 2\t# CH 3\t# CH 4\tPeaks\n",
    );
    for i in 0..n {
        let nm: Vec<f64> = (0..3).map(|g| nominal[g] + d.dl_pm[g][i] / 1000.0).collect();
        if i == dropped {
            text.push_str(&format!("{}\t1\t0\t1\t0\t{:.9}\t{:.9}\t\n", stamp(d.t_s[i]), nm[0], nm[2]));
        } else {
            text.push_str(&format!("{}\t1\t1\t1\t0\t{:.9}\t{:.9}\t{:.9}\t\n", stamp(d.t_s[i]), nm[0], nm[1], nm[2]));
        }
    }
    std::fs::write(&peaks, text).unwrap();
    let refs = dir.path().join("sim_refs.csv");
    let mut text = String::from("time,T_amb_C,T_C,strain_ue,p_kPa\n");
    for i in 0..n {
        text.push_str(&format!(
            "{},{:.9},{:.9},{:.9},{:.9}\n",
            stamp(d.t_s[i]),
            d.ambient()[i],
            d.target(0).as_slice()[i],
            d.target(1).as_slice()[i],
            d.target(2).as_slice()[i]
        ));
    }
    std::fs::write(&refs, text).unwrap();
    let map = dir.path().join("sim_map.toml");
    let mut text = String::new();
    for (g, nm) in nominal.iter().enumerate() {
        text.push_str(&format!(
            "[[grating]]\nchannel = {}\nwindow_nm = [{}, {}]\nref_nm = {nm}\n\n",
            g + 1,
            nm - 2.0,
            nm + 2.0
        ));
    }
    std::fs::write(&map, text).unwrap();

    let out = dir.path().join("data.csv");
    let o = ImportOptions {
        format: Format::Enlight,
        input: peaks,
        map: Some(map),
        refs: Some(refs),
        split: SplitChoice::Fraction(0.5),
        on_error: OnError::Fail,
        max_skipped: DEFAULT_MAX_SKIPPED,
        zero_from: None,
        start_unix_s: None,
    };
    let s = import_to_csv(&o, &out).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.gaps), (n, n, vec![0, 1, 0]));
    let back = Dataset::read_csv(&out).unwrap();
    assert_eq!(back.len(), n);
    for i in 0..n {
        assert!(close(back.t_s[i], d.t_s[i], 1e-9));
        for g in 0..3 {
            if g == 1 && i == dropped {
                assert!(back.dl_pm[g][i].is_nan());
                continue;
            }
            assert!(
                close(back.dl_pm[g][i], d.dl_pm[g][i], 1e-3),
                "row {i} grating {g}: {} vs {}",
                back.dl_pm[g][i],
                d.dl_pm[g][i]
            );
        }
        assert!(close(back.ambient()[i], d.ambient()[i], 1e-6));
        assert!(
            close(back.target(0).as_slice()[i], d.target(0).as_slice()[i], 1e-6)
                && close(back.target(1).as_slice()[i], d.target(1).as_slice()[i], 1e-6)
                && close(back.target(2).as_slice()[i], d.target(2).as_slice()[i], 1e-6)
        );
    }
    // The same split as the simulator's 50 %.
    assert_eq!(back.split, d.split);

    let grid = TrainOptions::builder()
        .centres(vec![8, 16])
        .sigma_mults(vec![1.0, 2.0])
        .alpha_rels(vec![1e-5, 1e-3])
        .dead_bands_pm(vec![2.0, 4.0])
        .check()
        .unwrap();
    let t = train(&back, &grid, &Origin { scenario: "imported".into(), seed: 0 }).unwrap();
    assert_eq!(t.selection.n_cal, n / 2 - 1, "the gap row is not used for fitting");
    assert_eq!(t.model_h.fitted, [true, true, true, false]);
    assert!(t.selection.cv_rmse_h.iter().all(|r| r.is_finite()), "{:?}", t.selection.cv_rmse_h);
}

// ---------------------------------------------------------------------------------------------
// 1 to 8 gratings, any measurands, no references (issue 17)

/// A one-channel ENLIGHT export as an SM130 writes it (metadata lines, timestamps, a peak count
/// per channel, no references): without a map the single grating is dl1_pm, referenced to its
/// first reading; a dropped peak and a spurious second peak are gaps; every row is kept.
#[test]
fn single_grating_enlight_export_without_references_imports_row_for_row() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t1.csv");
    let s = import_to_csv(&enlight("enlight_single.txt", None, None), &out).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.rows_skipped), (16, 16, 0));
    assert_eq!(s.purpose, Purpose::Compensation);
    let e = s.enlight.as_ref().unwrap();
    assert_eq!((e.channels, e.metadata_lines, e.unassigned_rows), (4, 10, 2));
    assert_eq!(s.gaps, [2]);
    assert_eq!(s.gratings[0].ref_nm, Some(1550.12));
    assert!(s.gratings[0].ref_source.contains("line 11"), "{}", s.gratings[0].ref_source);
    assert!(s.references.ambient.is_none() && s.references.measurands.is_empty());
    let text = s.text();
    assert!(text.contains("no ambient thermometer") && text.contains("every row kept"), "{text}");
    let j = serde_json::to_value(&s).unwrap();
    assert_eq!(j["purpose"], "compensation");
    assert_eq!(j["references"]["T_amb_C"], serde_json::Value::Null);

    let text = std::fs::read_to_string(&out).unwrap();
    // The zero travels with the record: the first reading, named as such.
    assert!(text.starts_with("# lambda_ref_nm: 1550.120000 first reading\n"), "{text:.120}");
    let body = common::csv_body(&text);
    assert_eq!(body.lines().next().unwrap(), "t_s,dl1_pm,split");
    let d = Dataset::read_field_csv(&out).unwrap();
    assert_eq!(d.len(), 16);
    assert_eq!(d.t_s[15], 30.0);
    assert!(close(d.dl_pm[0][3], 1.5, 1e-6), "{}", d.dl_pm[0][3]);
    assert!(d.dl_pm[0][6].is_nan() && d.dl_pm[0][11].is_nan());
    // A training command refuses it by name; a model of another shape refuses it naming both.
    assert!(Dataset::read_csv(&out).unwrap_err().to_string().contains("no reference column"));
    let e = d.inputs_for(&fbg_shared::layout::Dims::PAPER, "t1.csv", "compensate").unwrap_err().to_string();
    assert!(e.contains("t1.csv") && e.contains("column dl2_pm") && e.contains("1 grating (dl1_pm)"), "{e}");
    assert!(e.contains("3 gratings (dl1_pm..dl3_pm) and the ambient thermometer T_amb_C"), "{e}");
}

/// The same export with a window map: the spurious peak lies outside the window, so only the
/// dropped peak is a gap; the shift is taken from the map's ref_nm.
#[test]
fn single_grating_enlight_export_with_a_window_map() {
    let (d, s) = import(&enlight("enlight_single.txt", Some("enlight_single_map.toml"), None)).unwrap();
    assert_eq!((d.n_gratings(), s.rows_written), (1, 16));
    assert_eq!(s.gaps, [1]);
    assert!(close(d.dl_pm[0][0], 120.0, 1e-6) && close(d.dl_pm[0][11], 125.5, 1e-6), "{:?}", &d.dl_pm[0]);
}

/// A logger's single-grating file (metadata lines, `;`, timestamps, absolute nm, a missing
/// cell, no ambient thermometer, no references): every row kept, the gap a gap.
#[test]
fn single_grating_logger_file_without_references_or_ambient() {
    let (d, s) = import(&logger("logger_single.csv", Some("logger_single_map.toml"))).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.gaps.clone()), (12, 12, vec![1]));
    assert_eq!(s.purpose, Purpose::Compensation);
    assert_eq!(d.shape().to_string(), "1 grating (dl1_pm), no reference columns, no ambient thermometer (T_amb_C)");
    assert!(close(d.dl_pm[0][1], 0.6, 1e-6) && d.dl_pm[0][4].is_nan());
    assert_eq!(s.time.start.as_deref(), Some("2024-06-12T14:30:00.000"));
    assert!(close(s.time.span_s, 55.0, 1e-9));
}

/// The map names any measurand: `[strain]` and `[[measurand]] name = "strain2_ue"`; two
/// gratings; the dataset writes and reads them back in canonical order.
#[test]
fn the_map_names_any_measurand_columns() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("two.csv");
    let s = import_to_csv(&logger("logger_two_strains.csv", Some("logger_two_strains_map.toml")), &out).unwrap();
    assert_eq!(s.purpose, Purpose::Training);
    let e2: Measurand = "strain2_ue".parse().unwrap();
    assert_eq!(s.references.get(e2).unwrap().column, "SG2");
    let body = common::read_csv_body(&out);
    assert_eq!(body.lines().next().unwrap(), "t_s,strain_ue,strain2_ue,T_amb_C,dl1_pm,dl2_pm,split");
    let d = Dataset::read_csv(&out).unwrap();
    assert_eq!(d.measurands(), [Measurand::STRAIN, e2]);
    assert!(close(d.reference(e2).unwrap()[3], -6.0, 1e-9) && close(d.dl_pm[1][3], -2.7, 1e-9));
    // Its model has 2 gratings, the ambient input and the outputs strain, strain 2.
    let dims = d.dims("two.csv").unwrap();
    assert_eq!((dims.gratings(), dims.ambient(), dims.n_outputs()), (2, true, 2));
    assert_eq!(Measurand::of_dims(&dims), [Measurand::STRAIN, e2]);
}

/// A logger file with references but no ambient column keeps every row; one with an ambient
/// column drops (and counts) rows without it, as before.
#[test]
fn ambient_is_optional_for_a_logger() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("noamb.csv");
    std::fs::write(&csv, "t_s,T_C,dl1_pm\n0,20.0,1.0\n1,20.1,2.0\n2,,3.0\n").unwrap();
    let mut o = logger("logger.csv", None);
    o.input = csv;
    let (d, s) = import(&o).unwrap();
    assert_eq!((s.rows_written, d.t_amb_c.is_none(), d.measurands()), (3, true, vec![Measurand::T]));
    assert!(d.target(0).as_slice()[2].is_nan());
}

// ---------------------------------------------------------------------------------------------
// Locale: the `Culture:` line (issue 27 item 7)

fn locale(file: &str) -> ImportOptions {
    enlight(&format!("locale/{file}"), None, None)
}

/// de-DE: decimal commas (times and wavelengths) and day-first dates that only the culture can
/// settle (every day is 3, every month 1): the 3rd of January, never the 1st of March.
#[test]
fn a_de_de_export_reads_decimal_commas_and_day_first_dates() {
    let (d, s) = import(&locale("enlight_de.txt")).unwrap();
    assert_eq!((s.rows_read, s.rows_written, s.rows_skipped), (6, 6, 0));
    assert_eq!(s.time.start.as_deref(), Some("2024-01-03T10:00:00.000"));
    assert_eq!(s.time.end.as_deref(), Some("2024-01-03T10:00:05.000"));
    assert_eq!(s.time.span_s, 5.0);
    // `1535,0130` is 1535.013 nm: 1 pm above the first reading.
    assert_eq!(s.gratings[0].ref_nm, Some(1535.012));
    assert_eq!(s.gratings[1].ref_nm, Some(1545.023));
    for k in 0..6 {
        assert!(close(d.dl_pm[0][k], k as f64, 1e-6) && close(d.dl_pm[1][k], k as f64, 1e-6), "row {k}");
    }
    let e = s.enlight.as_ref().unwrap();
    assert_eq!(e.culture.as_deref(), Some("de-DE (line 3)"));
    let j = serde_json::to_value(&s).unwrap();
    assert_eq!(j["enlight"]["date_order"], "day_first");
    assert!(s.text().contains("culture de-DE (line 3)") && s.text().contains("day-first"), "{}", s.text());
}

/// fr-FR with `;` between cells: seconds and wavelengths with decimal commas.
#[test]
fn a_fr_fr_export_in_seconds_reads_decimal_commas() {
    let (d, s) = import(&locale("enlight_fr_seconds.txt")).unwrap();
    assert_eq!(s.rows_written, 4);
    assert_eq!(s.enlight.as_ref().unwrap().delimiter, ";");
    assert_eq!(d.t_s, [0.0, 0.5, 1.0, 1.5]);
    for (k, want) in [0.0, 1.5, 3.0, 4.5].into_iter().enumerate() {
        assert!(close(d.dl_pm[0][k], want, 1e-6), "row {k}: {}", d.dl_pm[0][k]);
    }
}

/// Without a culture, one date with a first field above 12 makes the whole file day-first —
/// the rows before it too (12/01 is the 12th of January, not the 1st of December); one with a
/// second field above 12 makes it month-first.
#[test]
fn without_a_culture_a_day_above_12_settles_the_order() {
    let (d, s) = import(&locale("enlight_day13.txt")).unwrap();
    assert_eq!(s.time.start.as_deref(), Some("2024-01-12T23:59:58.000"));
    assert_eq!(d.t_s, [0.0, 1.0, 2.0, 3.0]);
    let e = s.enlight.as_ref().unwrap();
    assert!(e.culture.is_none());
    assert_eq!(serde_json::to_value(e).unwrap()["date_order"], "day_first");
    assert!(e.date_order_from.as_deref().unwrap().contains("line 7"), "{:?}", e.date_order_from);

    let (d, s) = import(&locale("enlight_month13.txt")).unwrap();
    assert_eq!(s.time.start.as_deref(), Some("2024-01-12T23:59:58.000"));
    assert_eq!(d.t_s, [0.0, 1.0, 2.0, 3.0]);
    assert_eq!(serde_json::to_value(s.enlight.as_ref().unwrap()).unwrap()["date_order"], "month_first");
}

/// Every date ≤ 12 in both fields and no culture: refused at the first date's line, saying how
/// to fix it — in both error modes (skipping rows would not make the dates less ambiguous).
/// The map's `[enlight] culture` is one fix.
#[test]
fn ambiguous_dates_without_a_culture_are_refused_with_their_line() {
    for o in [locale("enlight_ambiguous.txt"), skipping(locale("enlight_ambiguous.txt"))] {
        let e = failure(&o);
        assert_place(&e, "enlight_ambiguous.txt", 5, "1 (time)");
        assert!(e.contains("01/03/2024 10:00:00") && e.contains("ambiguous"), "{e}");
        assert!(e.contains("Culture: de-DE") && e.contains("[enlight]") && e.contains("culture"), "{e}");
    }
    let (_, s) = import(&enlight("locale/enlight_ambiguous.txt", Some("locale/culture_map.toml"), None)).unwrap();
    assert_eq!(s.time.start.as_deref(), Some("2024-01-03T10:00:00.000"));
    assert!(s.enlight.as_ref().unwrap().culture.as_deref().unwrap().starts_with("en-US (map key enlight.culture"));
}

/// A culture the dates contradict (de-DE reads `01.13.2024` as month 13) is an error naming the
/// line, in both error modes; so is a map whose culture differs from the file's line.
#[test]
fn a_culture_the_dates_contradict_is_an_error_naming_the_line() {
    for o in [locale("enlight_contradicts.txt"), skipping(locale("enlight_contradicts.txt"))] {
        let e = failure(&o);
        assert_place(&e, "enlight_contradicts.txt", 8, "1 (time)");
        assert!(e.contains("01.13.2024") && e.contains("month 13") && e.contains("de-DE (line 3)"), "{e}");
    }
    let e = failure(&enlight("locale/enlight_contradicts.txt", Some("locale/culture_map.toml"), None));
    assert_place(&e, "enlight_contradicts.txt", 3, "Culture");
    assert!(e.contains("de-DE") && e.contains("en-US"), "{e}");
}

/// Numbers that do not match the culture: a point in a de-DE file, a comma without a culture,
/// an unknown culture. Each names file, line and column.
#[test]
fn numbers_that_do_not_match_the_culture_name_their_place() {
    let dir = tempfile::tempdir().unwrap();
    let file = |name: &str, text: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, text).unwrap();
        enlight(p.to_str().unwrap(), None, None)
    };
    let rows =
        |v: &str| format!("Timestamp\t# CH 1\tPeaks\n2024-03-01 10:00:00\t1\t1550,1200\n2024-03-01 10:00:01\t1\t{v}\n");
    let e = failure(&file("point.txt", &format!("Culture: de-DE\n{}", rows("1550.1210"))));
    assert_place(&e, "point.txt", 4, "3 (ch1 peak 1)");
    assert!(e.contains("1550.1210") && e.contains("decimal comma"), "{e}");
    let e = failure(&file("comma.txt", &rows("1550,1210")));
    assert_place(&e, "comma.txt", 2, "3 (ch1 peak 1)");
    assert!(e.contains("Culture"), "{e}");
    let e = failure(&file("unknown.txt", &format!("Culture: xx-YY\n{}", rows("1550,1210"))));
    assert_place(&e, "unknown.txt", 1, "Culture");
    assert!(e.contains("xx-YY") && e.contains("de-DE"), "{e}");
}
