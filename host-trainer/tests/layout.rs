//! The library's modules follow the data: a module may use only the modules of earlier layers,
//! so there is no import cycle between them. The layers are ARCHITECTURE.md's table "Inside the
//! trainer" (the backticked names of its second column), so the document and the code are kept
//! in step: a module of `src/lib.rs` in no layer, a layer naming no module of `src/lib.rs`, or
//! a path to a module of the same or a later layer fails.
//!
//! Every source file of each module is parsed (`syn`): every `use` tree (`use crate::{a, b}`
//! names both) and every path in expressions, types and patterns (`crate::x::f()`), with
//! `super::` and `self::` resolved from the file's place in the module tree. Paths inside macro
//! invocations are tokens, not paths, and are not seen.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use syn::visit::Visit;

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

/// The top-level modules `src/lib.rs` declares, and the names it re-exports at the crate root
/// (`pub use error::TrainerError;`: `crate::TrainerError` is a use of `error`).
fn declared(lib: &syn::File) -> (Vec<String>, BTreeMap<String, String>) {
    let mut modules = Vec::new();
    let mut aliases = BTreeMap::new();
    for item in &lib.items {
        match item {
            syn::Item::Mod(m) => modules.push(m.ident.to_string()),
            syn::Item::Use(u) => {
                let mut paths = Vec::new();
                use_paths(&u.tree, Vec::new(), &mut paths);
                for p in paths {
                    if let (Some(first), Some(last)) = (p.first(), p.last()) {
                        aliases.insert(last.clone(), first.clone());
                    }
                }
            }
            _ => {}
        }
    }
    (modules, aliases)
}

/// Every path a `use` tree names, as segments (a rename keeps the original path; a glob or
/// `self` ends the path at its module).
fn use_paths(tree: &syn::UseTree, prefix: Vec<String>, out: &mut Vec<Vec<String>>) {
    let with = |seg: String| {
        let mut p = prefix.clone();
        p.push(seg);
        p
    };
    match tree {
        syn::UseTree::Path(p) => use_paths(&p.tree, with(p.ident.to_string()), out),
        syn::UseTree::Name(n) if n.ident == "self" => out.push(prefix),
        syn::UseTree::Name(n) => out.push(with(n.ident.to_string())),
        syn::UseTree::Rename(r) => out.push(with(r.ident.to_string())),
        syn::UseTree::Glob(_) => out.push(prefix),
        syn::UseTree::Group(g) => {
            for t in &g.items {
                use_paths(t, prefix.clone(), out);
            }
        }
    }
}

/// The top-level module an absolute or relative path names, from inside module `here` (its
/// path under the crate root), or `None` for a path that does not start at the crate
/// (`std::…`, a local name).
fn top_module(path: &[String], here: &[String]) -> Option<String> {
    let (first, rest) = path.split_first()?;
    match first.as_str() {
        "crate" => rest.first().cloned(),
        "self" => here.first().cloned().or_else(|| rest.first().cloned()),
        "super" => {
            let mut at: Vec<String> = here.to_vec();
            at.pop();
            let mut rest = rest;
            while rest.first().is_some_and(|s| s == "super") {
                at.pop();
                rest = &rest[1..];
            }
            at.first().cloned().or_else(|| rest.first().cloned())
        }
        _ => None,
    }
}

/// Collects the top-level modules a file's paths name.
struct Uses {
    /// The module the visitor is in (path under the crate root).
    here: Vec<String>,
    used: BTreeSet<String>,
}

impl Uses {
    fn add(&mut self, path: &[String]) {
        if let Some(m) = top_module(path, &self.here) {
            self.used.insert(m);
        }
    }
}

impl<'ast> Visit<'ast> for Uses {
    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        self.here.push(m.ident.to_string());
        syn::visit::visit_item_mod(self, m);
        self.here.pop();
    }

    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        let mut paths = Vec::new();
        use_paths(&u.tree, Vec::new(), &mut paths);
        for p in paths {
            self.add(&p);
        }
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        let segs: Vec<String> = p.segments.iter().map(|s| s.ident.to_string()).collect();
        self.add(&segs);
        syn::visit::visit_path(self, p);
    }
}

/// The top-level modules the source `text` of module `here` uses (itself included).
fn used_modules(text: &str, here: &[&str]) -> BTreeSet<String> {
    let file = syn::parse_file(text).expect("a source file that parses");
    let mut v = Uses { here: here.iter().map(|s| s.to_string()).collect(), used: BTreeSet::new() };
    v.visit_file(&file);
    v.used
}

/// What is wrong with module `module` using `used`: a module of the same or a later layer, or
/// one in no layer (`aliases`: root re-exports, resolved to their module).
fn problems_of(
    module: &str,
    used: &BTreeSet<String>,
    layers: &BTreeMap<String, usize>,
    aliases: &BTreeMap<String, String>,
    file: &Path,
) -> Vec<String> {
    let mine = layers[module];
    let mut out = Vec::new();
    for u in used {
        let u = aliases.get(u).unwrap_or(u);
        if u == module {
            continue;
        }
        match layers.get(u) {
            Some(&l) if l < mine => {}
            Some(&l) => out.push(format!(
                "{} (module `{module}`, layer {mine}) uses `crate::{u}`, of layer {l}: the same or a later one",
                file.display()
            )),
            None => out.push(format!("{} (module `{module}`) uses `crate::{u}`, which is in no layer", file.display())),
        }
    }
    out
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

/// The module path of `file` under the crate root (`src/fit/select.rs` → `fit::select`,
/// `src/fit/mod.rs` → `fit`).
fn module_path(src: &Path, file: &Path) -> Vec<String> {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut segs: Vec<String> = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    if segs.last().is_some_and(|s| s == "mod") {
        segs.pop();
    }
    segs
}

#[test]
fn every_module_uses_only_earlier_layers_of_architecture_md() {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let src = crate_dir.join("src");
    let doc = std::fs::read_to_string(crate_dir.join("../ARCHITECTURE.md")).unwrap();
    let layers = layers_from_architecture(&doc);
    assert!(!layers.is_empty(), "ARCHITECTURE.md's \"Inside the trainer\" table names no module");
    let lib = syn::parse_file(&std::fs::read_to_string(src.join("lib.rs")).unwrap()).unwrap();
    let (modules, aliases) = declared(&lib);
    let mut problems = Vec::new();
    for m in layers.keys().filter(|m| !modules.contains(m)) {
        problems.push(format!("ARCHITECTURE.md's table names `{m}`, which src/lib.rs does not declare"));
    }
    for m in &modules {
        if !layers.contains_key(m) {
            problems.push(format!("module `{m}` of src/lib.rs is in no layer of ARCHITECTURE.md's table"));
            continue;
        }
        let mut files = Vec::new();
        rust_files(&src.join(format!("{m}.rs")), &mut files);
        rust_files(&src.join(m), &mut files);
        assert!(!files.is_empty(), "module `{m}` has no source file");
        for f in files {
            let here = module_path(&src, &f);
            let here: Vec<&str> = here.iter().map(String::as_str).collect();
            let used = used_modules(&std::fs::read_to_string(&f).unwrap(), &here);
            problems.extend(problems_of(m, &used, &layers, &aliases, &f));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_table_and_the_paths_are_read_as_written() {
    let doc = "# x\n## Inside the trainer (`src`)\n\n| layer | modules | what |\n|---|---|---|\n\
               | 1 | `error`, `stats` | the error (`line_col`) |\n| 2 | `data` | `Dataset` |\n| 3 | `report` | r |\n\n\
               ## Outputs\n| 9 | `not_a_layer` | x |\n";
    let layers = layers_from_architecture(doc);
    assert_eq!(
        layers,
        BTreeMap::from([("error".into(), 1), ("stats".into(), 1), ("data".into(), 2), ("report".into(), 3)])
    );
    let text = "use crate::{error::E, stats};\nuse super::super::data::X as Y;\nuse self::inner::*;\n\
                fn f() -> crate::report::R { super::sibling::g(); std::mem::drop(1); crate::data::h() }\n";
    let used = used_modules(text, &["data", "import", "logger"]);
    assert_eq!(used, BTreeSet::from(["error".into(), "stats".into(), "data".into(), "report".into()]));
}

#[test]
fn a_use_of_a_later_layer_inside_a_group_is_caught() {
    let layers = BTreeMap::from([("error".to_string(), 1), ("data".to_string(), 2), ("report".to_string(), 6)]);
    let aliases = BTreeMap::from([("TrainerError".to_string(), "error".to_string())]);
    let wrong = used_modules("use crate::{report, data};\nfn f() -> crate::TrainerError { todo!() }\n", &["data"]);
    let problems = problems_of("data", &wrong, &layers, &aliases, Path::new("src/data/mod.rs"));
    assert_eq!(problems.len(), 1, "{problems:?}");
    assert!(problems[0].contains("uses `crate::report`, of layer 6"), "{problems:?}");
    // `super::` out of a nested module reaches the crate root's modules too.
    let via_super = used_modules("use super::super::report::Page;\n", &["data", "import"]);
    assert!(!problems_of("data", &via_super, &layers, &aliases, Path::new("src/data/import.rs")).is_empty());
    let fine = used_modules("use crate::error::TrainerError;\nuse super::Dataset;\n", &["data", "files"]);
    assert!(problems_of("data", &fine, &layers, &aliases, Path::new("src/data/files.rs")).is_empty());
}
