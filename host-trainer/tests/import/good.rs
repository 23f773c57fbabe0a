//! Good files.

use super::*;

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

/// The logger table is read as a stream from its header's byte on: the same rows written with
/// a byte-order mark before a first-line header, with CRLF line ends, with invalid UTF-8 in the
/// preamble, or found by the map's `header_lines`, import as the file itself does; a last row
/// cut short is still named as truncated, at its line.
#[test]
fn logger_csv_byte_variants_import_alike() {
    let dir = tempfile::tempdir().unwrap();
    let original = std::fs::read(data("logger.csv")).unwrap();
    let map = std::fs::read_to_string(data("logger_map.toml")).unwrap();
    let (want, _) = import(&logger("logger.csv", Some("logger_map.toml"))).unwrap();
    let text = String::from_utf8(original.clone()).unwrap();
    let body: String = text.lines().skip(2).map(|l| format!("{l}\n")).collect();
    let crlf: String = text.lines().map(|l| format!("{l}\r\n")).collect();
    let mut bad_utf8 = b"Logger \xff\xfe rig\n".to_vec();
    bad_utf8.extend_from_slice(&original);
    let mut bom = b"\xEF\xBB\xBF".to_vec();
    bom.extend_from_slice(body.as_bytes());
    let cases: Vec<(&str, Vec<u8>, String)> = vec![
        ("bom", bom, map.clone()),
        ("crlf", crlf.into_bytes(), map.clone()),
        ("utf8", bad_utf8, map.clone()),
        ("header_lines", original.clone(), format!("header_lines = 2\n{map}")),
    ];
    for (name, bytes, m) in cases {
        let (f, mp) = (dir.path().join(format!("{name}.csv")), dir.path().join(format!("{name}.toml")));
        std::fs::write(&f, bytes).unwrap();
        std::fs::write(&mp, m).unwrap();
        let (d, _) =
            import(&common::import_options(Format::Csv, f, Some(mp))).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(d.t_s, want.t_s, "{name}");
        for (a, b) in d.dl_pm.iter().zip(&want.dl_pm) {
            assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()), "{name}");
        }
    }
    // The last row cut inside a cell and without its line end.
    let cut = dir.path().join("cut.csv");
    let trimmed = text.trim_end();
    std::fs::write(&cut, &trimmed[..trimmed.len() - 2]).unwrap();
    let mp = dir.path().join("cut.toml");
    std::fs::write(&mp, &map).unwrap();
    let e = import(&common::import_options(Format::Csv, cut, Some(mp))).unwrap_err().to_string();
    let last = text.trim_end().lines().count();
    assert!(e.contains("truncated") && e.contains(&format!("line {last}")), "{e}");
}
