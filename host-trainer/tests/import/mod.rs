//! ENLIGHT / Hyperion peaks exports and logger CSVs into the dataset CSV.
//! Every bad case is an error naming file, line and column under `--on-error fail`, and a
//! counted skip under `--on-error skip`; nothing is written when the import fails.

use crate::common;

mod bad_rows;
mod cli;
mod end_to_end;
mod good;
mod locale;
mod quotes;
mod refusals;
mod shapes;

use std::path::{Path, PathBuf};

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
        scale: None,
    }
}

fn logger(file: &str, map: Option<&str>) -> ImportOptions {
    common::import_options(Format::Csv, data(file), map.map(data))
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
