//! 1 to 8 gratings, any measurands, no references.

use super::*;

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
    // The zero travels with the record, in its sidecar: the first reading, named as such.
    let side = std::fs::read_to_string(fbg_trainer::data::record_meta::sidecar_path(&out)).unwrap();
    assert!(side.contains("\"lambda_ref_nm\": 1550.12,\n      \"source\": \"first reading\""), "{side}");
    assert!(text.starts_with("t_s,"), "{text:.120}");
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
