//! The record's zero and clock travel in its `.record.json` sidecar, beside a CSV that is a
//! plain table: written with the CSV as one output set, read back, still refused when the zero
//! disagrees with the model's; records with the older `#` comment lines are still read.

use std::path::Path;

use fbg_trainer::compensate::{self, FieldOptions, Precision};
use fbg_trainer::data::record_meta::sidecar_path;
use fbg_trainer::data::{Dataset, RecordMeta};
use fbg_trainer::fit::{self, FeatureChoice, Origin};
use fbg_trainer::sim::{self, scenario::Preset};

/// A day of the `temperature-1` preset (one grating, simulated zero and clock).
fn record() -> Dataset {
    let mut cfg = Preset::Temperature1.config();
    cfg.clock.days = 1.0;
    sim::simulate(&cfg, 7).data
}

/// A quick fit of `d` written to `dir/m.fbgm`.
fn model(d: &Dataset, dir: &Path) -> std::path::PathBuf {
    let tr = fit::train(d, &FeatureChoice::Paper.train_options(8).unwrap(), &Origin::default()).unwrap();
    let m = dir.join("m.fbgm");
    fbg_trainer::export::write_blob(&m, &tr.model_h).unwrap();
    m
}

/// An edit of a sidecar's JSON.
type Edit = dyn Fn(&mut serde_json::Value);

fn side_json(csv: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(sidecar_path(csv)).unwrap()).unwrap()
}

fn set_side(csv: &Path, v: &serde_json::Value) {
    std::fs::write(sidecar_path(csv), serde_json::to_string_pretty(v).unwrap()).unwrap();
}

#[test]
fn the_csv_is_a_plain_table_and_the_sidecar_carries_zero_and_clock() {
    let dir = tempfile::tempdir().unwrap();
    let d = record();
    let csv = dir.path().join("d.csv");
    d.write_csv(&csv).unwrap();
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("t_s,T_C,T_amb_C,dl1_pm,split\n"), "{text:.100}");
    assert!(!text.contains('#'), "no comment line anywhere");
    let s = side_json(&csv);
    assert_eq!(s["format"], "fbg-trainer record v1");
    assert_eq!(s["record"], "d.csv");
    assert_eq!(s["zero"][0]["column"], "dl1_pm");
    assert_eq!(s["zero"][0]["source"], "simulated");
    assert_eq!(s["zero"][0]["lambda_ref_nm"].as_f64(), d.meta.lambda_ref(0));
    assert_eq!(s["t0_utc"], "2026-01-05T00:00:00.000Z");
    for back in [Dataset::read_csv(&csv).unwrap(), Dataset::read_field_csv(&csv).unwrap()] {
        assert_eq!(back.meta, d.meta, "zero and clock read back");
        assert_eq!(back.meta.sidecar.as_deref(), Some(sidecar_path(&csv).as_path()));
    }
    // Without its sidecar the CSV is a record of shifts from an unknown zero on an unknown clock.
    std::fs::remove_file(sidecar_path(&csv)).unwrap();
    let bare = Dataset::read_csv(&csv).unwrap();
    assert!(bare.meta.is_empty(), "{:?}", bare.meta);
}

#[test]
fn records_with_the_older_comment_lines_are_still_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = record();
    let csv = dir.path().join("new.csv");
    d.write_csv(&csv).unwrap();
    let body = std::fs::read_to_string(&csv).unwrap();
    let nm = d.meta.lambda_ref(0).unwrap();
    let old = dir.path().join("old.csv");
    let mut lines: Vec<String> = body.lines().map(str::to_string).collect();
    // A bad cell in the third data row: its line number counts the comment lines.
    let mut cells: Vec<String> = lines[3].split(',').map(str::to_string).collect();
    cells[3] = "x".into();
    lines[3] = cells.join(",");
    let head = format!("# lambda_ref_nm: {nm:.6} simulated\n# t0_utc: 2026-01-05T00:00:00.000Z\n");
    std::fs::write(&old, format!("{head}{body}")).unwrap();
    let back = Dataset::read_csv(&old).unwrap();
    assert_eq!(back.meta, d.meta);
    assert_eq!(back.meta.comment_lines, 2);
    assert!(back.meta.sidecar.is_none());
    std::fs::write(&old, format!("{head}{}\n", lines.join("\n"))).unwrap();
    let e = Dataset::read_csv(&old).unwrap_err().to_string();
    assert!(e.contains("line 6, column dl1_pm") && e.contains("`x` is not a number"), "{e}");
    // Written again, it gets a sidecar and loses its comment lines.
    let again = dir.path().join("again.csv");
    back.write_csv(&again).unwrap();
    assert_eq!(std::fs::read_to_string(&again).unwrap(), body);
    assert_eq!(Dataset::read_csv(&again).unwrap().meta, d.meta);
}

#[test]
fn a_zero_that_disagrees_with_the_model_is_refused_from_the_sidecar_or_the_comment_lines() {
    let dir = tempfile::tempdir().unwrap();
    let d = record();
    let m = model(&d, dir.path());
    let csv = dir.path().join("field.csv");
    d.write_csv(&csv).unwrap();
    let out = dir.path().join("out.csv");
    // The record's own zero is the model's: compensated.
    compensate::run(&m, &csv, &out, Precision::F64, FieldOptions::default(), false).unwrap();
    std::fs::remove_file(&out).unwrap();
    // 1 nm off in the sidecar: refused by grating, naming the sidecar; nothing written.
    let mut s = side_json(&csv);
    let nm = s["zero"][0]["lambda_ref_nm"].as_f64().unwrap();
    s["zero"][0]["lambda_ref_nm"] = (nm + 1.0).into();
    s["zero"][0]["source"] = "first reading".into();
    set_side(&csv, &s);
    let e = compensate::run(&m, &csv, &out, Precision::F64, FieldOptions::default(), false).unwrap_err().to_string();
    assert!(e.contains("column dl1_pm") && e.contains("+1000.0 pm apart"), "{e}");
    assert!(e.contains(&format!("first reading, stated in {}", sidecar_path(&csv).display())), "{e}");
    assert!(!out.exists());
    // The same zero in the older comment lines: refused as before.
    std::fs::remove_file(sidecar_path(&csv)).unwrap();
    let body = std::fs::read_to_string(&csv).unwrap();
    let old = dir.path().join("old.csv");
    std::fs::write(&old, format!("# lambda_ref_nm: {:.6} first reading\n{body}", nm + 1.0)).unwrap();
    let e = compensate::run(&m, &old, &out, Precision::F64, FieldOptions::default(), false).unwrap_err().to_string();
    assert!(e.contains("column dl1_pm") && e.contains("+1000.0 pm apart"), "{e}");
    assert!(!out.exists());
}

#[test]
fn a_sidecar_that_does_not_fit_is_refused_by_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let d = record();
    let csv = dir.path().join("d.csv");
    d.write_csv(&csv).unwrap();
    let good = side_json(&csv);
    let side = sidecar_path(&csv).display().to_string();
    let cases: Vec<(Box<Edit>, &str)> = vec![
        (Box::new(|s| s["zero"][0]["lambda_ref_nm"] = 15.0.into()), "zero[0].lambda_ref_nm: 15 nm is not a plausible"),
        (Box::new(|s| s["zero"][0]["lambda_ref_nm"] = 1e300.into()), "zero[0].lambda_ref_nm: 1e300 nm"),
        (
            Box::new(|s| s["zero"][0]["lambda_ref_nm"] = serde_json::Value::Null),
            "zero[0].lambda_ref_nm: null with source",
        ),
        (Box::new(|s| s["zero"][0]["source"] = "guessed".into()), "zero[0].source: `guessed` is not a source"),
        (Box::new(|s| s["zero"][0]["column"] = "dl2_pm".into()), "zero[0].column: `dl2_pm` where `dl1_pm` belongs"),
        (
            Box::new(|s| {
                let z = s["zero"][0].clone();
                s["zero"].as_array_mut().unwrap().push(z);
            }),
            "zero: 2 gratings, but",
        ),
        (Box::new(|s| s["t0_utc"] = "yesterday".into()), "t0_utc: `yesterday` is not a UTC timestamp"),
        (Box::new(|s| s["format"] = "v2".into()), "format: `v2` is not"),
        (Box::new(|s| s["csv_crc32c"] = "xyz".into()), "csv_crc32c: `xyz` is not a CRC-32C"),
        (Box::new(|s| s["csv_crc32c"] = "1234567".into()), "csv_crc32c: `1234567` is not a CRC-32C"),
        (Box::new(|s| s["extra"] = 1.into()), "unknown field `extra`"),
        (Box::new(|s| s["zero"] = "x".repeat(500).into()), "not a record sidecar"),
    ];
    for (edit, says) in &cases {
        let mut s = good.clone();
        edit(&mut s);
        set_side(&csv, &s);
        let e = Dataset::read_csv(&csv).unwrap_err().to_string();
        assert!(e.starts_with(&side) && e.contains(says), "{says}: {e}");
        assert!(e.len() < 400, "{e}");
    }
    std::fs::write(sidecar_path(&csv), "{ not json").unwrap();
    let e = Dataset::read_csv(&csv).unwrap_err().to_string();
    assert!(e.starts_with(&format!("{side}: line 1, column ")), "{e}");
    // Comment lines and a sidecar that say different things: refused (the sidecar without the
    // table's length and digest, as written before them, so that the prepended lines are
    // not a rewritten table).
    let mut older = good.clone();
    older.as_object_mut().unwrap().retain(|k, _| !k.starts_with("csv_"));
    set_side(&csv, &older);
    let body = std::fs::read_to_string(&csv).unwrap();
    std::fs::write(&csv, format!("# t0_utc: 2020-01-01T00:00:00.000Z\n{body}")).unwrap();
    let e = Dataset::read_csv(&csv).unwrap_err().to_string();
    assert!(e.contains("another zero or clock than") && e.contains(&side), "{e}");
}

#[test]
fn the_csv_and_its_sidecar_are_replaced_together() {
    let dir = tempfile::tempdir().unwrap();
    let d = record();
    let csv = dir.path().join("d.csv");
    d.write_csv(&csv).unwrap();
    // A record that says nothing replaces the sidecar too: no stale zero beside it.
    let mut plain = d.clone();
    plain.meta = RecordMeta::default();
    plain.write_csv(&csv).unwrap();
    let s = side_json(&csv);
    assert_eq!(s["zero"], serde_json::json!([]));
    assert_eq!(s["t0_utc"], serde_json::Value::Null);
    assert!(Dataset::read_csv(&csv).unwrap().meta.is_empty());
    // A sidecar that cannot be written (a directory in its place): neither file is replaced.
    let other = dir.path().join("e.csv");
    std::fs::write(&other, "old").unwrap();
    std::fs::create_dir(sidecar_path(&other)).unwrap();
    let e = d.write_csv(&other).unwrap_err().to_string();
    assert!(e.contains("e.record.json") && e.contains("directory"), "{e}");
    assert_eq!(std::fs::read_to_string(&other).unwrap(), "old");
    let litter: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".fbg-"))
        .collect();
    assert!(litter.is_empty(), "{litter:?}");
}

/// `csv` rewritten by "another tool": the same columns, other rows (the record of another day),
/// its sidecar left as it was.
fn rewrite_rows(csv: &Path, seed: u64, same_length: bool) {
    let mut cfg = Preset::Temperature1.config();
    cfg.clock.days = 1.0;
    let other = sim::simulate(&cfg, seed).data;
    let mut text = Vec::new();
    other.write_csv_to(&mut text).unwrap();
    let old = std::fs::read(csv).unwrap();
    let head = String::from_utf8_lossy(&old).lines().next().unwrap().to_string();
    assert!(text.starts_with(head.as_bytes()), "the same columns");
    if same_length {
        // Same length too: only the digest can tell (the last digit of the first row's t_s).
        text = old.clone();
        let at = head.len() + 1 + 7;
        assert_eq!(&text[head.len() + 1..at + 1], b"0.000000", "{:?}", String::from_utf8_lossy(&text[..at + 10]));
        text[at] = b'1';
    } else {
        assert_ne!(text.len(), old.len(), "another length");
    }
    assert_ne!(text, old);
    std::fs::write(csv, text).unwrap();
}

#[test]
fn a_csv_rewritten_by_another_tool_is_refused_naming_both_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = record();
    let csv = dir.path().join("d.csv");
    d.write_csv(&csv).unwrap();
    let side = sidecar_path(&csv).display().to_string();
    // The sidecar records the table's length and CRC-32C.
    let s = side_json(&csv);
    let bytes = std::fs::read(&csv).unwrap();
    assert_eq!(s["csv_bytes"].as_u64(), Some(bytes.len() as u64));
    assert_eq!(s["csv_crc32c"].as_str().map(str::len), Some(8));
    // The CRC-32C the device's links use (fbg-shared's, written apart from the trainer's).
    assert_eq!(s["csv_crc32c"].as_str(), Some(format!("{:08x}", fbg_shared::crc32c::crc32c(&bytes)).as_str()));
    // Unchanged: read, every reader.
    assert_eq!(Dataset::read_csv(&csv).unwrap().meta, d.meta);
    assert_eq!(Dataset::read_csv_meta(&csv).unwrap(), d.meta);

    // Other rows of another length: refused as the file is opened, by every reader (the
    // header-only ones too), naming the sidecar, its field and the CSV, and what to do.
    rewrite_rows(&csv, 8, false);
    let new_len = std::fs::metadata(&csv).unwrap().len();
    let header_only = Dataset::read_csv_meta(&csv).unwrap_err().to_string();
    let field = Dataset::read_field_csv(&csv).unwrap_err().to_string();
    let e = Dataset::read_csv(&csv).unwrap_err().to_string();
    for e in [&e, &header_only, &field] {
        assert!(e.starts_with(&format!("{side}: csv_bytes: {} is not the table", csv.display())), "{e}");
        assert!(e.contains(&format!("({} bytes, but it has {new_len})", bytes.len())), "{e}");
        assert!(e.contains("write the pair again") && e.contains(&format!("or delete {side}")), "{e}");
    }
    // Written by the tool again: read.
    d.write_csv(&csv).unwrap();
    assert_eq!(Dataset::read_csv(&csv).unwrap().meta, d.meta);

    // Other bytes of the same length: refused once the rows are read (no pass of its own),
    // by the whole-file readers and the streaming ones (compensate).
    let m = model(&d, dir.path());
    let out = dir.path().join("out.csv");
    rewrite_rows(&csv, 8, true);
    assert_eq!(std::fs::metadata(&csv).unwrap().len(), bytes.len() as u64);
    let e = Dataset::read_csv(&csv).unwrap_err().to_string();
    assert!(e.starts_with(&format!("{side}: csv_crc32c: {} is not the table", csv.display())), "{e}");
    assert!(e.contains(&format!("(CRC-32C {}, but its bytes give ", s["csv_crc32c"].as_str().unwrap())), "{e}");
    assert!(e.contains(&format!("or delete {side}")), "{e}");
    let e = compensate::run(&m, &csv, &out, Precision::F64, FieldOptions::default(), false).unwrap_err().to_string();
    assert!(e.contains("csv_crc32c") && e.contains(&side), "{e}");
    assert!(!out.exists(), "nothing written");
    // Deleting the sidecar, as the message says: the table is read with no zero or clock.
    std::fs::remove_file(sidecar_path(&csv)).unwrap();
    assert!(Dataset::read_csv(&csv).unwrap().meta.is_empty());
}

#[test]
fn a_sidecar_older_than_the_digest_is_read_without_the_check() {
    let dir = tempfile::tempdir().unwrap();
    let d = record();
    let csv = dir.path().join("d.csv");
    d.write_csv(&csv).unwrap();
    let mut s = side_json(&csv);
    s.as_object_mut().unwrap().retain(|k, _| !k.starts_with("csv_"));
    assert_eq!(s.as_object().unwrap().len(), 4, "format, record, zero, t0_utc: {s}");
    set_side(&csv, &s);
    let back = Dataset::read_csv(&csv).unwrap();
    assert_eq!(back.meta, d.meta);
    assert_eq!(back.meta.sidecar.as_deref(), Some(sidecar_path(&csv).as_path()));
    // Nothing to tell a rewritten table by: read with the sidecar's zero, as before.
    rewrite_rows(&csv, 8, false);
    assert_eq!(Dataset::read_csv(&csv).unwrap().meta, d.meta);
    // Either field alone is checked.
    d.write_csv(&csv).unwrap();
    let mut only_crc = side_json(&csv);
    only_crc.as_object_mut().unwrap().remove("csv_bytes");
    set_side(&csv, &only_crc);
    assert_eq!(Dataset::read_csv(&csv).unwrap().meta, d.meta);
    rewrite_rows(&csv, 8, true);
    assert!(Dataset::read_csv(&csv).unwrap_err().to_string().contains("csv_crc32c"));
}
