//! Every bad case, in both modes.

use super::*;

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
