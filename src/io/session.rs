//! What a front end learns and shares while jobs read files: the files a job read (for
//! depfiles and incremental rebuild keys) and decoded inputs kept for the next job of the
//! same input (a batch decodes each input once). A [`Session`] is a small copyable handle,
//! carried in [`super::Limits`] to every reader; the default one records and keeps nothing.

use super::{Decoded, Meta};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, OnceLock};

/// A handle to a record of reads and a cache of decoded files, open while its [`SessionGuard`]
/// lives. Copies share the record.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Session(u64);

/// Keeps a [`Session`] open; dropping it frees what the session cached.
#[derive(Debug)]
pub struct SessionGuard(Session);

type Cached = Arc<(Decoded, Meta)>;

/// The cache key: the file as named, and how it was decoded.
type Key = (PathBuf, bool, bool);

#[derive(Default)]
struct Record {
    share: bool,
    reads: Vec<PathBuf>,
    decoded: HashMap<Key, Cached>,
}

fn registry() -> &'static Mutex<HashMap<u64, Record>> {
    static REGISTRY: OnceLock<Mutex<HashMap<u64, Record>>> = OnceLock::new();
    REGISTRY.get_or_init(Default::default)
}

fn with<T>(s: Session, f: impl FnOnce(&mut Record) -> T) -> Option<T> {
    if s.0 == 0 {
        return None;
    }
    let mut map = registry().lock().unwrap_or_else(|e| e.into_inner());
    map.get_mut(&s.0).map(f)
}

impl Session {
    /// Opens a session that records every file read through it.
    pub fn open() -> SessionGuard {
        Session::start(false)
    }

    /// Opens a session that records every file read and keeps each decoded file until the
    /// guard is dropped: the jobs of one input decode it once.
    pub fn open_shared() -> SessionGuard {
        Session::start(true)
    }

    fn start(share: bool) -> SessionGuard {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        let id = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        registry().lock().unwrap_or_else(|e| e.into_inner()).insert(
            id,
            Record {
                share,
                ..Record::default()
            },
        );
        SessionGuard(Session(id))
    }

    /// Notes that `path` was read (standard input, `-`, is not a file and is not noted).
    pub(crate) fn note(self, path: &Path) {
        if path == Path::new("-") {
            return;
        }
        with(self, |r| {
            if !r.reads.iter().any(|p| p == path) {
                r.reads.push(path.to_path_buf());
            }
        });
    }

    /// The files read since the last call, in the order first read; the record starts over.
    pub fn take_reads(self) -> Vec<PathBuf> {
        with(self, |r| std::mem::take(&mut r.reads)).unwrap_or_default()
    }

    /// A decoded file kept by this session.
    pub(crate) fn cached(self, path: &Path, linear: bool, as_stored: bool) -> Option<Cached> {
        let key = (path.to_path_buf(), linear, as_stored);
        with(self, |r| r.decoded.get(&key).cloned()).flatten()
    }

    /// Whether this session keeps decoded files.
    pub(crate) fn shares(self) -> bool {
        with(self, |r| r.share).unwrap_or(false)
    }

    /// Keeps a decoded file for the session's later jobs.
    pub(crate) fn keep(self, path: &Path, linear: bool, as_stored: bool, value: Cached) {
        with(self, |r| {
            r.decoded
                .insert((path.to_path_buf(), linear, as_stored), value)
        });
    }
}

impl SessionGuard {
    /// The session, to put in a job's [`super::Limits`].
    pub fn session(&self) -> Session {
        self.0
    }
}

impl Drop for SessionGuard {
    fn drop(&mut self) {
        registry()
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(&self.0 .0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_until_dropped() {
        let guard = Session::open();
        let s = guard.session();
        s.note(Path::new("a.exr"));
        s.note(Path::new("-"));
        s.note(Path::new("a.exr"));
        s.note(Path::new("b.png"));
        assert_eq!(s.take_reads(), [PathBuf::from("a.exr"), "b.png".into()]);
        assert!(s.take_reads().is_empty());
        drop(guard);
        s.note(Path::new("c.exr"));
        assert!(s.take_reads().is_empty());
        Session::default().note(Path::new("d.exr"));
        assert!(Session::default().take_reads().is_empty());
    }

    #[test]
    fn a_shared_session_decodes_a_file_once() {
        let t = tempfile::tempdir().unwrap();
        let path = t.path().join("sky.exr");
        std::fs::copy(
            concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr"),
            &path,
        )
        .unwrap();
        let guard = Session::open_shared();
        let mut opts = crate::io::ReadOptions::default();
        opts.limits.session = guard.session();
        let (first, _) = crate::io::decode_file(&path, &opts).unwrap();
        // Gone from the disk: the second job's read is the kept decode.
        std::fs::remove_file(&path).unwrap();
        let (again, _) = crate::io::decode_file(&path, &opts).unwrap();
        let (Decoded::Image(a), Decoded::Image(b)) = (first, again) else {
            panic!("images")
        };
        assert_eq!(a.pixels, b.pixels);
        assert_eq!(guard.session().take_reads(), std::slice::from_ref(&path));
        drop(guard);
        assert!(crate::io::decode_file(&path, &opts).is_err());
    }
}
