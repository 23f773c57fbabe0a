//! No import circle inside the crate: at every level of the module tree, the modules under one
//! parent depend on each other without a cycle (a file's `use crate::…`/`use super::…` trees
//! and every other `crate::`/`super::` path in its code, parsed with `syn`; `#[cfg(test)]`
//! modules are left out, as they may reach anywhere).
//!
//! A path is attributed to the deepest module it names; an item a parent re-exports counts as
//! the parent's (a child reading its parent's re-export is not an edge between siblings).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use syn::visit::Visit;

/// A module: its path from the crate root (`[]` is the crate).
type Module = Vec<String>;

/// Every module file of `src` with its module path.
fn modules(src: &Path) -> BTreeMap<Module, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                let rel = p.strip_prefix(src).unwrap().with_extension("");
                let mut m: Module = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
                if m.last().is_some_and(|l| l == "mod" || l == "lib") {
                    m.pop();
                }
                out.insert(m, p);
            }
        }
    }
    out
}

/// The `crate::`/`super::` paths of one file, resolved to absolute module-path segments.
struct Paths<'a> {
    here: &'a Module,
    /// Inline modules entered (`mod x { … }`), below `here`.
    inner: Vec<String>,
    found: BTreeSet<Vec<String>>,
}

impl Paths<'_> {
    fn add(&mut self, segs: Vec<String>) {
        let mut base: Vec<String> = self.here.iter().chain(self.inner.iter()).cloned().collect();
        let mut rest = segs.as_slice();
        match rest.first().map(String::as_str) {
            Some("crate") => {
                base.clear();
                rest = &rest[1..];
            }
            Some("super") => {
                while rest.first().is_some_and(|s| s == "super") {
                    base.pop();
                    rest = &rest[1..];
                }
            }
            Some("self") => rest = &rest[1..],
            _ => return,
        }
        base.extend(rest.iter().cloned());
        self.found.insert(base);
    }

    /// Every leaf path of a `use` tree under `prefix`.
    fn tree(&mut self, prefix: &mut Vec<String>, t: &syn::UseTree) {
        match t {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) => self.leaf(prefix, Some(n.ident.to_string())),
            syn::UseTree::Rename(r) => self.leaf(prefix, Some(r.ident.to_string())),
            syn::UseTree::Glob(_) => self.leaf(prefix, None),
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.tree(prefix, t);
                }
            }
        }
    }

    fn leaf(&mut self, prefix: &[String], name: Option<String>) {
        let mut segs = prefix.to_vec();
        segs.extend(name.filter(|n| n != "self"));
        self.add(segs);
    }
}

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs
        .iter()
        .any(|a| a.path().is_ident("cfg") && a.meta.require_list().is_ok_and(|l| l.tokens.to_string().contains("test")))
}

impl<'ast> Visit<'ast> for Paths<'_> {
    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        if !is_cfg_test(&u.attrs) {
            self.tree(&mut Vec::new(), &u.tree);
        }
    }

    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        if is_cfg_test(&m.attrs) {
            return;
        }
        self.inner.push(m.ident.to_string());
        syn::visit::visit_item_mod(self, m);
        self.inner.pop();
    }

    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        if !is_cfg_test(&f.attrs) {
            syn::visit::visit_item_fn(self, f);
        }
    }

    fn visit_path(&mut self, p: &'ast syn::Path) {
        self.add(p.segments.iter().map(|s| s.ident.to_string()).collect());
        syn::visit::visit_path(self, p);
    }
}

/// Module `a` depends on module `b` (both deepest known modules), per file.
fn edges(src: &Path) -> (BTreeSet<Module>, BTreeSet<(Module, Module)>) {
    let files = modules(src);
    let known: BTreeSet<Module> = files.keys().cloned().collect();
    let mut out = BTreeSet::new();
    for (m, path) in &files {
        let file = syn::parse_file(&std::fs::read_to_string(path).unwrap()).unwrap();
        let mut v = Paths { here: m, inner: Vec::new(), found: BTreeSet::new() };
        v.visit_file(&file);
        for p in v.found {
            // The deepest known module the path names.
            let target = (0..=p.len()).rev().map(|n| p[..n].to_vec()).find(|q| known.contains(q));
            if let Some(t) = target {
                if &t != m {
                    out.insert((m.clone(), t));
                }
            }
        }
    }
    (known, out)
}

/// A cycle among the children of one parent, if any: edges between the children (each
/// module counted as its ancestor among them).
fn cycle(known: &BTreeSet<Module>, deps: &BTreeSet<(Module, Module)>) -> Option<(Module, Vec<String>)> {
    for parent in known {
        let child = |m: &Module| -> Option<String> {
            (m.len() > parent.len() && m.starts_with(parent)).then(|| m[parent.len()].clone())
        };
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in deps {
            if let (Some(x), Some(y)) = (child(a), child(b)) {
                if x != y {
                    g.entry(x).or_default().insert(y);
                }
            }
        }
        // Depth-first search for a back edge.
        fn visit(
            n: &str,
            g: &BTreeMap<String, BTreeSet<String>>,
            state: &mut BTreeMap<String, u8>,
            path: &mut Vec<String>,
        ) -> Option<Vec<String>> {
            state.insert(n.to_string(), 1);
            path.push(n.to_string());
            for m in g.get(n).into_iter().flatten() {
                match state.get(m.as_str()).copied().unwrap_or(0) {
                    1 => {
                        let at = path.iter().position(|p| p == m).unwrap_or(0);
                        let mut c = path[at..].to_vec();
                        c.push(m.clone());
                        return Some(c);
                    }
                    0 => {
                        if let Some(c) = visit(m, g, state, path) {
                            return Some(c);
                        }
                    }
                    _ => {}
                }
            }
            path.pop();
            state.insert(n.to_string(), 2);
            None
        }
        let mut state = BTreeMap::new();
        for n in g.keys() {
            if !state.contains_key(n.as_str()) {
                if let Some(c) = visit(n, &g, &mut state, &mut Vec::new()) {
                    return Some((parent.clone(), c));
                }
            }
        }
    }
    None
}

#[test]
fn no_module_cycle_in_the_crate() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let (known, deps) = edges(&src);
    assert!(known.len() > 20, "modules found: {known:?}");
    if let Some((parent, c)) = cycle(&known, &deps) {
        panic!("import cycle under crate::{}: {}", parent.join("::"), c.join(" → "));
    }
}

/// The checker itself: a `use crate::{a, b}` group, a `super::` path and a path in code are
/// edges, and a circle through them is found.
#[test]
fn the_checker_finds_a_circle_through_use_groups_and_code_paths() {
    let dir = std::env::temp_dir().join(format!("fbg-modules-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("p")).unwrap();
    std::fs::write(dir.join("lib.rs"), "mod a; mod p;").unwrap();
    std::fs::write(dir.join("a.rs"), "use crate::{p::{x, y}, b};").unwrap();
    std::fs::write(dir.join("p/mod.rs"), "mod x; mod y;").unwrap();
    std::fs::write(dir.join("p/x.rs"), "fn f() { super::y::g(); }").unwrap();
    std::fs::write(dir.join("p/y.rs"), "fn g() { let _ = crate::p::x::f; }\n#[cfg(test)]\nmod tests { use crate::a; }")
        .unwrap();
    let (known, deps) = edges(&dir);
    let found = cycle(&known, &deps);
    std::fs::remove_dir_all(&dir).unwrap();
    let v = |s: &[&str]| s.iter().map(|x| x.to_string()).collect::<Vec<_>>();
    assert!(deps.contains(&(v(&["a"]), v(&["p", "x"]))));
    assert!(!deps.contains(&(v(&["p", "y"]), v(&["a"]))), "cfg(test) modules are left out");
    assert_eq!(found.map(|(p, _)| p), Some(v(&["p"])));
}
