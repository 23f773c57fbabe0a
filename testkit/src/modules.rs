//! No import circle among a crate's files (feature `modules`): at every level of the module
//! tree, the modules under one parent use each other without a cycle. A parent's own file
//! (`mod.rs`, `lib.rs`) is the face of its directory, so a parent and its children may use each
//! other; two children, or two files under two children, may not loop.
//!
//! What a file uses is read with `syn`: its `use` trees and every other path in its code
//! (`crate::`, `super::`, `self::`, a child module's or an imported name), each attributed to
//! the file that defines the item, through the `use` re-exports on the way (`super::Kept`
//! read from a parent that re-exports `detect::Kept` is a use of `detect.rs`). `#[cfg(test)]`
//! items are left out (tests may reach anywhere), and so are paths inside macro invocations
//! (tokens, not paths). A `main.rs` below `src` is a binary's root: `crate::` from its files
//! starts there.
//!
//! ```no_run
//! let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
//! fbg_testkit::modules::check(&src).unwrap();
//! ```

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use syn::visit::Visit;

/// A module: its path from the crate root (`[]` is the crate, `["data", "import"]` its
/// `data::import`).
pub type Module = Vec<String>;

/// Imports deeper than this are not followed (a `use` loop is a compile error anyway).
const MAX_HOPS: usize = 32;

/// A crate's source tree: its files, the `use` names in scope of each module and every path
/// its code writes.
pub struct Sources {
    /// Module → the file that holds it.
    files: BTreeMap<Module, PathBuf>,
    /// Every module, inline ones (`mod x { … }`) included.
    modules: BTreeSet<Module>,
    /// Module → name → the path the name was imported from, as written there.
    imports: BTreeMap<Module, BTreeMap<String, Vec<String>>>,
    /// (the file's module, the module the path is written in, the path as written).
    paths: Vec<(Module, Module, Vec<String>)>,
}

/// A dependency between two files: module `.0` uses an item of module `.1` (both file
/// modules), with one path that makes it, for messages.
pub type Edges = BTreeMap<(Module, Module), String>;

impl Sources {
    /// Every `.rs` file under `src`, parsed.
    pub fn read(src: &Path) -> Result<Sources, String> {
        let mut files = Vec::new();
        let mut stack = vec![src.to_path_buf()];
        while let Some(dir) = stack.pop() {
            let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            for e in entries {
                let p = e.map_err(|e| format!("{}: {e}", dir.display()))?.path();
                if p.is_dir() {
                    stack.push(p);
                } else if p.extension().is_some_and(|x| x == "rs") {
                    let text = std::fs::read_to_string(&p).map_err(|e| format!("{}: {e}", p.display()))?;
                    files.push((module_of(src, &p), p, text));
                }
            }
        }
        Sources::parse(files)
    }

    /// Files given as (module, path, text): the sources of [`Sources::read`], or made up in a
    /// test.
    pub fn parse(files: Vec<(Module, PathBuf, String)>) -> Result<Sources, String> {
        let mut s =
            Sources { files: BTreeMap::new(), modules: BTreeSet::new(), imports: BTreeMap::new(), paths: Vec::new() };
        for (module, path, text) in files {
            let file = syn::parse_file(&text).map_err(|e| format!("{}: {e}", path.display()))?;
            let mut r = Reader { file: &module, scope: module.clone(), sources: &mut s };
            r.visit_file(&file);
            s.modules.insert(module.clone());
            s.files.insert(module, path);
        }
        Ok(s)
    }

    /// The file modules and their files.
    pub fn files(&self) -> &BTreeMap<Module, PathBuf> {
        &self.files
    }

    /// The crate root of module `m`: the deepest ancestor held by a `main.rs`, else `[]`.
    fn root(&self, m: &[String]) -> Module {
        (0..=m.len())
            .rev()
            .map(|n| m[..n].to_vec())
            .find(|q| self.files.get(q).is_some_and(|f| f.file_name().is_some_and(|n| n == "main.rs")))
            .unwrap_or_default()
    }

    /// The absolute form of `path` written in module `scope`; `None` for a path outside the
    /// crate (`std::…`, another crate, a local name).
    fn absolute(&self, scope: &[String], path: &[String], hops: usize) -> Option<Vec<String>> {
        let (first, rest) = path.split_first()?;
        let mut base: Vec<String> = match first.as_str() {
            "crate" => self.root(scope),
            "self" => scope.to_vec(),
            "super" => {
                let mut b = scope.to_vec();
                b.pop();
                let mut rest = rest;
                while rest.first().is_some_and(|s| s == "super") {
                    b.pop();
                    rest = &rest[1..];
                }
                b.extend(rest.iter().cloned());
                return Some(b);
            }
            _ => {
                let child: Module = scope.iter().chain([first]).cloned().collect();
                if self.modules.contains(&child) {
                    child
                } else {
                    let imported = self.imports.get(scope)?.get(first)?;
                    if hops >= MAX_HOPS {
                        return None;
                    }
                    self.absolute(scope, imported, hops + 1)?
                }
            }
        };
        base.extend(rest.iter().cloned());
        Some(base)
    }

    /// The file that defines the item `path` (absolute) names, through the modules' imports.
    fn file_of(&self, mut path: Vec<String>) -> Option<Module> {
        for _ in 0..MAX_HOPS {
            let m = (0..=path.len()).rev().map(|n| path[..n].to_vec()).find(|q| self.modules.contains(q))?;
            let through = path.get(m.len()).and_then(|name| self.imports.get(&m)?.get(name));
            match through.and_then(|i| self.absolute(&m, i, 0)) {
                Some(mut next) if next != path => {
                    next.extend(path[m.len() + 1..].iter().cloned());
                    path = next;
                }
                _ => return (0..=m.len()).rev().map(|n| m[..n].to_vec()).find(|q| self.files.contains_key(q)),
            }
        }
        None
    }

    /// Every file-to-file use.
    pub fn edges(&self) -> Edges {
        let mut out = Edges::new();
        for (file, scope, path) in &self.paths {
            let Some(target) = self.absolute(scope, path, 0).and_then(|p| self.file_of(p)) else { continue };
            if &target != file {
                out.entry((file.clone(), target)).or_insert_with(|| path.join("::"));
            }
        }
        out
    }
}

/// The module of file `p` under `src` (`data/import/mod.rs` → `data::import`, `lib.rs` → the
/// crate, `cli/main.rs` → `cli`).
fn module_of(src: &Path, p: &Path) -> Module {
    let rel = p.strip_prefix(src).unwrap_or(p).with_extension("");
    let mut m: Module = rel.iter().map(|c| c.to_string_lossy().into_owned()).collect();
    if m.last().is_some_and(|l| l == "mod" || l == "lib" || l == "main") {
        m.pop();
    }
    m
}

/// Reads one file into [`Sources`].
struct Reader<'a> {
    file: &'a Module,
    /// The module being read (the file's, or an inline module in it).
    scope: Module,
    sources: &'a mut Sources,
}

impl Reader<'_> {
    fn path(&mut self, p: Vec<String>) {
        self.sources.paths.push((self.file.clone(), self.scope.clone(), p));
    }

    fn import(&mut self, name: String, p: Vec<String>) {
        self.sources.imports.entry(self.scope.clone()).or_default().insert(name, p.clone());
        self.path(p);
    }

    /// Every leaf of a `use` tree under `prefix`.
    fn tree(&mut self, prefix: &mut Vec<String>, t: &syn::UseTree) {
        match t {
            syn::UseTree::Path(p) => {
                prefix.push(p.ident.to_string());
                self.tree(prefix, &p.tree);
                prefix.pop();
            }
            syn::UseTree::Name(n) if n.ident == "self" => {
                if let Some(last) = prefix.last() {
                    self.import(last.clone(), prefix.clone());
                }
            }
            syn::UseTree::Name(n) => {
                let name = n.ident.to_string();
                self.import(name.clone(), prefix.iter().cloned().chain([name]).collect());
            }
            syn::UseTree::Rename(r) => {
                self.import(r.rename.to_string(), prefix.iter().cloned().chain([r.ident.to_string()]).collect());
            }
            syn::UseTree::Glob(_) => self.path(prefix.clone()),
            syn::UseTree::Group(g) => {
                for t in &g.items {
                    self.tree(prefix, t);
                }
            }
        }
    }
}

fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs
        .iter()
        .any(|a| a.path().is_ident("cfg") && a.meta.require_list().is_ok_and(|l| l.tokens.to_string().contains("test")))
}

impl<'ast> Visit<'ast> for Reader<'_> {
    fn visit_item_use(&mut self, u: &'ast syn::ItemUse) {
        if !is_cfg_test(&u.attrs) {
            self.tree(&mut Vec::new(), &u.tree);
        }
    }

    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        if is_cfg_test(&m.attrs) {
            return;
        }
        self.scope.push(m.ident.to_string());
        self.sources.modules.insert(self.scope.clone());
        syn::visit::visit_item_mod(self, m);
        self.scope.pop();
    }

    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        if !is_cfg_test(&f.attrs) {
            syn::visit::visit_item_fn(self, f);
        }
    }

    fn visit_item_impl(&mut self, i: &'ast syn::ItemImpl) {
        if !is_cfg_test(&i.attrs) {
            syn::visit::visit_item_impl(self, i);
        }
    }

    // `pub(crate)`, `pub(super)`: a visibility, not a use.
    fn visit_vis_restricted(&mut self, _: &'ast syn::VisRestricted) {}

    fn visit_path(&mut self, p: &'ast syn::Path) {
        self.path(p.segments.iter().map(|s| s.ident.to_string()).collect());
        syn::visit::visit_path(self, p);
    }
}

/// A cycle among the children of one parent: the parent and the children in the loop, the
/// first again at the end.
#[derive(Debug, PartialEq)]
pub struct Cycle {
    /// The parent module.
    pub parent: Module,
    /// The children, `a → b → … → a`.
    pub children: Vec<String>,
}

/// A cycle among the children of each parent that has one (each file counted as its ancestor
/// among them).
pub fn cycles(sources: &Sources, edges: &Edges) -> Vec<Cycle> {
    let mut out = Vec::new();
    for parent in &sources.modules {
        let child = |m: &Module| (m.len() > parent.len() && m.starts_with(parent)).then(|| m[parent.len()].clone());
        let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (a, b) in edges.keys() {
            if let (Some(x), Some(y)) = (child(a), child(b)) {
                if x != y {
                    g.entry(x).or_default().insert(y);
                }
            }
        }
        let mut state = BTreeMap::new();
        let found = g.keys().find_map(|n| {
            if state.contains_key(n) {
                return None;
            }
            back_edge(n, &g, &mut state, &mut Vec::new())
        });
        if let Some(children) = found {
            out.push(Cycle { parent: parent.clone(), children });
        }
    }
    out
}

/// Depth-first search from `n` for an edge back into the path: the loop it closes.
fn back_edge(
    n: &String,
    g: &BTreeMap<String, BTreeSet<String>>,
    state: &mut BTreeMap<String, bool>,
    path: &mut Vec<String>,
) -> Option<Vec<String>> {
    // `false`: on the path; `true`: done.
    state.insert(n.clone(), false);
    path.push(n.clone());
    for m in g.get(n).into_iter().flatten() {
        match state.get(m) {
            Some(false) => {
                let at = path.iter().position(|p| p == m).unwrap_or(0);
                return Some(path[at..].iter().chain([m]).cloned().collect());
            }
            None => {
                if let Some(c) = back_edge(m, g, state, path) {
                    return Some(c);
                }
            }
            Some(true) => {}
        }
    }
    path.pop();
    state.insert(n.clone(), true);
    None
}

/// The crate under `src` has no cycle; else each cycle found, with the files (`src/…`) and the
/// paths that make its steps.
pub fn check(src: &Path) -> Result<(), String> {
    let sources = Sources::read(src)?;
    let edges = sources.edges();
    let crate_dir = src.parent().unwrap_or(src);
    let file = |m: &Module| sources.files[m].strip_prefix(crate_dir).unwrap_or(&sources.files[m]).display().to_string();
    let mut msg = Vec::new();
    for c in cycles(&sources, &edges) {
        let parent = if c.parent.is_empty() { "crate".to_string() } else { c.parent.join("::") };
        msg.push(format!("import cycle under {parent}: {}", c.children.join(" → ")));
        let n = c.parent.len();
        let under = |m: &Module, child: &String| m.len() > n && m.starts_with(&c.parent) && &m[n] == child;
        for step in c.children.windows(2) {
            for ((a, b), path) in &edges {
                if under(a, &step[0]) && under(b, &step[1]) {
                    msg.push(format!("  {} uses {} ({path})", file(a), file(b)));
                }
            }
        }
    }
    if msg.is_empty() {
        Ok(())
    } else {
        Err(msg.join("\n"))
    }
}
