//! One error type whose message always names the file and the problem, so the CLI can print
//! one line, and whose kind a library user can match on (retry an I/O failure, raise a limit,
//! point at a recipe's line).

#![warn(missing_docs)]

use std::path::{Path, PathBuf};

/// Everything that can go wrong; the message names the file and says what to change.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The operating system refused a read or a write.
    #[error("{}: {}", path.display(), io_msg(source))]
    Io {
        /// The file read or written.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// A file whose content is malformed, truncated, or not what its name says.
    #[error("{}: {msg}", path.display())]
    Decode {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// Over a limit on pixels, dimensions or memory (raise it if the input is genuine).
    #[error("{}{msg}", path.as_ref().map(|p| format!("{}: ", p.display())).unwrap_or_default())]
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
    #[error("{}: {msg}", path.display())]
    Unsupported {
        /// The file (or the output name).
        path: PathBuf,
        /// What is not handled.
        msg: String,
    },
    /// A recipe or material file that does not say something valid, at a line when known.
    #[error("{}: {}{msg}", path.display(), line.map(|l| format!("line {l}: ")).unwrap_or_default())]
    Recipe {
        /// The recipe or material file.
        path: PathBuf,
        /// Line of the problem, from 1.
        line: Option<usize>,
        /// What is wrong there.
        msg: String,
    },
    /// A parameter out of range, or parameters that do not fit together.
    #[error("{0}")]
    InvalidOption(String),
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

/// Whether messages name parameters as command-line flags (`--from`) rather than as the
/// library's field names (`` `from` ``): the CLI switches once at start-up, so one message
/// text serves both.
static FLAG_NAMES: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// From now on, messages name parameters as command-line flags (`from` becomes `--from`,
/// `lod_bias` becomes `--lod-bias`). For command-line front ends.
pub fn name_parameters_as_flags() {
    FLAG_NAMES.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// A parameter as messages name it: `` `from` `` in the library, `--from` in the CLI.
pub(crate) fn param(name: &str) -> String {
    if FLAG_NAMES.load(std::sync::atomic::Ordering::Relaxed) {
        format!("--{}", name.replace('_', "-"))
    } else {
        format!("`{name}`")
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
        // The CLI's flag wording (--lod-bias) is tested through the binary.
        assert_eq!(param("lod_bias"), "`lod_bias`");
        let e = crate::layout::detect(64, 64).unwrap_err();
        assert!(e.contains("`from` sphere") && !e.contains("--"), "{e}");
    }
}
