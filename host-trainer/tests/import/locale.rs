//! Locale: the `Culture:` line.

use super::*;

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
