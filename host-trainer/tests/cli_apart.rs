//! The command line is apart from the library (src/lib.rs): clap's argument types, indicatif's
//! progress bars and anyhow's errors appear only under src/cli/ (the `fbg-trainer` binary).
//! The library takes plain option structs, reports progress through `fbg_trainer::progress`
//! and returns `TrainerError`. (One package cannot keep these dependencies to its binary, so
//! this test keeps them there.)

use std::path::{Path, PathBuf};

/// The crates only the command line may use.
const CLI_ONLY: [&str; 3] = ["clap", "indicatif", "anyhow"];

fn rust_files(p: &Path, out: &mut Vec<PathBuf>) {
    if p.is_dir() {
        for e in std::fs::read_dir(p).unwrap() {
            rust_files(&e.unwrap().path(), out);
        }
    } else if p.extension().is_some_and(|e| e == "rs") {
        out.push(p.to_path_buf());
    }
}

/// Uses of `krate` in a line of code (comments stripped): a path through it (`clap::Args`,
/// `::anyhow::Error`), a `use` or `extern crate` of it, or its macro (`anyhow!`).
fn uses(code: &str, krate: &str) -> bool {
    let bytes = code.as_bytes();
    code.match_indices(krate).any(|(k, _)| {
        let before = code[..k].chars().next_back();
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
            return false;
        }
        let rest = code[k + krate.len()..].trim_start();
        let word_ends = bytes.get(k + krate.len()).is_none_or(|c| !(c.is_ascii_alphanumeric() || *c == b'_'));
        let declared = code[..k].trim_end().ends_with("use") || code[..k].trim_end().ends_with("extern crate");
        word_ends
            && (rest.starts_with("::") || rest.starts_with('!') || (declared && rest.starts_with([';', ' ', '{'])))
    })
}

#[test]
fn clap_indicatif_and_anyhow_only_under_src_cli() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    rust_files(&src, &mut files);
    let cli = src.join("cli");
    let mut problems = Vec::new();
    for f in files.iter().filter(|f| !f.starts_with(&cli)) {
        let text = std::fs::read_to_string(f).unwrap();
        for (n, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for krate in CLI_ONLY.iter().filter(|k| uses(code, k)) {
                problems.push(format!("{}:{}: uses `{krate}` ({})", f.display(), n + 1, line.trim()));
            }
        }
    }
    assert!(problems.is_empty(), "the library uses the command line's crates:\n{}", problems.join("\n"));
}

#[test]
fn the_scan_sees_each_way_of_using_a_crate() {
    for line in [
        "#[derive(Clone, clap::ValueEnum)]",
        "use anyhow::{bail, Result};",
        "    let bar = indicatif::ProgressBar::hidden();",
        "    return Err(anyhow!(\"x\"));",
        "use clap;",
        "extern crate indicatif;",
        "    x: ::anyhow::Error,",
    ] {
        assert!(CLI_ONLY.iter().any(|k| uses(line, k)), "{line}");
    }
    for line in ["let clapping = 1;", "fn anyhow_like() {}", "let s = \"indicatif\";", "my_clap::Args"] {
        assert!(!CLI_ONLY.iter().any(|k| uses(line, k)), "{line}");
    }
}
