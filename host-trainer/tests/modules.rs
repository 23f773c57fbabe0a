//! No import circle among the trainer's files, the library's and the command line's: at every
//! level of the module tree, the modules under one parent use each other without a cycle
//! (`fbg_testkit::modules`; `layout.rs` orders the library's top-level modules in layers).

use std::path::{Path, PathBuf};

use fbg_testkit::modules::{check, cycles, Cycle, Module, Sources};

#[test]
fn no_module_cycle_in_the_crate() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    if let Err(e) = check(&src) {
        panic!("{e}");
    }
}

fn m(s: &str) -> Module {
    s.split("::").filter(|x| !x.is_empty()).map(String::from).collect()
}

fn sources(files: &[(&str, &str)]) -> Sources {
    let files = files.iter().map(|(module, text)| (m(module), PathBuf::from(format!("{module}.rs")), text.to_string()));
    Sources::parse(files.collect()).unwrap()
}

/// A `use crate::{a, b}` group, a `super::` path and a path in code are uses, a `#[cfg(test)]`
/// module is not, and a circle through them is found.
#[test]
fn the_checker_finds_a_circle_through_use_groups_and_code_paths() {
    let s = sources(&[
        ("", "mod a; mod p;"),
        ("a", "use crate::{p::{x, y}, b};"),
        ("p", "mod x; mod y;"),
        ("p::x", "fn f() { super::y::g(); }"),
        ("p::y", "fn g() { let _ = crate::p::x::f; }\n#[cfg(test)]\nmod tests { use crate::a; }"),
    ]);
    let edges = s.edges();
    assert!(edges.contains_key(&(m("a"), m("p::x"))));
    assert!(!edges.contains_key(&(m("p::y"), m("a"))), "cfg(test) modules are left out");
    assert_eq!(cycles(&s, &edges), [Cycle { parent: m("p"), children: vec!["x".into(), "y".into(), "x".into()] }]);
}

/// A parent's re-export does not hide a circle between its children: `super::Kept` is a use
/// of the file that defines `Kept`, however many `use`s it passes through.
#[test]
fn a_use_through_the_parents_re_export_is_a_use_of_the_defining_file() {
    let s = sources(&[
        ("p", "mod detect; mod plausible; mod kept_names; pub(crate) use detect::Kept; use self::kept_names as k;"),
        ("p::detect", "pub trait Kept {} fn f() { super::plausible::implausible(); }"),
        ("p::plausible", "use super::Kept; pub fn implausible() {}"),
        ("p::kept_names", "pub use super::detect::Kept as Renamed;"),
    ]);
    let edges = s.edges();
    assert_eq!(edges.get(&(m("p::plausible"), m("p::detect"))).map(String::as_str), Some("super::Kept"));
    assert!(!edges.contains_key(&(m("p::plausible"), m("p"))));
    assert_eq!(cycles(&s, &edges).into_iter().map(|c| c.parent).collect::<Vec<_>>(), [m("p")]);
    // A parent and its own children may use each other.
    let s = sources(&[("p", "mod a; pub struct T; fn f() { a::g(); }"), ("p::a", "use super::T; pub fn g() {}")]);
    assert!(s.edges().contains_key(&(m("p::a"), m("p"))));
    assert_eq!(cycles(&s, &s.edges()), []);
}

/// `crate::` in a binary's files (`cli/main.rs` and below) starts at the binary's root.
#[test]
fn a_binary_below_src_is_a_crate_of_its_own() {
    let files =
        [("cli", "main", "mod a; mod b;"), ("cli::a", "a", "use crate::b::X;"), ("cli::b", "b", "pub struct X;")];
    let files =
        files.iter().map(|(module, file, text)| (m(module), PathBuf::from(format!("{file}.rs")), text.to_string()));
    let s = Sources::parse(files.collect()).unwrap();
    assert!(s.edges().contains_key(&(m("cli::a"), m("cli::b"))));
}
