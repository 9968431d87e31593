//! A manifest's input patterns: a path without wildcards as it is, a glob as its matches in
//! name order. `**` enters real folders only, as bash's globstar does: a symlinked folder is
//! not followed (through the `glob` crate, which follows them, a link to its own folder made
//! 41 jobs of one file and two links made planning endless). A pattern's other components
//! may name a link (`hdri/*.exr` where `hdri` is one): they go one level each.

use std::collections::HashSet;
use std::path::{Component, Path, PathBuf};

/// Whether `pattern` has wildcards (else it names one path, which need not exist yet).
pub fn is_glob(pattern: &str) -> bool {
    pattern.contains(['*', '?', '['])
}

/// The paths `pattern` names: itself when it is no glob (a missing file fails its job), else
/// its matches, sorted, each once.
pub fn expand(pattern: &str) -> Result<Vec<PathBuf>, String> {
    if !is_glob(pattern) {
        return Ok(vec![PathBuf::from(pattern)]);
    }
    // The glob crate's own check, and its words for a bad pattern.
    glob::Pattern::new(pattern).map_err(|e| e.to_string())?;
    let options = glob::MatchOptions::new();
    let parts: Vec<Component> = Path::new(pattern).components().collect();
    let mut paths = vec![PathBuf::new()];
    for (k, part) in parts.iter().enumerate() {
        let last = k + 1 == parts.len();
        let mut next = Vec::new();
        match part {
            Component::Normal(s) if s.to_str() == Some("**") => {
                for p in &paths {
                    folders(p, &mut next, &mut HashSet::new());
                }
            }
            Component::Normal(s) if is_glob(&s.to_string_lossy()) => {
                let one = glob::Pattern::new(&s.to_string_lossy()).map_err(|e| e.to_string())?;
                for p in &paths {
                    let Ok(entries) = std::fs::read_dir(dir(p)) else {
                        continue;
                    };
                    for e in entries.flatten() {
                        let name = e.file_name();
                        if one.matches_with(&name.to_string_lossy(), options) {
                            let q = p.join(&name);
                            if last || q.is_dir() {
                                next.push(q);
                            }
                        }
                    }
                }
            }
            _ => {
                for p in &paths {
                    let q = p.join(part.as_os_str());
                    if last || q.is_dir() {
                        next.push(q);
                    }
                }
            }
        }
        paths = next;
    }
    paths.retain(|p| p.symlink_metadata().is_ok());
    paths.sort();
    paths.dedup();
    Ok(paths)
}

/// The folder to list for `p` (the empty path is the current folder).
fn dir(p: &Path) -> &Path {
    if p.as_os_str().is_empty() {
        Path::new(".")
    } else {
        p
    }
}

/// `p` and every real folder under it, links to folders not followed; a folder met twice
/// (a bind mount of its own parent) is not entered again.
fn folders(p: &Path, out: &mut Vec<PathBuf>, seen: &mut HashSet<(u64, u64)>) {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match std::fs::metadata(dir(p)) {
            Ok(m) if seen.insert((m.dev(), m.ino())) => {}
            _ => return,
        }
    }
    #[cfg(not(unix))]
    let _ = seen;
    out.push(p.to_path_buf());
    let Ok(entries) = std::fs::read_dir(dir(p)) else {
        return;
    };
    let mut subs: Vec<PathBuf> = entries
        .flatten()
        .filter(|e| e.file_type().is_ok_and(|t| t.is_dir()))
        .map(|e| p.join(e.file_name()))
        .collect();
    subs.sort();
    for s in subs {
        folders(&s, out, seen);
    }
}
