//! An error quotes at most 40 characters of a cell, and prints a number short: a 20 MB cell or
//! a 1e308 is named, not copied into the message.

use super::*;

/// `logger.csv` with the cell of FBG_B on its first data row replaced by `cell`.
fn logger_with(dir: &Path, cell: &str) -> ImportOptions {
    let text = std::fs::read_to_string(data("logger.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let row = lines.iter().position(|l| l.starts_with("\"2024")).unwrap();
    let mut cells: Vec<String> = lines[row].split(';').map(str::to_string).collect();
    cells[3] = cell.to_string();
    lines[row] = cells.join(";");
    let path = dir.join("logger.csv");
    std::fs::write(&path, lines.join("\n") + "\n").unwrap();
    ImportOptions { input: path, ..logger("logger.csv", Some("logger_map.toml")) }
}

#[test]
fn a_huge_cell_is_quoted_to_forty_characters() {
    let d = tempfile::tempdir().unwrap();
    let e = import(&logger_with(d.path(), &"7".repeat(20_000_000).replacen('7', "x", 1))).unwrap_err().to_string();
    assert!(
        e.contains(&format!("`x{}… (20000000 bytes)` is not a number", "7".repeat(39))),
        "{}",
        &e[..e.len().min(300)]
    );
    assert!(e.len() < 300, "{} bytes: {}", e.len(), &e[..300]);
}

#[test]
fn a_huge_number_is_printed_short() {
    let d = tempfile::tempdir().unwrap();
    let e = import(&logger_with(d.path(), "1e308")).unwrap_err().to_string();
    assert!(e.contains("1e308 (shift_pm) is a shift beyond"), "{e}");
    assert!(e.len() < 300, "{e}");
}
