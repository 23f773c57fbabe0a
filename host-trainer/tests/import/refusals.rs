//! Refusals that do not depend on rows.

use super::*;

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
