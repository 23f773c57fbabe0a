//! The command line.

use super::*;

use crate::common::bin;

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
