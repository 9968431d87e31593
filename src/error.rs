//! One error type whose message always names the file and the problem, so the CLI can print
//! one line, and whose kind a library user can match on (retry an I/O failure, raise a limit,
//! point at a recipe's line).

#![warn(missing_docs)]

use std::path::{Path, PathBuf};

/// Everything that can go wrong; the message names the file and says what to change.
///
/// A message names the caller's parameters by their field names (`` `size` ``) when shown
/// with `Display`; [`Error::with_flags`] names them as command-line flags (`--size`).
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// The operating system refused a read or a write.
    Io {
        /// The file read or written.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// A file whose content is malformed, truncated, or not what its name says.
    Decode {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// Over a limit on pixels, dimensions or memory (raise it if the input is genuine).
    Limit {
        /// The file, when the limit is about one.
        path: Option<PathBuf>,
        /// Which field of [`crate::io::Limits`] refused it, so a caller can say how to raise it.
        kind: LimitKind,
        /// What is over the limit, and by how much.
        msg: String,
    },
    /// A well-formed file or request that cubeforge does not handle (a pixel format, a
    /// layout, a container of another kind).
    Unsupported {
        /// The file (or the output name).
        path: PathBuf,
        /// What is not handled.
        msg: String,
    },
    /// A recipe or material file that does not say something valid, at a line when known.
    Recipe {
        /// The recipe or material file.
        path: PathBuf,
        /// Line of the problem, from 1.
        line: Option<usize>,
        /// What is wrong there.
        msg: String,
    },
    /// A parameter out of range, or parameters that do not fit together.
    InvalidOption(String),
}

/// A path as messages name it: standard output's stand-in name (`-.EXT`, which picks the
/// encoder) as "standard output".
pub fn shown(path: &Path) -> String {
    let name = path.to_string_lossy();
    match name.strip_prefix("-.") {
        Some(ext) if !ext.is_empty() && !ext.contains(['/', '\\']) => {
            format!("standard output ({ext})")
        }
        _ => path.display().to_string(),
    }
}

impl Error {
    /// The message with each parameter marked, before it is named one way or the other.
    fn marked(&self) -> String {
        match self {
            Error::Io { path, source } => format!("{}: {}", shown(path), io_msg(source)),
            Error::Decode { path, msg } | Error::Unsupported { path, msg } => {
                format!("{}: {msg}", shown(path))
            }
            Error::Limit { path, msg, .. } => format!(
                "{}{msg}",
                path.as_ref()
                    .map(|p| format!("{}: ", shown(p)))
                    .unwrap_or_default()
            ),
            Error::Recipe { path, line, msg } => format!(
                "{}: {}{msg}",
                shown(path),
                line.map(|l| format!("line {l}: ")).unwrap_or_default()
            ),
            Error::InvalidOption(msg) => msg.clone(),
        }
    }

    /// The message with parameters named as command-line flags (`--lod-bias`), for a
    /// command-line front end; `Display` names them as fields (`` `lod_bias` ``).
    pub fn with_flags(&self) -> String {
        name_params(&self.marked(), true)
    }
}

impl std::fmt::Display for Error {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&name_params(&self.marked(), false))
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// The field of [`crate::io::Limits`] an [`Error::Limit`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum LimitKind {
    /// `max_pixels` or `max_dimension`: the image is too large.
    Pixels,
    /// `max_memory`: the work needs more memory than the budget.
    Memory,
}

/// Marks around a parameter's name in a message (private-use characters, which no
/// terminal acts on and [`escape_text`] leaves alone), so one text serves the library, which
/// names fields, and a command line, which names flags.
const OPEN: char = '\u{e000}';
const CLOSE: char = '\u{e001}';

/// `word` with its indefinite article, as read aloud: "an equirect", "an hcross" (aitch),
/// "a vcross", "an OpenEXR", "a KTX2".
pub(crate) fn with_article(word: &str) -> String {
    let lower = word.to_ascii_lowercase();
    let an = lower.starts_with(['a', 'e', 'i', 'o', 'u'])
        || lower.starts_with("hc")
        || lower.starts_with("hs");
    format!("{} {word}", if an { "an" } else { "a" })
}

/// A parameter in a message: `` `from` `` where the library shows it, `--from` where a
/// command line does ([`Error::with_flags`], [`name_params`]).
pub(crate) fn param(name: &str) -> String {
    format!("{OPEN}{name}{CLOSE}")
}

/// `text` (a message, a warning, a summary line) with its parameters named as command-line
/// flags (`flags`: `lod_bias` becomes `--lod-bias`) or as the library's fields
/// (`` `lod_bias` ``).
pub fn name_params(text: &str, flags: bool) -> String {
    if !text.contains(OPEN) {
        return text.to_owned();
    }
    let mut out = String::with_capacity(text.len() + 8);
    let mut rest = text;
    while let Some(i) = rest.find(OPEN) {
        out.push_str(&rest[..i]);
        let after = &rest[i + OPEN.len_utf8()..];
        let Some(j) = after.find(CLOSE) else {
            out.push_str(after);
            return out;
        };
        let name = &after[..j];
        if flags {
            out.push_str("--");
            out.push_str(&name.replace('_', "-"));
        } else {
            out.push('`');
            out.push_str(name);
            out.push('`');
        }
        rest = &after[j + CLOSE.len_utf8()..];
    }
    out.push_str(rest);
    out
}

/// A message for people (a warning, a summary line) whose parameters a front end names its
/// own way: `Display` names fields (`` `size` ``), [`Text::with_flags`] flags (`--size`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Text(String);

impl Text {
    /// The text as written, parameters marked by [`param`].
    pub fn new(text: impl Into<String>) -> Text {
        Text(text.into())
    }
    /// The text with parameters named as command-line flags.
    pub fn with_flags(&self) -> String {
        name_params(&self.0, true)
    }
}

impl std::fmt::Display for Text {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&name_params(&self.0, false))
    }
}

/// `text` with every character that would act on a terminal written out instead: control
/// characters (C0, DEL, C1: ESC, BEL, line breaks) as `\n`, `\x1b`, `\u{9b}`, and the
/// bidirectional overrides that reorder what is shown. Messages quote what files hold (a
/// Radiance header line, a KTX key, a JSON error): a hostile file must not drive the
/// terminal that prints them.
pub fn escape_text(text: &str) -> std::borrow::Cow<'_, str> {
    let acts =
        |c: char| c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}');
    if !text.chars().any(acts) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if acts(c) && (c as u32) < 0x100 => out.push_str(&format!("\\x{:02x}", c as u32)),
            c if acts(c) => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
            c => out.push(c),
        }
    }
    std::borrow::Cow::Owned(out)
}

fn escaped(msg: String) -> String {
    match escape_text(&msg) {
        std::borrow::Cow::Borrowed(_) => msg,
        std::borrow::Cow::Owned(s) => s,
    }
}

/// An I/O error as a short phrase ("No such file or directory").
pub fn io_msg(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" (os error") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

/// The result of every fallible call in cubeforge.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// A problem with what a named file holds (or where it would go).
    pub fn file(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Error::Decode {
            path: path.as_ref().to_path_buf(),
            msg: escaped(msg.into()),
        }
    }
    /// A parameter the caller gave that cannot work.
    pub fn usage(msg: impl Into<String>) -> Self {
        Error::InvalidOption(escaped(msg.into()))
    }
    /// The operating system's refusal to read or write `path`.
    pub fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }
    /// Over the limit of `kind`; `msg` says what and by how much (the caller names its own
    /// way to raise it: the CLI adds its flag).
    pub fn limit(path: Option<&Path>, kind: LimitKind, msg: impl Into<String>) -> Self {
        Error::Limit {
            path: path.map(Path::to_path_buf),
            kind,
            msg: escaped(msg.into()),
        }
    }
    /// Something valid in or about `path` that cubeforge does not handle.
    pub fn unsupported(path: impl AsRef<Path>, msg: impl Into<String>) -> Self {
        Error::Unsupported {
            path: path.as_ref().to_path_buf(),
            msg: escaped(msg.into()),
        }
    }
    /// A mistake in a recipe or material file, at `line` (from 1) when known.
    pub fn recipe(path: impl AsRef<Path>, line: Option<usize>, msg: impl Into<String>) -> Self {
        Error::Recipe {
            path: path.as_ref().to_path_buf(),
            line,
            msg: escaped(msg.into()),
        }
    }
    /// The file the error is about, if any.
    pub fn path(&self) -> Option<&Path> {
        match self {
            Error::Io { path, .. }
            | Error::Decode { path, .. }
            | Error::Unsupported { path, .. }
            | Error::Recipe { path, .. } => Some(path),
            Error::Limit { path, .. } => path.as_deref(),
            Error::InvalidOption(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_library_names_parameters_by_their_fields() {
        let e = Error::usage(format!("{} must be >= 0", param("lod_bias")));
        assert_eq!(e.to_string(), "`lod_bias` must be >= 0");
        assert_eq!(e.with_flags(), "--lod-bias must be >= 0");
        let e = crate::layout::detect(64, 64).unwrap_err();
        let e = name_params(&e, false);
        assert!(e.contains("`from` sphere") && !e.contains("--"), "{e}");
    }
}
