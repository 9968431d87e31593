//! Sizes a reader can hold in mind (issue 46): no source file over 600 lines, no library
//! function of 100 lines or more. What is still over is listed with what it waits for; an
//! entry that no longer holds fails the test, so the lists only shrink.

use std::path::Path;

/// Library functions of 100 lines or more (file under `src/`, name), still to be split:
/// none left.
const KNOWN_LONG_FUNCTIONS: &[(&str, &str)] = &[];

/// Source files over 600 lines, still to be split: none left.
const KNOWN_LONG_FILES: &[&str] = &[];

fn sources() -> Vec<(String, String)> {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files = Vec::new();
    super::layers::walk(&src, &mut files);
    files.sort();
    files
        .into_iter()
        .map(|f| {
            let rel = super::layers::rel_path(&src, &f);
            (rel, std::fs::read_to_string(&f).unwrap())
        })
        .collect()
}

/// A function's name when `line` starts one (`fn`, with any of `pub`, `const`, `unsafe`
/// before it) and is not a declaration without a body.
fn fn_name(line: &str) -> Option<&str> {
    let mut rest = line.trim_start();
    if line.trim_end().ends_with(';') {
        return None;
    }
    for word in [
        "pub(crate) ",
        "pub(super) ",
        "pub ",
        "const ",
        "async ",
        "unsafe ",
    ] {
        rest = rest.strip_prefix(word).unwrap_or(rest);
    }
    let rest = rest.strip_prefix("fn ")?;
    let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_'))?;
    Some(&rest[..end])
}

/// Each library function's length in lines, from its `fn` line to the `}` at the same
/// indent (the code is rustfmt's), tests left out (`tests.rs` files and what follows
/// `#[cfg(test)]`), the command line too (its `run`s have a limit of their own).
fn function_lengths(rel: &str, text: &str) -> Vec<(String, usize)> {
    if rel.starts_with("cli/") || rel == "main.rs" || rel.ends_with("tests.rs") {
        return Vec::new();
    }
    let lines: Vec<&str> = text.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        if line.trim_start().starts_with("#[cfg(test)]") {
            break;
        }
        let Some(name) = fn_name(line) else { continue };
        let indent = &line[..line.len() - line.trim_start().len()];
        let close = format!("{indent}}}");
        if let Some(j) = lines[i + 1..].iter().position(|l| *l == close) {
            out.push((name.to_owned(), j + 2));
        }
    }
    out
}

#[test]
fn no_library_function_reaches_100_lines() {
    let mut long = Vec::new();
    for (rel, text) in sources() {
        for (name, n) in function_lengths(&rel, &text) {
            if n >= 100 {
                long.push((rel.clone(), name, n));
            }
        }
    }
    for (rel, name, n) in &long {
        assert!(
            KNOWN_LONG_FUNCTIONS.contains(&(rel.as_str(), name.as_str())),
            "src/{rel}: fn {name} is {n} lines: split it under 100"
        );
    }
    for (rel, name) in KNOWN_LONG_FUNCTIONS {
        assert!(
            long.iter().any(|(r, f, _)| r == rel && f == name),
            "src/{rel}: fn {name} is under 100 lines now: take it off KNOWN_LONG_FUNCTIONS"
        );
    }
}

#[test]
fn no_source_file_over_600_lines() {
    let long: Vec<(String, usize)> = sources()
        .into_iter()
        .map(|(rel, text)| (rel, text.lines().count()))
        .filter(|(_, n)| *n > 600)
        .collect();
    for (rel, n) in &long {
        assert!(
            KNOWN_LONG_FILES.contains(&rel.as_str()),
            "src/{rel} has {n} lines: split it at 600"
        );
    }
    for rel in KNOWN_LONG_FILES {
        assert!(
            long.iter().any(|(r, _)| r == rel),
            "src/{rel} is 600 lines or less now: take it off KNOWN_LONG_FILES"
        );
    }
}

/// The scanner itself: a function's length, a declaration, a test module left out.
#[test]
fn functions_are_measured_as_written() {
    let text = "pub(crate) fn a(x: u8) -> u8 {\n    x\n}\nfn b();\nimpl T {\n    pub const fn c() {\n    }\n}\n#[cfg(test)]\nfn d() {\n}\n";
    assert_eq!(
        function_lengths("x.rs", text),
        [("a".to_owned(), 3), ("c".to_owned(), 2)]
    );
    assert!(function_lengths("cli/x.rs", text).is_empty());
}
