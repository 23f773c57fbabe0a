//! The library's modules follow the data: a module may use only the modules of earlier layers,
//! so there is no import cycle between them. The layers are ARCHITECTURE.md's table "Inside the
//! trainer" (the backticked names of its second column), so the document and the code are kept
//! in step: a module of `src/lib.rs` in no layer, a layer naming no module of `src/lib.rs`, or
//! a use of a module of the same or a later layer fails.
//!
//! What each file uses is `fbg_testkit::modules`' reading, as for `modules.rs`: every `use`
//! tree and every path in expressions, types and patterns, attributed to the file that defines
//! the item (`crate::TrainerError` is a use of `error`, through the root's re-export). Paths
//! inside macro invocations are tokens, not paths, and are not seen.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use fbg_testkit::modules::{Module, Sources};

/// The layers of ARCHITECTURE.md's "Inside the trainer" table: module → layer number.
fn layers_from_architecture(text: &str) -> BTreeMap<String, usize> {
    let section = text.split("## Inside the trainer").nth(1).expect("ARCHITECTURE.md has no \"Inside the trainer\"");
    let section = section.split("\n## ").next().unwrap_or(section);
    let mut layers = BTreeMap::new();
    for line in section.lines().filter(|l| l.trim_start().starts_with('|')) {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        // "| 3 | `sim`, `fit` | … |": cells[0] is empty, cells[1] the layer, cells[2] the modules.
        let (Some(layer), Some(modules)) = (cells.get(1).and_then(|c| c.parse::<usize>().ok()), cells.get(2)) else {
            continue;
        };
        for name in modules.split('`').skip(1).step_by(2) {
            layers.insert(name.to_string(), layer);
        }
    }
    layers
}

/// The top-level modules a crate root (`src/lib.rs`) declares.
fn declared(lib: &str) -> Vec<String> {
    let file = syn::parse_file(lib).expect("src/lib.rs parses");
    file.items
        .iter()
        .filter_map(|i| match i {
            syn::Item::Mod(m) => Some(m.ident.to_string()),
            _ => None,
        })
        .collect()
}

/// Every use between two of the library's `modules` that goes to the same or a later layer,
/// or to a module in no layer.
fn problems(sources: &Sources, modules: &[String], layers: &BTreeMap<String, usize>) -> Vec<String> {
    let name = |m: &Module| if m.is_empty() { "crate".to_string() } else { format!("crate::{}", m.join("::")) };
    let mut out = Vec::new();
    for ((a, b), path) in sources.edges() {
        let Some(from) = a.first().filter(|m| modules.contains(m)) else { continue };
        if b.first() == Some(from) {
            continue;
        }
        let file = &sources.files()[&a];
        let file = file.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap_or(file).display();
        let mine = layers[from];
        match b.first().and_then(|m| layers.get(m)) {
            Some(&l) if l < mine => {}
            Some(&l) => out.push(format!(
                "{file} (module `{from}`, layer {mine}) uses {} (`{path}`), of layer {l}: the same or a later one",
                name(&b)
            )),
            None => out.push(format!("{file} (module `{from}`) uses {} (`{path}`), which is in no layer", name(&b))),
        }
    }
    out
}

#[test]
fn every_module_uses_only_earlier_layers_of_architecture_md() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = crate_dir.join("src");
    let doc = std::fs::read_to_string(crate_dir.join("../ARCHITECTURE.md")).unwrap();
    let layers = layers_from_architecture(&doc);
    assert!(!layers.is_empty(), "ARCHITECTURE.md's \"Inside the trainer\" table names no module");
    let modules = declared(&std::fs::read_to_string(src.join("lib.rs")).unwrap());
    let mut problems_found = Vec::new();
    for m in layers.keys().filter(|m| !modules.contains(m)) {
        problems_found.push(format!("ARCHITECTURE.md's table names `{m}`, which src/lib.rs does not declare"));
    }
    for m in modules.iter().filter(|m| !layers.contains_key(*m)) {
        problems_found.push(format!("module `{m}` of src/lib.rs is in no layer of ARCHITECTURE.md's table"));
    }
    if problems_found.is_empty() {
        problems_found = problems(&Sources::read(&src).unwrap(), &modules, &layers);
    }
    assert!(problems_found.is_empty(), "{}", problems_found.join("\n"));
}

#[test]
fn the_table_is_read_as_written() {
    let doc = "# x\n## Inside the trainer (`src`)\n\n| layer | modules | what |\n|---|---|---|\n\
               | 1 | `error`, `stats` | the error (`line_col`) |\n| 2 | `data` | `Dataset` |\n| 3 | `report` | r |\n\n\
               ## Outputs\n| 9 | `not_a_layer` | x |\n";
    let layers = layers_from_architecture(doc);
    assert_eq!(
        layers,
        BTreeMap::from([("error".into(), 1), ("stats".into(), 1), ("data".into(), 2), ("report".into(), 3)])
    );
    assert_eq!(declared("pub mod error;\nmod data;\npub use error::E;\nfn f() {}"), ["error", "data"]);
}

#[test]
fn a_use_of_a_later_layer_inside_a_group_or_through_a_re_export_is_caught() {
    let layers = BTreeMap::from([("error".to_string(), 1), ("data".to_string(), 2), ("report".to_string(), 6)]);
    let modules: Vec<String> = layers.keys().cloned().collect();
    let check = |data_import: &str| {
        let files = [
            ("", "pub mod error; pub mod data; pub mod report; pub use error::TrainerError;"),
            ("error", "pub struct TrainerError;"),
            ("data", "mod import; pub struct Dataset;"),
            ("data::import", data_import),
            ("report", "pub struct Page;"),
        ];
        let files = files.iter().map(|(m, text)| {
            let module: Module = m.split("::").filter(|s| !s.is_empty()).map(String::from).collect();
            (module, PathBuf::from(format!("{m}.rs")), text.to_string())
        });
        problems(&Sources::parse(files.collect()).unwrap(), &modules, &layers)
    };
    let wrong = check("use crate::{report, data};\nfn f() -> crate::TrainerError { todo!() }\n");
    assert_eq!(wrong.len(), 1, "{wrong:?}");
    assert!(wrong[0].contains("uses crate::report (`crate::report`), of layer 6"), "{wrong:?}");
    // `super::` out of a nested module reaches the crate root's modules too.
    assert_eq!(check("use super::super::report::Page;\n").len(), 1);
    assert!(check("use crate::TrainerError;\nuse super::Dataset;\n").is_empty());
}
