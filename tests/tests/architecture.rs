//! ARCHITECTURE.md's crate table and diagram are kept in step with the `Cargo.toml` files: every
//! crate of both workspaces (and the fuzz crate) has a row, and the row's "depends on" and "for
//! tests also" columns name exactly the project's crates it depends on (normal and build
//! dependencies; dev-dependencies not already normal ones).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// One row of the crate table.
#[derive(Debug, PartialEq)]
struct Row {
    path: String,
    depends: BTreeSet<String>,
    dev: BTreeSet<String>,
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap().to_path_buf()
}

/// Backticked names in a table cell.
fn ticked(cell: &str) -> BTreeSet<String> {
    cell.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

/// The rows of the table under "## Crates and who may depend on whom", by crate name.
fn table(doc: &str) -> BTreeMap<String, Row> {
    let section = doc.split("## Crates and who may depend on whom").nth(1).expect("the crates section");
    let section = section.split("\n## ").next().unwrap_or(section);
    let mut rows = BTreeMap::new();
    for line in section.lines().filter(|l| l.starts_with("| `")) {
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
        assert_eq!(cells.len(), 5, "a crate row has five cells: {line}");
        let name = ticked(cells[0]).into_iter().next().expect("crate name");
        let path = ticked(cells[1]).into_iter().next().expect("crate path");
        rows.insert(name, Row { path, depends: ticked(cells[3]), dev: ticked(cells[4]) });
    }
    rows
}

/// The project's crates `manifest` names in `section`s.
fn deps(manifest: &toml::Table, sections: &[&str], ours: &BTreeSet<String>) -> BTreeSet<String> {
    sections
        .iter()
        .filter_map(|s| manifest.get(*s).and_then(|v| v.as_table()))
        .flat_map(|t| t.keys().cloned())
        .filter(|k| ours.contains(k))
        .collect()
}

/// What the manifests say, for the crates (paths) of the table.
fn manifests(paths: &BTreeMap<String, String>) -> BTreeMap<String, Row> {
    let ours: BTreeSet<String> = paths.keys().cloned().collect();
    let mut out = BTreeMap::new();
    for (name, dir) in paths {
        let file = root().join(dir).join("Cargo.toml");
        let text = std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let m: toml::Table = toml::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let declared = m["package"]["name"].as_str().unwrap().to_string();
        assert_eq!(&declared, name, "{} declares `{declared}`, the table says `{name}`", file.display());
        let depends = deps(&m, &["dependencies", "build-dependencies"], &ours);
        let dev = &deps(&m, &["dev-dependencies"], &ours) - &depends;
        out.insert(name.clone(), Row { path: dir.clone(), depends, dev });
    }
    out
}

/// Every `Cargo.toml` with a `[package]` under the repository (outside `target/`).
fn every_package(dir: &Path, out: &mut BTreeSet<String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        if p.is_dir() && !name.starts_with('.') && name != "target" {
            every_package(&p, out);
        } else if name == "Cargo.toml" {
            let m: toml::Table = toml::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
            if let Some(n) = m.get("package").and_then(|p| p.get("name")).and_then(|n| n.as_str()) {
                out.insert(n.to_string());
            }
        }
    }
}

#[test]
fn the_crate_table_matches_the_manifests() {
    let doc = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    let rows = table(&doc);
    let mut found = BTreeSet::new();
    every_package(&root(), &mut found);
    let listed: BTreeSet<String> = rows.keys().cloned().collect();
    assert_eq!(listed, found, "ARCHITECTURE.md's crate table against the packages of the repository");

    let paths: BTreeMap<String, String> =
        rows.iter().map(|(n, r)| (n.clone(), r.path.trim_end_matches('/').to_string())).collect();
    let actual = manifests(&paths);
    let mut problems = Vec::new();
    for (name, row) in &rows {
        let a = &actual[name];
        if row.depends != a.depends {
            problems
                .push(format!("{name}: the table says it depends on {:?}, Cargo.toml on {:?}", row.depends, a.depends));
        }
        if row.dev != a.dev {
            problems.push(format!("{name}: the table says its tests also use {:?}, Cargo.toml {:?}", row.dev, a.dev));
        }
    }
    assert!(problems.is_empty(), "ARCHITECTURE.md is out of step:\n{}", problems.join("\n"));
}

#[test]
fn the_diagram_names_every_crate() {
    let doc = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    let section = doc.split("## Crates and who may depend on whom").nth(1).unwrap();
    let diagram = section.split("```").nth(1).expect("the diagram");
    let missing: Vec<String> =
        table(&doc).into_keys().filter(|n| n != "fbg-shared-fuzz" && !diagram.contains(n.as_str())).collect();
    assert!(missing.is_empty(), "crates missing from the diagram: {missing:?}");
}

#[test]
fn a_row_out_of_step_is_caught() {
    let doc = "## Crates and who may depend on whom\n\n| crate | path | what | depends on | for tests also |\n|---|---|---|---|---|\n| `fbg-link` | `link/` | x | — | — |\n";
    let rows = table(doc);
    let paths = BTreeMap::from([
        ("fbg-link".to_string(), "link".to_string()),
        ("fbg-shared".to_string(), "shared".to_string()),
    ]);
    let actual = manifests(&paths);
    assert!(rows["fbg-link"].depends.is_empty());
    assert!(actual["fbg-link"].depends.contains("fbg-shared"), "the manifest's dependency is seen, so the row differs");
}
