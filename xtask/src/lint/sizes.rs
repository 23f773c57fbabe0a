//! Source sizes: no `.rs` file over [`MAX_FILE_LINES`] lines, no function over
//! [`MAX_FN_LINES`] lines outside tests, in every workspace of the repository (the host, the
//! firmware and the fuzz target; `target/` directories skipped).
//!
//! The files are parsed with `syn`; a function's length runs from its `fn` keyword to its
//! closing brace (span locations). Test code is exempt from the function rule, not from the
//! file rule: files under a `tests/` or `benches/` directory, inline modules under
//! `#[cfg(test)]`, and the files of out-of-line modules declared under `#[cfg(test)]`
//! (`#[cfg(test)] mod tests;`), with their own submodules.

use std::collections::BTreeSet;
use std::fs;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use syn::spanned::Spanned;
use syn::visit::Visit;

/// The longest a source file may be.
pub const MAX_FILE_LINES: usize = 800;
/// The longest a function outside tests may be.
pub const MAX_FN_LINES: usize = 120;

/// One rule broken.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Offender {
    /// File, relative to the repository root.
    pub path: PathBuf,
    /// Line of the file (1 for a whole file).
    pub line: usize,
    /// `fn name`, or `file`.
    pub what: String,
    /// Its length in lines.
    pub lines: usize,
}

impl std::fmt::Display for Offender {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{} {}: {} lines", self.path.display(), self.line, self.what, self.lines)
    }
}

/// Check every `.rs` under `root`; fail naming each offender.
pub fn check(root: &Path) -> Result<()> {
    let mut files = Vec::new();
    rust_files(root, &mut files)?;
    files.sort();
    let mut parsed = Vec::new();
    for f in &files {
        let text = fs::read_to_string(f).with_context(|| format!("reading {}", f.display()))?;
        let ast = syn::parse_file(&text).with_context(|| format!("parsing {}", f.display()))?;
        parsed.push((f.clone(), text, ast));
    }
    // Out-of-line test modules, from their declarations.
    let mut test_files = BTreeSet::new();
    for (f, _, ast) in &parsed {
        test_module_files(f, &ast.items, false, &mut test_files);
    }
    let mut offenders = Vec::new();
    for (f, text, ast) in &parsed {
        let rel = f.strip_prefix(root).unwrap_or(f).to_path_buf();
        let is_test = is_test_path(&rel) || test_files.iter().any(|t| f == t || f.starts_with(t.with_extension("")));
        offenders.extend(offenders_in(&rel, text, ast, is_test));
    }
    report(&offenders, files.len())
}

fn report(offenders: &[Offender], files: usize) -> Result<()> {
    if offenders.is_empty() {
        eprintln!(
            "xtask: {files} source files: none over {MAX_FILE_LINES} lines, no function over {MAX_FN_LINES} lines outside tests"
        );
        return Ok(());
    }
    for o in offenders {
        eprintln!("{o}");
    }
    bail!(
        "{} source files or functions are too long (files ≤ {MAX_FILE_LINES} lines, functions outside tests ≤ \
         {MAX_FN_LINES} lines)",
        offenders.len()
    )
}

/// The offenders of one parsed file (`is_test`: the whole file is test code).
pub fn offenders_in(rel: &Path, text: &str, ast: &syn::File, is_test: bool) -> Vec<Offender> {
    let mut out = Vec::new();
    let n = text.lines().count();
    if n > MAX_FILE_LINES {
        out.push(Offender { path: rel.to_path_buf(), line: 1, what: "file".into(), lines: n });
    }
    if !is_test {
        let mut v = FnLengths { path: rel, in_test: 0, out: &mut out };
        v.visit_file(ast);
    }
    out
}

/// Every `.rs` file under `dir`, skipping `target/` and hidden directories.
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    for e in fs::read_dir(dir).with_context(|| format!("reading {}", dir.display()))? {
        let path = e?.path();
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        if path.is_dir() {
            if name != "target" && !name.starts_with('.') {
                rust_files(&path, out)?;
            }
        } else if name.ends_with(".rs") {
            out.push(path);
        }
    }
    Ok(())
}

/// Integration tests and benches (a `tests` or `benches` directory of a crate).
fn is_test_path(rel: &Path) -> bool {
    rel.parent().is_some_and(|p| p.components().any(|c| c.as_os_str() == "tests" || c.as_os_str() == "benches"))
}

/// Whether the attributes hold `#[cfg(test)]` (or a `cfg` that needs `test`).
fn is_cfg_test(attrs: &[syn::Attribute]) -> bool {
    attrs.iter().any(|a| {
        a.path().is_ident("cfg") && {
            let t = a.meta.require_list().map(|l| l.tokens.to_string()).unwrap_or_default();
            t.split(|c: char| !c.is_alphanumeric() && c != '_').any(|w| w == "test") && !t.contains("not")
        }
    })
}

/// The directory a module declared in `file` puts its children's files in.
fn child_dir(file: &Path) -> PathBuf {
    let stem = file.file_stem().and_then(|s| s.to_str()).unwrap_or("");
    let parent = file.parent().map(Path::to_path_buf).unwrap_or_default();
    if matches!(stem, "mod" | "lib" | "main") {
        parent
    } else {
        parent.join(stem)
    }
}

/// The files of out-of-line modules declared under `#[cfg(test)]` in `file` (inline modules
/// followed; `in_test`: already inside a test module).
fn test_module_files(file: &Path, items: &[syn::Item], in_test: bool, out: &mut BTreeSet<PathBuf>) {
    test_modules_in(file, &child_dir(file), items, in_test, out);
}

fn test_modules_in(file: &Path, dir: &Path, items: &[syn::Item], in_test: bool, out: &mut BTreeSet<PathBuf>) {
    for item in items {
        let syn::Item::Mod(m) = item else { continue };
        let test = in_test || is_cfg_test(&m.attrs);
        let name = m.ident.to_string();
        match &m.content {
            Some((_, inner)) => test_modules_in(file, &dir.join(&name), inner, test, out),
            None if test => {
                let explicit = m.attrs.iter().find(|a| a.path().is_ident("path")).and_then(|a| match &a.meta {
                    syn::Meta::NameValue(nv) => match &nv.value {
                        syn::Expr::Lit(syn::ExprLit { lit: syn::Lit::Str(s), .. }) => Some(s.value()),
                        _ => None,
                    },
                    _ => None,
                });
                let base = file.parent().map(Path::to_path_buf).unwrap_or_default();
                match explicit {
                    Some(p) => {
                        out.insert(base.join(p));
                    }
                    None => {
                        out.insert(dir.join(format!("{name}.rs")));
                        out.insert(dir.join(&name).join("mod.rs"));
                    }
                }
            }
            None => {}
        }
    }
}

/// Collects the functions over [`MAX_FN_LINES`] outside `#[cfg(test)]` modules.
struct FnLengths<'a> {
    path: &'a Path,
    /// Depth of `#[cfg(test)]` modules around the current item.
    in_test: usize,
    out: &'a mut Vec<Offender>,
}

impl FnLengths<'_> {
    fn measure(&mut self, name: &syn::Ident, fn_token: &syn::token::Fn, block: &syn::Block) {
        if self.in_test > 0 {
            return;
        }
        let start = fn_token.span().start().line;
        let end = block.brace_token.span.close().end().line;
        let n = end.saturating_sub(start) + 1;
        if n > MAX_FN_LINES {
            self.out.push(Offender {
                path: self.path.to_path_buf(),
                line: start,
                what: format!("fn {name}"),
                lines: n,
            });
        }
    }
}

impl<'ast> Visit<'ast> for FnLengths<'_> {
    fn visit_item_mod(&mut self, m: &'ast syn::ItemMod) {
        let test = is_cfg_test(&m.attrs);
        self.in_test += usize::from(test);
        syn::visit::visit_item_mod(self, m);
        self.in_test -= usize::from(test);
    }

    fn visit_item_fn(&mut self, f: &'ast syn::ItemFn) {
        self.measure(&f.sig.ident, &f.sig.fn_token, &f.block);
        syn::visit::visit_item_fn(self, f);
    }

    fn visit_impl_item_fn(&mut self, f: &'ast syn::ImplItemFn) {
        self.measure(&f.sig.ident, &f.sig.fn_token, &f.block);
        syn::visit::visit_impl_item_fn(self, f);
    }

    fn visit_trait_item_fn(&mut self, f: &'ast syn::TraitItemFn) {
        if let Some(block) = &f.default {
            self.measure(&f.sig.ident, &f.sig.fn_token, block);
        }
        syn::visit::visit_trait_item_fn(self, f);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn long_fn(name: &str, body_lines: usize) -> String {
        format!("fn {name}() {{\n{}}}\n", "    let _ = 1;\n".repeat(body_lines))
    }

    #[test]
    fn long_functions_are_named_with_their_line_and_length() {
        let text = format!(
            "//! doc\n{}{}impl S {{\n{}}}\n#[cfg(test)]\nmod tests {{\n{}}}\n",
            long_fn("short", 10),
            long_fn("long", 119),
            long_fn("method", 130),
            long_fn("in_test", 200)
        );
        let ast = syn::parse_file(&text).unwrap();
        let got: Vec<String> =
            offenders_in(Path::new("a/b.rs"), &text, &ast, false).iter().map(ToString::to_string).collect();
        assert_eq!(got, ["a/b.rs:14 fn long: 121 lines", "a/b.rs:136 fn method: 132 lines"]);
        // Test files are held to the file rule only.
        let big = format!("{}\n", "// x\n".repeat(MAX_FILE_LINES));
        let ast = syn::parse_file(&format!("{big}{}", long_fn("t", 300))).unwrap();
        let got = offenders_in(Path::new("tests/x.rs"), &format!("{big}{}", long_fn("t", 300)), &ast, true);
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].what, "file");
    }

    #[test]
    fn test_modules_and_test_directories_are_recognised() {
        assert!(is_test_path(Path::new("host-trainer/tests/layout.rs")));
        assert!(is_test_path(Path::new("shared/benches/step.rs")));
        assert!(!is_test_path(Path::new("xtask/src/tests.rs")));
        let ast =
            syn::parse_file("#[cfg(test)]\nmod tests;\nmod inner { #[cfg(test)] mod more; }\nmod real;\n").unwrap();
        let mut out = BTreeSet::new();
        test_module_files(Path::new("x/src/fixtures.rs"), &ast.items, false, &mut out);
        assert!(out.contains(Path::new("x/src/fixtures/tests.rs")));
        assert!(out.contains(Path::new("x/src/fixtures/inner/more.rs")));
        assert!(!out.iter().any(|p| p.ends_with("real.rs")));
        let mut out = BTreeSet::new();
        test_module_files(Path::new("x/src/lib.rs"), &ast.items, false, &mut out);
        assert!(out.contains(Path::new("x/src/tests.rs")));
    }
}
