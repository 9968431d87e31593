//! Output templates: `{stem}`, `{name}` and `{dir}` of an input filled in one pass (a name
//! that holds `{dir}` is never filled again), and no output that a file's name steers out of
//! the template's folder (`...exr` has the stem `..`: `build/{stem}/bevy` was `bevy`).

use std::path::{Component, Path, PathBuf};

enum Part {
    Text(String),
    Stem,
    Name,
    Dir,
}

/// An output template, read once per `[[job]]` table.
pub struct Template {
    parts: Vec<Part>,
}

/// Why a template gave no output for an input.
pub enum Unfilled {
    /// The input's name makes no output (its stem is `..`): the input is at fault.
    Input(String),
    /// The template itself leads out of its folder: the manifest is at fault.
    Template(String),
}

impl Template {
    /// The template's parts; an unknown `{...}` (a typo) is refused.
    pub fn parse(t: &str) -> Result<Template, String> {
        let mut parts = Vec::new();
        let mut rest = t;
        while let Some(i) = rest.find('{') {
            if i > 0 {
                parts.push(Part::Text(rest[..i].to_owned()));
            }
            let at = &rest[i..];
            let (part, len) = if at.starts_with("{stem}") {
                (Part::Stem, 6)
            } else if at.starts_with("{name}") {
                (Part::Name, 6)
            } else if at.starts_with("{dir}") {
                (Part::Dir, 5)
            } else {
                let end = at.find('}').map_or(at.len(), |j| j + 1);
                return Err(format!(
                    "output {t:?}: unknown placeholder {}: use {{stem}}, {{name}} or {{dir}}",
                    &at[..end]
                ));
            };
            parts.push(part);
            rest = &at[len..];
        }
        if !rest.is_empty() {
            parts.push(Part::Text(rest.to_owned()));
        }
        Ok(Template { parts })
    }

    /// Whether it names a part of an input (a job without one has nothing to fill it with).
    pub fn has_placeholders(&self) -> bool {
        self.parts.iter().any(|p| !matches!(p, Part::Text(_)))
    }

    /// The output for `input`, each placeholder filled once, left to right.
    pub fn fill(&self, input: &Path) -> Result<String, Unfilled> {
        let lossy = |s: Option<&std::ffi::OsStr>| s.map(|s| s.to_string_lossy().into_owned());
        let part = |what: &str, s: Option<String>| match s {
            Some(s) if !s.is_empty() && s != "." && s != ".." => Ok(s),
            Some(s) => Err(Unfilled::Input(format!(
                "its {what} is {s:?}, which names no output of its own"
            ))),
            None => Err(Unfilled::Input(format!("it has no {what}"))),
        };
        let dir = input
            .parent()
            .map(|d| d.display().to_string())
            .filter(|d| !d.is_empty())
            .unwrap_or_else(|| ".".into());
        let mut out = String::new();
        // The output's text before its first {stem} or {name}, up to its last `/`.
        let mut folder: Option<String> = None;
        for p in &self.parts {
            let name = match p {
                Part::Text(t) => {
                    out.push_str(t);
                    continue;
                }
                Part::Dir => {
                    out.push_str(&dir);
                    continue;
                }
                Part::Stem => part("stem", lossy(input.file_stem()))?,
                Part::Name => part("name", lossy(input.file_name()))?,
            };
            folder.get_or_insert_with(|| out[..out.rfind('/').map_or(0, |i| i + 1)].to_owned());
            out.push_str(&name);
        }
        if let Some(folder) = folder {
            let (f, o) = (normal(Path::new(&folder)), normal(Path::new(&out)));
            let inside = o
                .strip_prefix(&f)
                .ok()
                .and_then(|rest| rest.components().next())
                .is_some_and(|c| c != Component::ParentDir);
            if !inside {
                let f = if folder.is_empty() { "." } else { &folder };
                return Err(Unfilled::Template(format!(
                    "output {out:?} (for {}) is not inside the template's folder {f:?}",
                    input.display()
                )));
            }
        }
        Ok(out)
    }
}

/// `p` with `.` left out and `..` taking back the component before it, by the text alone.
fn normal(p: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.components().next_back() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                Some(Component::RootDir | Component::Prefix(_)) => {}
                _ => out.push(".."),
            },
            c => out.push(c),
        }
    }
    out
}
