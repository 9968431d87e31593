//! Layers that only point down (issue 27): every library module's `crate::` paths, read from
//! the source with comments left out, may name only modules of its own rank or below, and
//! the modules form no import cycle. What is still wrong is listed below, each entry with
//! what it waits for; an entry that no longer holds fails the test, so the lists only shrink.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Each top-level module's rank, lowest first: image -> cube and layout -> filter and flux ->
/// io (codecs) -> convert -> output -> chain -> input, ibl, info -> preview -> jobs (the commands) -> batch.
const RANKS: &[(&str, u32)] = &[
    ("alloc", 0),
    ("simd", 0),
    ("error", 0),
    ("progress", 0),
    ("image", 1),
    ("synthetic", 2),
    ("tonemap", 2),
    ("cube", 2),
    ("layout", 3),
    ("filter", 3),
    ("flux", 3),
    ("resample", 4),
    ("io", 4),
    ("lut", 5),
    ("control", 5),
    ("convert", 5),
    ("output", 6),
    ("chain", 7),
    ("input", 8),
    ("ibl", 8),
    ("info", 8),
    ("preview", 9),
    ("view", 9),
    ("jobs", 10),
    ("batch", 11),
];

/// Imports upward, still to be moved (issue 27): none left. An entry names the importing
/// module, the module above it and what waits to move.
const KNOWN_UPWARD: &[(&str, &str, &str)] = &[];

/// Cycles still to be broken (issue 27), each as its sorted set of modules: none left. An
/// entry is a sorted list, e.g. `&["flux", "layout"]`.
const KNOWN_CYCLES: &[&[&str]] = &[];

/// The source without comments (`//` to the line's end; no string in it holds `//` before a
/// `crate::` path that matters).
fn code(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The modules `text` names through `crate::` (paths and `crate::{a, b}` groups).
fn named(text: &str, known: &BTreeMap<&str, u32>) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let mut rest = text;
    while let Some(i) = rest.find("crate::") {
        rest = &rest[i + "crate::".len()..];
        let names: Vec<&str> = if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            group[..end]
                .split(',')
                .map(|p| p.trim().split("::").next().unwrap_or("").trim())
                .collect()
        } else {
            let end = rest
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                .unwrap_or(rest.len());
            vec![&rest[..end]]
        };
        out.extend(
            names
                .into_iter()
                .filter(|n| known.contains_key(n))
                .map(str::to_owned),
        );
    }
    out
}

/// A library file's text before its `#[cfg(test)]` module: the code the checks read.
pub(crate) fn library_text(path: &Path) -> String {
    let mut text = std::fs::read_to_string(path).unwrap();
    if let Some(i) = text.find("#[cfg(test)]") {
        text.truncate(i);
    }
    text
}

/// Whether the file named `rel` (see [`rel_path`]) is a test module's own file (`tests.rs`,
/// or under a `tests/` folder): test code, as the `#[cfg(test)]` part of a file is.
pub(crate) fn is_test_file(rel: &str) -> bool {
    rel.ends_with("/tests.rs") || rel.contains("/tests/")
}

/// `file`'s path under `src`, `/`-separated: how the checks' lists name a file.
pub(crate) fn rel_path(src: &Path, file: &Path) -> String {
    file.strip_prefix(src)
        .unwrap()
        .to_string_lossy()
        .replace('\\', "/")
}

pub(crate) fn walk(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            walk(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// Module -> the modules it imports, over the library (tests inside files left out).
fn graph() -> BTreeMap<String, BTreeSet<String>> {
    let known: BTreeMap<&str, u32> = RANKS.iter().copied().collect();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&src, &mut files);
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(&src).unwrap();
        let top = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy()
            .trim_end_matches(".rs")
            .to_owned();
        if ["cli", "main", "lib"].contains(&top.as_str()) {
            continue;
        }
        assert!(
            known.contains_key(top.as_str()),
            "{top}: a new module; give it a rank in RANKS"
        );
        let text = library_text(&f);
        let text = text.as_str();
        let mut to = named(&code(text), &known);
        to.remove(&top);
        edges.entry(top).or_default().extend(to);
    }
    edges
}

/// Groups of two or more modules that import each other, each sorted.
fn cycles(edges: &BTreeMap<String, BTreeSet<String>>) -> BTreeSet<Vec<String>> {
    let reach = |from: &str| {
        let mut seen = BTreeSet::new();
        let mut todo = vec![from.to_owned()];
        while let Some(m) = todo.pop() {
            for n in edges.get(&m).into_iter().flatten() {
                if seen.insert(n.clone()) {
                    todo.push(n.clone());
                }
            }
        }
        seen
    };
    let mut out = BTreeSet::new();
    for m in edges.keys() {
        let from_m = reach(m);
        let mut group: Vec<String> = from_m
            .iter()
            .filter(|n| *n != m && reach(n).contains(m))
            .cloned()
            .collect();
        if !group.is_empty() {
            group.push(m.clone());
            group.sort();
            out.insert(group);
        }
    }
    out
}

#[test]
fn library_modules_only_import_downward() {
    let ranks: BTreeMap<&str, u32> = RANKS.iter().copied().collect();
    let edges = graph();
    let mut upward = BTreeSet::new();
    for (from, tos) in &edges {
        for to in tos {
            if ranks[to.as_str()] > ranks[from.as_str()] {
                upward.insert((from.clone(), to.clone()));
            }
        }
    }
    for (from, to) in &upward {
        assert!(
            KNOWN_UPWARD.iter().any(|(a, b, _)| a == from && b == to),
            "{from} imports {to}, a layer above it: move what it needs down, or the code up"
        );
    }
    for (a, b, why) in KNOWN_UPWARD {
        assert!(
            upward.contains(&(a.to_string(), b.to_string())),
            "{a} -> {b} ({why}) is gone: take it off KNOWN_UPWARD"
        );
    }
    let found = cycles(&edges);
    let known: BTreeSet<Vec<String>> = KNOWN_CYCLES
        .iter()
        .map(|c| c.iter().map(|s| s.to_string()).collect())
        .collect();
    assert_eq!(
        found, known,
        "import cycles among library modules (KNOWN_CYCLES lists those still to break)"
    );
}

/// The parser itself: paths, groups and comments.
#[test]
fn crate_paths_are_read_as_written() {
    let known: BTreeMap<&str, u32> = RANKS.iter().copied().collect();
    let text = code(
        "use crate::cube::{Faces, X};\nuse crate::{image::Image, io};\n// crate::preview\nlet a = crate::flux::mean(); // crate::chain",
    );
    let got: Vec<String> = named(&text, &known).into_iter().collect();
    assert_eq!(got, ["cube", "flux", "image", "io"]);
}

/// Within each module folder, its files import each other without a cycle either
/// (`filter::bright` and `filter::lobe` did, until the lobes' shapes moved below both).
#[test]
fn submodules_form_no_cycle() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    for top in std::fs::read_dir(&src).unwrap().flatten() {
        let dir = top.path();
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        if !dir.is_dir() || name == "cli" {
            continue;
        }
        let mut files = Vec::new();
        walk(&dir, &mut files);
        // Each file's submodule: the first path component under the folder (mod.rs is the
        // folder itself).
        let sub = |f: &Path| -> String {
            let rel = f.strip_prefix(&dir).unwrap();
            rel.components()
                .next()
                .unwrap()
                .as_os_str()
                .to_string_lossy()
                .trim_end_matches(".rs")
                .to_owned()
        };
        let subs: BTreeSet<String> = files
            .iter()
            .map(|f| sub(f))
            .filter(|s| s != "mod")
            .collect();
        let known: BTreeMap<&str, u32> = subs.iter().map(|s| (s.as_str(), 0)).collect();
        let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for f in &files {
            let from = sub(f);
            if from == "mod" {
                continue;
            }
            let text = library_text(f);
            let text = text.as_str();
            let text = code(text)
                .replace("super::", "crate::")
                .replace(&format!("crate::{name}::"), "crate::");
            let mut to = named(&text, &known);
            to.remove(&from);
            edges.entry(from).or_default().extend(to);
        }
        let found = cycles(&edges);
        assert!(
            found.is_empty(),
            "src/{name}: its files import each other in a cycle: {found:?}"
        );
    }
}

/// What `io` may not import (issue 46): it holds codecs and the file-system edge, and the
/// pixel work of these modules (SH for a .env, an edge fixup undone, RGBM/RGBD decoded,
/// UltraHDR's light measured, OpenEXR's layouts resampled) sits above it.
const NOT_IN_IO: &[&str] = &["filter", "flux", "layout", "tonemap"];

/// Files of `io` that still import one of [`NOT_IN_IO`], each with what it waits for; an
/// entry that no longer holds fails the test, so the list only shrinks.
const KNOWN_IN_IO: &[(&str, &str, &str)] = &[];

#[test]
fn io_is_codecs_and_the_file_edge() {
    let known: BTreeMap<&str, u32> = RANKS.iter().copied().collect();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    walk(&src.join("io"), &mut files);
    let mut found = BTreeSet::new();
    for f in files {
        let rel = rel_path(&src, &f);
        if is_test_file(&rel) {
            continue;
        }
        let text = library_text(&f);
        let text = text.as_str();
        for m in named(&code(text), &known) {
            if NOT_IN_IO.contains(&m.as_str()) {
                found.insert((rel.clone(), m));
            }
        }
    }
    for (file, m) in &found {
        assert!(
            KNOWN_IN_IO.iter().any(|(f, k, _)| f == file && k == m),
            "src/{file} imports {m}: io filters no pixel; move that work up to the layer that owns it"
        );
    }
    for (file, m, why) in KNOWN_IN_IO {
        assert!(
            found.contains(&(file.to_string(), m.to_string())),
            "src/{file} -> {m} ({why}) is gone: take it off KNOWN_IN_IO"
        );
    }
}
