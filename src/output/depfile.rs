//! Make-style depfiles (`target: dep dep ...`), as Make, Ninja (`deps = gcc`) and asset
//! cookers read them: the output a command was asked for, and every file it read. Every
//! command's `--depfile` and each job of a batch write them, so they sit beside `deliver`.

use crate::error::{Error, Result};
use crate::io::atomic::{Place, Places};
use crate::output::{self, Destination, Files};
use std::path::{Path, PathBuf};

/// `path` as a depfile names it, as GNU Make (4.3) and Ninja's depfile reader (1.10, 1.11:
/// `deps = gcc`) both read it back: the target (`target`) or a file it read. Space, `#` and
/// `:` take a backslash, `$` is doubled. What one of them cannot read back as the same name
/// is refused, naming the file: a depfile that lies leaves a rule rebuilt for ever, or
/// never, or stops Make. Ninja ends a name at any character outside its plain set (`;`,
/// `|`, `&`, quotes, backtick, `*`, `?`, `<`, `>`, `^`, tab, control characters) and has no
/// escape for them; Make reads `=` as a variable, `%` in a target as a pattern, `[...]` as a
/// wildcard, a leading `~` as a home folder, `NAME(MEMBER)` as an archive's member.
pub fn escape(path: &Path, target: bool) -> Result<String> {
    let refuse = |why: String| {
        Err(Error::file(
            path,
            format!("a depfile cannot name this file ({why}): rename it"),
        ))
    };
    let Some(s) = path.to_str() else {
        return refuse("the name is not UTF-8".into());
    };
    if s.is_empty() {
        return refuse("the name is empty".into());
    }
    if s.starts_with('~') {
        return refuse("Make reads a leading `~` as a home folder".into());
    }
    if s.ends_with(' ') {
        return refuse("Make drops a space at the end".into());
    }
    if s.ends_with(':') {
        return refuse("Ninja keeps the backslash of `\\:` at the end of a name".into());
    }
    // A word that ends in `)` closes an archive's member list (`lib.a(x.o y.o)`) that any
    // earlier name holding a `(` would open.
    if s.ends_with(')') {
        return refuse("Make reads a name ending in `)` as a member of an archive".into());
    }
    if s.find('[').is_some_and(|i| s[i..].contains(']')) {
        return refuse("Make reads `[...]` as a wildcard".into());
    }
    if target && s.contains('%') {
        return refuse("Make reads `%` in a target as a pattern".into());
    }
    let special = s
        .strip_prefix('.')
        .is_some_and(|r| !r.is_empty() && r.bytes().all(|b| b.is_ascii_uppercase() || b == b'_'));
    if target && special {
        return refuse(format!("Make reads `{s}` as a special target"));
    }
    let mut out = String::with_capacity(s.len() + 8);
    for c in s.chars() {
        match c {
            ' ' | '#' | ':' => {
                out.push('\\');
                out.push(c);
            }
            '$' => out.push_str("$$"),
            // Ninja's plain characters, less `=` (a Make variable); `%` and `~` checked above.
            c if c.is_ascii_alphanumeric() || "+,/_.~(){}%@[]!-".contains(c) => out.push(c),
            c if !c.is_ascii() && !c.is_control() => out.push(c),
            '=' => return refuse("Make reads `=` as a variable's value".into()),
            '\\' => return refuse("Make and Ninja read `\\` as an escape".into()),
            c if c.is_control() => {
                let shown = crate::error::escape_text(&c.to_string()).into_owned();
                return refuse(format!("it holds the control character {shown}"));
            }
            '`' => return refuse("Ninja ends a name at a backtick".into()),
            c => return refuse(format!("Ninja ends a name at `{c}`")),
        }
    }
    Ok(out)
}

/// The depfile's text: `target` depends on each of `reads`, one per line; an error names a
/// file whose name the depfile cannot hold ([`escape`]).
pub fn text(target: &Path, reads: &[PathBuf]) -> Result<String> {
    let mut s = format!("{}:", escape(target, true)?);
    for r in reads {
        s.push_str(" \\\n  ");
        s.push_str(&escape(r, false)?);
    }
    s.push('\n');
    Ok(s)
}

/// Refuses, before the command runs, a depfile `path` that would land on its output
/// `target` or inside it (a folder output: faces, a chain, an engine's files), or where no
/// regular file can be (a FIFO, a device). Spellings are compared as places.
pub fn check(path: &Path, target: &Path) -> Result<()> {
    crate::io::atomic::check_regular(path)?;
    let (at, out) = (Place::of(path), Place::of(target));
    let mut places = Places::default();
    places.insert(&out, ());
    if places.get(&at).is_some() {
        return Err(Error::file(
            path,
            "is the command's output: the depfile would overwrite it; name another file",
        ));
    }
    if places.above(&at).is_some() {
        return Err(Error::file(
            path,
            format!(
                "is inside the output folder {}: the depfile would overwrite or join what the \
                 command writes there; name a file outside it",
                target.display()
            ),
        ));
    }
    Ok(())
}

/// Writes the depfile `path` for `target` (atomically), never over one of `reads` nor over a
/// file the command wrote (`written`: the output, a face, an `--sh` file).
pub fn write(path: &Path, target: &Path, reads: &[PathBuf], written: &[PathBuf]) -> Result<()> {
    let at = Place::of(path);
    let mut outs = Places::default();
    for w in written {
        outs.insert(&Place::of(w), ());
    }
    if outs.get(&at).is_some() {
        return Err(Error::file(
            path,
            "is a file the command wrote: the depfile would overwrite it; name another file",
        ));
    }
    let files = Files::new(vec![(
        path.to_path_buf(),
        text(target, reads)?.into_bytes(),
    )]);
    output::deliver(&files, &Destination::Path(path.to_path_buf()), reads)
}

/// The depfile a batch writes beside an output: `OUTPUT.d`.
pub fn beside(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".d");
    PathBuf::from(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_as_make_reads() {
        let t = text(
            Path::new("out dir/sky.ktx2"),
            &["a b.exr".into(), "c#1$.png".into(), "sky 12:30.exr".into()],
        )
        .unwrap();
        assert_eq!(
            t,
            "out\\ dir/sky.ktx2: \\\n  a\\ b.exr \\\n  c\\#1$$.png \\\n  sky\\ 12\\:30.exr\n"
        );
        assert_eq!(text(Path::new("lut.png"), &[]).unwrap(), "lut.png:\n");
        // Plain for both readers.
        for ok in [
            "100%.exr",
            "(1).exr",
            "a[b.exr",
            "{dir}.exr",
            "-o.exr",
            "é.exr",
        ] {
            assert_eq!(escape(Path::new(ok), false).unwrap(), ok);
        }
    }

    #[test]
    fn refuses_what_make_or_ninja_cannot_read_back() {
        let bad = [
            "a;b", "a|b", "a`b", "a'b", "a\"b", "a&b", "a*b", "a?b", "a<b", "a>b", "a^b", "a=b",
            "a\tb", "a\nb", "a\rb", "a\x1bb", "a\\b", "ab\\", "~x", "a ", "a:", "x(1)", "d/(x)",
            "a[1]b",
        ];
        for b in bad {
            let e = escape(Path::new(b), false).unwrap_err().to_string();
            assert!(
                e.contains("a depfile cannot name this file ("),
                "{b:?}: {e}"
            );
        }
        // A target: no pattern, no special target.
        assert!(escape(Path::new("100%.ktx2"), true).is_err());
        assert!(escape(Path::new(".PHONY"), true).is_err());
        assert!(escape(Path::new(".PHONY"), false).is_ok());
        assert!(text(Path::new("out.ktx2"), &["a;b.exr".into()]).is_err());
    }
}
