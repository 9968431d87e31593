//! The public surface (issue 46): what a library user can name, counted from the source as
//! `layers.rs` reads it, must stay at most [`MOST`] items. The modules are private, so the
//! surface is what `src/lib.rs` re-exports outside `internals` (the command line's, tests' and
//! benches' door, `#[doc(hidden)]` and not API).
//!
//! How it counts, as the Rust reference counts items: each name the crate root re-exports
//! is one item, and so is each associated item a user reaches through it: every `pub fn` and
//! `pub const` of the type's inherent `impl` blocks (in its own top-level module), and every
//! method of a trait (a type alias reaches its target's). Fields and enum variants belong to
//! their type and are not counted; nor are trait impls (`Default`, `Job for ConvertJob`),
//! which add no name.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The most public items the crate may have.
const MOST: usize = 200;

/// The library's source files (the command line's left out), each cut before its test module.
fn library() -> BTreeMap<PathBuf, String> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    crate::layers::walk(&src, &mut files);
    files
        .into_iter()
        .filter(|f| {
            let rel = f.strip_prefix(&src).unwrap();
            !rel.starts_with("cli") && !rel.starts_with("main.rs")
        })
        .map(|f| {
            let text = std::fs::read_to_string(&f).unwrap();
            let text = match text.find("#[cfg(test)]\nmod ") {
                Some(i) => text[..i].to_owned(),
                None => text,
            };
            (f.strip_prefix(&src).unwrap().to_path_buf(), text)
        })
        .collect()
}

/// The crate root's re-exports outside `internals`: (path below the root, original name,
/// name the user sees), from every `pub use` statement, groups included.
fn facade(lib: &str) -> Vec<(String, String, String)> {
    let head = lib.split("pub mod internals").next().unwrap();
    let mut out = Vec::new();
    for stmt in head.split("pub use ").skip(1) {
        let stmt = &stmt[..stmt.find(';').unwrap()];
        let (prefix, items) = match stmt.find('{') {
            Some(i) => (&stmt[..i], stmt[i + 1..stmt.rfind('}').unwrap()].to_owned()),
            None => ("", stmt.to_owned()),
        };
        for item in items.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let (path, alias) = match item.split_once(" as ") {
                Some((p, a)) => (p.trim(), a.trim()),
                None => (item, item.rsplit("::").next().unwrap()),
            };
            let full = format!("{prefix}{path}");
            let name = full.rsplit("::").next().unwrap().to_owned();
            out.push((full, name, alias.to_owned()));
        }
    }
    out
}

/// The associated items a user reaches through `name`, defined in `files`: its inherent
/// impls' `pub fn`s and `pub const`s, or a trait's methods. None: no such definition.
fn members(name: &str, files: &[(&PathBuf, &String)]) -> Option<usize> {
    let def = |kind: &str| format!("pub {kind} {name}");
    let starts = |l: &str, kind: &str| {
        l.starts_with(&def(kind))
            && l[def(kind).len()..].starts_with(|c: char| !(c.is_alphanumeric() || c == '_'))
    };
    let mut found = false;
    let mut n = 0;
    for (_, text) in files {
        let lines: Vec<&str> = text.lines().collect();
        for (i, l) in lines.iter().enumerate() {
            let block = |from: usize| {
                lines[from + 1..]
                    .iter()
                    .take_while(|l| **l != "}")
                    .filter(|l| l.starts_with("    ") && !l.starts_with("     "))
                    .map(|l| l.trim_start())
                    .collect::<Vec<_>>()
            };
            if ["struct", "enum", "type", "fn", "const", "static"]
                .iter()
                .any(|k| starts(l, k))
            {
                found = true;
            }
            if starts(l, "trait") {
                found = true;
                n += block(i).iter().filter(|l| l.starts_with("fn ")).count();
            }
            // `impl Name {`, `impl<T> Name<T> {`, never `impl Trait for Name {`.
            let head = l
                .strip_prefix("impl")
                .filter(|h| l.ends_with('{') && !h.contains(" for "));
            let target = head.map(|h| {
                let h = if h.starts_with('<') {
                    &h[h.find('>').unwrap() + 1..]
                } else {
                    h
                };
                h.trim()
                    .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .next()
                    .unwrap()
                    .to_owned()
            });
            if target.as_deref() == Some(name) {
                n += block(i)
                    .iter()
                    .filter(|l| {
                        ["pub fn ", "pub const fn ", "pub unsafe fn ", "pub const "]
                            .iter()
                            .any(|p| l.starts_with(p))
                    })
                    .count();
            }
        }
    }
    found.then_some(n)
}

/// Each facade name with its item count, and the total.
fn count() -> (Vec<(String, usize)>, usize) {
    let lib = library();
    let root = &lib[Path::new("lib.rs")];
    let mut rows = Vec::new();
    for (path, name, alias) in facade(root) {
        // The definition's top-level module, or the whole library for a re-export from
        // elsewhere (`jobs::Progress` is `progress::Progress`).
        let top = path.split("::").next().unwrap().to_owned();
        let in_module: Vec<(&PathBuf, &String)> = lib
            .iter()
            .filter(|(p, _)| {
                p.components().next().unwrap().as_os_str().to_string_lossy() == *top.as_str()
                    || p.as_path() == Path::new(&format!("{top}.rs"))
            })
            .collect();
        let everywhere: Vec<(&PathBuf, &String)> = lib.iter().collect();
        let n = members(&name, &in_module)
            .or_else(|| members(&name, &everywhere))
            .unwrap_or_else(|| panic!("{path}: no definition found for the facade's {alias}"));
        // A type alias reaches its target's associated items (`Warning` is `error::Text`).
        let aliased = lib.values().find_map(|text| {
            let line = text
                .lines()
                .find(|l| l.starts_with(&format!("pub type {name} = ")))?;
            let target = line.trim_end_matches(';').rsplit("::").next()?.to_owned();
            let target = target.rsplit(' ').next()?.to_owned();
            target
                .chars()
                .all(|c| c.is_alphanumeric() || c == '_')
                .then_some(target)
        });
        let via = aliased.and_then(|t| members(&t, &everywhere)).unwrap_or(0);
        rows.push((alias, 1 + n + via));
    }
    let total = rows.iter().map(|(_, n)| n).sum();
    (rows, total)
}

#[test]
fn the_public_surface_stays_small() {
    let lib = library();
    let root = &lib[Path::new("lib.rs")];
    // The root declares no public module but `internals`, and no item of its own (the
    // README's doctest holder is built for doctests only).
    for l in root.lines() {
        let l = l.trim_start();
        if l.starts_with("pub mod ") {
            assert!(
                l.starts_with("pub mod internals"),
                "{l}: modules are private; re-export what a user needs at the root"
            );
        }
    }
    let (rows, total) = count();
    assert!(rows.len() > 40, "the facade was not read: {rows:?}");
    let list: Vec<String> = rows.iter().map(|(n, c)| format!("{n} {c}")).collect();
    println!("{total} public items: {}", list.join(", "));
    assert!(
        total <= MOST,
        "{total} public items (at most {MOST}): {}. Keep new plumbing crate-only, or reach it \
         through `internals`",
        list.join(", ")
    );
}

/// The counter itself: names, aliases, groups, inherent impls, traits.
#[test]
fn the_count_reads_items_as_written() {
    let lib = "pub use a::{B, c::D as E};\npub use f::G;\n#[doc(hidden)]\npub mod internals {\n    pub use crate::x::Y;\n}\n";
    let got: Vec<(String, String, String)> = facade(lib);
    let want = [
        ("a::B", "B", "B"),
        ("a::c::D", "D", "E"),
        ("f::G", "G", "G"),
    ];
    let want: Vec<(String, String, String)> = want
        .iter()
        .map(|(a, b, c)| (a.to_string(), b.to_string(), c.to_string()))
        .collect();
    assert_eq!(got, want);
    let text = "pub struct B {\n    pub x: u32,\n}\n\nimpl B {\n    pub fn new() -> B {\n        B { x: 0 }\n    }\n    fn private() {}\n    pub const N: u32 = 1;\n}\n\nimpl Default for B {\n    fn default() -> B {\n        B::new()\n    }\n}\n\npub trait T {\n    fn a(&self);\n    fn b(&self) {}\n}\n".to_owned();
    let p = PathBuf::from("a.rs");
    let files = [(&p, &text)];
    assert_eq!(members("B", &files), Some(2));
    assert_eq!(members("T", &files), Some(2));
    assert_eq!(members("Bx", &files), None);
}
