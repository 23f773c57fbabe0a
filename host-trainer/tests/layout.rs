//! The library's modules follow the data (src/lib.rs): a module may use only the modules of
//! earlier layers, so there is no import cycle between them. This test reads the sources and
//! checks every `crate::<module>` path outside comments.

use std::path::{Path, PathBuf};

/// The layers, first to last; modules in one layer do not use each other.
const LAYERS: &[&[&str]] = &[
    &["error", "progress", "rng", "stats", "warning"],
    &["data"],
    &["sim", "fit"],
    &["eval"],
    &["export", "sign"],
    &["report", "fleet", "stream", "benchmark", "compensate"],
];

fn layer_of(module: &str) -> Option<usize> {
    LAYERS.iter().position(|l| l.contains(&module))
}

fn rust_files(p: &Path, out: &mut Vec<PathBuf>) {
    if p.is_dir() {
        for e in std::fs::read_dir(p).unwrap() {
            rust_files(&e.unwrap().path(), out);
        }
    } else if p.is_file() && p.extension().is_some_and(|e| e == "rs") {
        out.push(p.to_path_buf());
    }
}

/// The top-level modules `crate::…` paths in `text` name, outside `//` comments.
fn used_modules(text: &str) -> Vec<String> {
    let mut used = Vec::new();
    for line in text.lines() {
        let code = line.split("//").next().unwrap_or("");
        for (k, _) in code.match_indices("crate::") {
            let name: String = code[k + 7..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
            if !name.is_empty() && !used.contains(&name) {
                used.push(name);
            }
        }
    }
    used
}

#[test]
fn every_module_uses_only_earlier_layers() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let lib = std::fs::read_to_string(src.join("lib.rs")).unwrap();
    let declared: Vec<&str> =
        lib.lines().filter_map(|l| l.trim().strip_prefix("pub mod ")).map(|l| l.trim_end_matches(';')).collect();
    let mut problems = Vec::new();
    for m in &declared {
        let Some(mine) = layer_of(m) else {
            problems.push(format!("module `{m}` is in no layer of this test (and of src/lib.rs's docs)"));
            continue;
        };
        let mut files = Vec::new();
        rust_files(&src.join(format!("{m}.rs")), &mut files);
        rust_files(&src.join(m), &mut files);
        for f in files {
            for used in used_modules(&std::fs::read_to_string(&f).unwrap()) {
                match layer_of(&used) {
                    Some(l) if used == *m || l < mine => {}
                    Some(_) => problems
                        .push(format!("{} uses `crate::{used}`, a module of the same or a later layer", f.display())),
                    None => problems.push(format!("{} uses `crate::{used}`, which is in no layer", f.display())),
                }
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
