//! What a path names, so that outputs are checked as places, not as spellings: `out/x.ktx2`,
//! `out/./x.ktx2`, `out/../out/x.ktx2`, a symlinked folder's spelling and a hard link are one
//! file. The output module's one check ([`crate::output::check_outputs`]) and the batch's
//! conflicts use these.

use crate::error::{Error, Result};
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};

/// A path's place: absolute, its longest existing part resolved (symbolic links and `..`
/// as the system follows them), the rest normalised lexically; and the (device, inode) of
/// the file it names, when that exists.
#[derive(Clone, Debug)]
pub(crate) struct Place {
    /// The resolved path.
    pub path: PathBuf,
    /// Device and inode, when the file exists (links followed).
    pub node: Option<(u64, u64)>,
}

impl Place {
    /// The place `path` names now.
    pub fn of(path: &Path) -> Place {
        Resolver::default().place(path)
    }
}

/// Resolves paths, keeping the folders it resolved: the many outputs of a batch share a few
/// folders, each resolved once.
#[derive(Default)]
pub(crate) struct Resolver {
    dirs: HashMap<PathBuf, PathBuf>,
}

impl Resolver {
    /// The place `path` names now.
    pub fn place(&mut self, path: &Path) -> Place {
        Place {
            path: self.resolve(path),
            node: node(path),
        }
    }

    /// `path` made absolute, resolved by the system where it exists; where it does not,
    /// its folder resolved and its last part added as written (`..` taking one off).
    fn resolve(&mut self, path: &Path) -> PathBuf {
        let abs = if path.is_absolute() {
            path.to_path_buf()
        } else {
            std::env::current_dir().unwrap_or_default().join(path)
        };
        if let Ok(real) = std::fs::canonicalize(&abs) {
            return real;
        }
        let (Some(up), Some(last)) = (abs.parent(), abs.components().next_back()) else {
            return abs;
        };
        let mut base = match self.dirs.get(up) {
            Some(b) => b.clone(),
            None => {
                let b = self.resolve(up);
                self.dirs.insert(up.to_path_buf(), b.clone());
                b
            }
        };
        match last {
            Component::CurDir => {}
            Component::ParentDir => {
                base.pop();
            }
            c => base.push(c),
        }
        base
    }
}

/// The (device, inode) of what `path` names, links followed (None: nothing there).
fn node(path: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// What a file that is neither a regular file nor a folder is, when `path` names one (links
/// followed): a FIFO, a device or a socket, which a write must never replace.
pub(crate) fn special_kind(path: &Path) -> Option<&'static str> {
    let t = std::fs::metadata(path).ok()?.file_type();
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO");
        }
        if t.is_char_device() {
            return Some("a character device");
        }
        if t.is_block_device() {
            return Some("a block device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    (!t.is_file() && !t.is_dir()).then_some("not a regular file")
}

/// `path` opened for reading when it is a regular file (links followed): its type is looked
/// at before the open, and again on the open file, which is opened without waiting (a FIFO
/// put there between the two would block an open for reading until a writer came).
pub(crate) fn open_regular(path: &Path) -> std::io::Result<std::fs::File> {
    let not_regular = || std::io::Error::other("not a regular file");
    if !std::fs::metadata(path)?.is_file() {
        return Err(not_regular());
    }
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK);
    }
    let f = o.open(path)?;
    if !f.metadata()?.is_file() {
        return Err(not_regular());
    }
    Ok(f)
}

/// Refuses `path` when it names (through links) a FIFO, a device or a socket: cubeforge
/// writes regular files only, and a rename would put one in place of the node (`/dev/null`
/// replaced, a pipe's reader never fed).
pub(crate) fn check_regular(path: &Path) -> Result<()> {
    match special_kind(path) {
        Some(kind) => Err(Error::file(
            path,
            format!(
                "is {kind}, not a regular file: cubeforge writes regular files only \
                 (-o - writes to standard output)"
            ),
        )),
        None => Ok(()),
    }
}

/// Refuses, before anything is staged, a target that is a FIFO, a device or a socket
/// ([`check_regular`]), and two targets that are one file however spelled (the second
/// rename would silently win).
pub(crate) fn check_targets(paths: &[PathBuf]) -> Result<()> {
    let mut seen = Places::default();
    for p in paths {
        check_regular(p)?;
        if let Some(first) = seen.insert(&Place::of(p), p) {
            return Err(Error::file(
                p,
                format!(
                    "is one file with {}, another output of this command: name the outputs apart",
                    first.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Places and what each is (a job's output, an input...), looked up by path and by node in
/// constant time, and by folder in time of the path's depth: a batch of 10,000 jobs is
/// checked without comparing pairs.
pub(crate) struct Places<T> {
    by_path: HashMap<PathBuf, T>,
    by_node: HashMap<(u64, u64), T>,
}

impl<T> Default for Places<T> {
    fn default() -> Self {
        Places {
            by_path: HashMap::new(),
            by_node: HashMap::new(),
        }
    }
}

impl<T: Clone> Places<T> {
    /// Adds `place` as `what`; the one already there when it is the same place (by path or
    /// by node), which stays.
    pub fn insert(&mut self, place: &Place, what: T) -> Option<T> {
        if let Some(old) = self.get(place) {
            return Some(old.clone());
        }
        self.by_path.insert(place.path.clone(), what.clone());
        if let Some(n) = place.node {
            self.by_node.insert(n, what);
        }
        None
    }

    /// What `place` is, if it is one of these.
    pub fn get(&self, place: &Place) -> Option<&T> {
        self.by_path
            .get(&place.path)
            .or_else(|| place.node.and_then(|n| self.by_node.get(&n)))
    }

    /// The nearest of these that is a folder above `place` (strictly), and what it is.
    pub fn above(&self, place: &Place) -> Option<(&Path, &T)> {
        place
            .path
            .ancestors()
            .skip(1)
            .find_map(|a| self.by_path.get_key_value(a))
            .map(|(k, t)| (k.as_path(), t))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_of_one_file_are_one_place() {
        let t = tempfile::tempdir().unwrap();
        let d = t.path();
        std::fs::create_dir(d.join("out")).unwrap();
        std::fs::write(d.join("out/x"), b"x").unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(d.join("out"), d.join("link")).unwrap();
        let a = Place::of(&d.join("out/x"));
        for other in ["out/./x", "out/../out/x", "link/x", "out/new/../x"] {
            #[cfg(not(unix))]
            if other.starts_with("link") {
                continue;
            }
            let b = Place::of(&d.join(other));
            assert_eq!(a.path, b.path, "{other}");
        }
        // A file not there yet: its folder resolved, its name kept.
        let new = Place::of(&d.join("link/../out/y"));
        assert_eq!(new.path, Place::of(&d.join("out")).path.join("y"));
        assert!(new.node.is_none());
        let mut places = Places::default();
        assert!(places.insert(&Place::of(&d.join("out")), 1).is_none());
        assert_eq!(places.above(&a).map(|(_, &t)| t), Some(1));
        assert_eq!(places.insert(&Place::of(&d.join("out/.")), 2), Some(1));
    }
}
