//! A cache many machines share, in Bazel's HTTP remote-cache layout: a job's outputs are a
//! pure function of cubeforge's build, its command line and the bytes it reads, so a result
//! one machine computed is fetched, not computed again, by every other.
//!
//! Two action-cache entries per job, as ccache's direct mode keeps them: `ac/` of the build
//! and the job's id alone lists the files the job read (paths relative to the manifest), and
//! `ac/` of the build, the id and the SHA-256 of each of those files holds the outputs'
//! manifest (paths and SHA-256); each output's bytes are under `cas/SHA256`. A list that is
//! stale (another variant's) only misses: the second key covers the bytes of every file it
//! names, and a file that decides which others are read is itself one of them. Blobs are
//! checked against their hash, outputs only land in the job's own output (or a sidecar named
//! after it, `OUTPUT.levels.json`), and every failure of the store is a warning: the job
//! runs here.

use crate::error::{Error, Result};
use crate::output::{self, Destination, Files};
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Where the cache's entries live: `get` and `put` of `ac/KEY` and `cas/SHA256` under one
/// root (an HTTP server in [`super::http`], a folder or a map in tests).
pub trait Store: Send + Sync {
    /// The bytes under `path`; `Ok(None)` when there are none (a miss, not a failure).
    fn get(&self, path: &str) -> std::result::Result<Option<Vec<u8>>, String>;
    /// Stores `bytes` under `path`.
    fn put(&self, path: &str, bytes: &[u8]) -> std::result::Result<(), String>;
    /// The store in one short phrase for warnings, never with credentials.
    fn name(&self) -> String;
}

/// A batch's use of a [`Store`]: what it may do, and what went wrong (warnings for the
/// report; after the first failure of the store the batch stops asking it).
pub struct Cache {
    store: Box<dyn Store>,
    /// Reads, never writes (a CI job that may not change what others get).
    pub read_only: bool,
    dead: AtomicBool,
    warnings: Mutex<Vec<String>>,
    shas: Mutex<HashMap<PathBuf, Option<String>>>,
}

/// The files a job read, as the first entry keeps them.
#[derive(serde::Serialize, serde::Deserialize)]
struct Reads {
    reads: Vec<PathBuf>,
}

/// A job's outputs, as the second entry keeps them.
#[derive(serde::Serialize, serde::Deserialize)]
struct Manifest {
    /// The job's output is a folder (faces, a chain), replaced whole.
    folder: bool,
    outputs: Vec<Blob>,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct Blob {
    path: PathBuf,
    sha256: String,
    size: u64,
}

/// A job's entry found: the files it reads and its outputs' manifest.
pub(crate) struct Entry {
    pub reads: Vec<PathBuf>,
    manifest: Manifest,
}

/// A job's outputs fetched and checked, ready to write.
pub(crate) struct Hit {
    pub reads: Vec<PathBuf>,
    files: Vec<(PathBuf, Vec<u8>)>,
    folder: bool,
}

impl Cache {
    /// A cache over `store`.
    pub fn new(store: impl Store + 'static, read_only: bool) -> Cache {
        Cache {
            store: Box::new(store),
            read_only,
            dead: AtomicBool::new(false),
            warnings: Mutex::new(Vec::new()),
            shas: Mutex::new(HashMap::new()),
        }
    }

    /// The warnings so far, taken.
    pub(crate) fn take_warnings(&self) -> Vec<String> {
        std::mem::take(&mut self.warnings.lock().unwrap_or_else(|e| e.into_inner()))
    }

    pub(crate) fn warn(&self, text: String) {
        self.warnings
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push(text);
    }

    /// The store failed: one warning, and no more asking it.
    fn failed(&self, what: &str, e: String) {
        if !self.dead.swap(true, Ordering::Relaxed) {
            self.warn(format!(
                "cache {}: {what}: {e}; jobs run here, and the cache is not asked again",
                self.store.name()
            ));
        }
    }

    fn get(&self, path: &str) -> Option<Vec<u8>> {
        if self.dead.load(Ordering::Relaxed) {
            return None;
        }
        self.store.get(path).unwrap_or_else(|e| {
            self.failed("cannot read", e);
            None
        })
    }

    /// The SHA-256 of `path`'s bytes, each file hashed once per batch (None: unreadable).
    fn sha(&self, path: &Path) -> Option<String> {
        if let Some(h) = self
            .shas
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .get(path)
        {
            return h.clone();
        }
        let h = sha_file(path);
        self.shas
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(path.to_path_buf(), h.clone());
        h
    }

    /// The entry of job `id` writing `output`, if the cache has one for the bytes its files
    /// hold now (a manifest that names anything outside `output` is refused).
    pub(crate) fn lookup(&self, id: &str, output: &Path) -> Option<Entry> {
        let reads: Reads = serde_json::from_slice(&self.get(&reads_key(id))?).ok()?;
        let shas: Vec<String> = reads
            .reads
            .iter()
            .map(|p| self.sha(p))
            .collect::<Option<_>>()?;
        let bytes = self.get(&outputs_key(id, &reads.reads, &shas))?;
        let manifest = match serde_json::from_slice::<Manifest>(&bytes) {
            Ok(m) if m.outputs.iter().all(|b| inside(&b.path, output)) => m,
            _ => {
                self.warn(format!(
                    "cache {}: the entry of `{id}` is not a manifest of files inside {}; \
                     refused, the job runs here",
                    self.store.name(),
                    output.display()
                ));
                return None;
            }
        };
        Some(Entry {
            reads: reads.reads,
            manifest,
        })
    }

    /// The outputs of job `id`, fetched and each checked against its hash (a blob that does
    /// not match is refused with a warning: the job runs here).
    pub(crate) fn fetch(&self, id: &str, output: &Path) -> Option<Hit> {
        let entry = self.lookup(id, output)?;
        let mut files = Vec::new();
        for b in &entry.manifest.outputs {
            let bytes = self.get(&format!("cas/{}", b.sha256))?;
            if sha_hex(&bytes) != b.sha256 || bytes.len() as u64 != b.size {
                self.warn(format!(
                    "cache {}: the blob of {} (`{id}`) does not match its hash {}; refused, \
                     the job runs here",
                    self.store.name(),
                    b.path.display(),
                    b.sha256
                ));
                return None;
            }
            files.push((b.path.clone(), bytes));
        }
        Some(Hit {
            reads: entry.reads,
            files,
            folder: entry.manifest.folder,
        })
    }

    /// Uploads the outputs of job `id`, which read `reads` and wrote `written` inside
    /// `output`: blobs first, then the entries that name them. A failure is a warning.
    pub(crate) fn upload(&self, id: &str, output: &Path, reads: &[PathBuf], written: &[PathBuf]) {
        if self.read_only || self.dead.load(Ordering::Relaxed) {
            return;
        }
        // A job that wrote beside its output (or nothing) is not kept: a hit could not write it.
        if written.is_empty() || !written.iter().all(|p| inside(p, output)) {
            return;
        }
        let Some(shas) = reads
            .iter()
            .map(|p| self.sha(p))
            .collect::<Option<Vec<_>>>()
        else {
            return;
        };
        let mut blobs = Vec::new();
        for p in written {
            let Ok(bytes) = std::fs::read(p) else { return };
            let sha = sha_hex(&bytes);
            if let Err(e) = self.store.put(&format!("cas/{sha}"), &bytes) {
                return self.put_failed(id, e);
            }
            blobs.push(Blob {
                path: p.clone(),
                sha256: sha,
                size: bytes.len() as u64,
            });
        }
        let manifest = Manifest {
            folder: output.is_dir(),
            outputs: blobs,
        };
        let list = Reads {
            reads: reads.to_vec(),
        };
        let entries = [
            (outputs_key(id, reads, &shas), serde_json::to_vec(&manifest)),
            (reads_key(id), serde_json::to_vec(&list)),
        ];
        for (key, bytes) in entries {
            let put = bytes
                .map_err(|e| e.to_string())
                .and_then(|b| self.store.put(&key, &b));
            if let Err(e) = put {
                return self.put_failed(id, e);
            }
        }
    }

    fn put_failed(&self, id: &str, e: String) {
        self.warn(format!(
            "cache {}: the upload of `{id}` failed: {e}; the build goes on",
            self.store.name()
        ));
    }
}

impl Hit {
    /// Writes the fetched outputs through the one output path (atomic; `reads` never
    /// overwritten; a folder output replaced whole); returns the files written.
    pub(crate) fn deliver(self, output: &Path) -> Result<Vec<PathBuf>> {
        let written: Vec<PathBuf> = self.files.iter().map(|(p, _)| p.clone()).collect();
        let files = Files {
            files: self.files,
            folders: if self.folder {
                vec![output.to_path_buf()]
            } else {
                Vec::new()
            },
            known: Vec::new(),
        };
        if files.files.is_empty() {
            return Err(Error::usage("the cache's entry names no output"));
        }
        output::deliver(
            &files,
            &Destination::Path(output.to_path_buf()),
            &self.reads,
        )?;
        Ok(written)
    }
}

/// Whether `path` is `output`, inside it, or a sidecar named after it (`OUTPUT.levels.json`),
/// by names alone (no `..`, nothing absolute beyond `output`'s own root).
fn inside(path: &Path, output: &Path) -> bool {
    if let Ok(rest) = path.strip_prefix(output) {
        return rest.components().all(|c| matches!(c, Component::Normal(_)));
    }
    let sidecar = |p: &Path| {
        let name = p.file_name()?.to_str()?;
        let stem = output.file_name()?.to_str()?;
        let rest = name.strip_prefix(stem)?.strip_prefix('.')?;
        Some(!rest.is_empty() && p.parent() == output.parent())
    };
    let plain = path
        .components()
        .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
        || path.parent() == output.parent();
    plain && sidecar(path).unwrap_or(false)
}

/// The build, as far as outputs go: cubeforge's version and a hash of the program's bytes
/// (the same build on every machine gives the same key; a rebuilt one, another).
fn build() -> &'static str {
    static BUILD: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    BUILD.get_or_init(|| {
        let exe = std::env::current_exe()
            .and_then(std::fs::read)
            .map(|b| format!("{:032x}", xxhash_rust::xxh3::xxh3_128(&b)))
            .unwrap_or_default();
        format!("{} {exe}", env!("CARGO_PKG_VERSION"))
    })
}

/// SHA-256 of length-prefixed parts, in hex.
fn key_of<'a>(parts: impl IntoIterator<Item = &'a [u8]>) -> String {
    let mut h = Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    hex(&h.finalize())
}

/// The key of the list of files job `id` reads.
fn reads_key(id: &str) -> String {
    let key = key_of([
        b"cubeforge reads 1".as_slice(),
        build().as_bytes(),
        id.as_bytes(),
    ]);
    format!("ac/{key}")
}

/// The action key of job `id` reading `reads` with bytes of hashes `shas`.
fn outputs_key(id: &str, reads: &[PathBuf], shas: &[String]) -> String {
    let names: Vec<String> = reads
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let mut parts: Vec<&[u8]> = vec![
        b"cubeforge outputs 1".as_slice(),
        build().as_bytes(),
        id.as_bytes(),
    ];
    for (n, s) in names.iter().zip(shas) {
        parts.push(n.as_bytes());
        parts.push(s.as_bytes());
    }
    format!("ac/{}", key_of(parts))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn sha_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// SHA-256 of a regular file's bytes (None: not one, or unreadable).
fn sha_file(path: &Path) -> Option<String> {
    let mut h = Sha256::new();
    super::state::stream_file(path, |b| h.update(b))?;
    Some(hex(&h.finalize()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A store in memory, counting its writes.
    #[derive(Default)]
    struct Memory(
        Mutex<HashMap<String, Vec<u8>>>,
        std::sync::atomic::AtomicUsize,
    );

    impl Store for std::sync::Arc<Memory> {
        fn get(&self, path: &str) -> std::result::Result<Option<Vec<u8>>, String> {
            Ok(self.0.lock().unwrap().get(path).cloned())
        }
        fn put(&self, path: &str, bytes: &[u8]) -> std::result::Result<(), String> {
            self.1.fetch_add(1, Ordering::Relaxed);
            self.0.lock().unwrap().insert(path.into(), bytes.to_vec());
            Ok(())
        }
        fn name(&self) -> String {
            "memory".into()
        }
    }

    /// A hit needs the bytes of every file the job read; a changed file is a miss, and a
    /// read-only cache never writes.
    #[test]
    fn a_hit_needs_the_same_bytes() {
        let t = tempfile::tempdir().unwrap();
        let (input, out) = (t.path().join("in.txt"), t.path().join("out.png"));
        std::fs::write(&input, b"one").unwrap();
        std::fs::write(&out, b"result").unwrap();
        let mem = std::sync::Arc::new(Memory::default());
        let (reads, written) = (vec![input.clone()], vec![out.clone()]);
        Cache::new(mem.clone(), true).upload("job", &out, &reads, &written);
        assert_eq!(mem.1.load(Ordering::Relaxed), 0);
        Cache::new(mem.clone(), false).upload("job", &out, &reads, &written);
        assert_eq!(mem.1.load(Ordering::Relaxed), 3);
        let hit = Cache::new(mem.clone(), false)
            .fetch("job", &out)
            .expect("a hit");
        assert_eq!(hit.files, vec![(out.clone(), b"result".to_vec())]);
        assert!(Cache::new(mem.clone(), false)
            .fetch("other job", &out)
            .is_none());
        std::fs::write(&input, b"two").unwrap();
        assert!(Cache::new(mem.clone(), false).fetch("job", &out).is_none());
    }

    /// A manifest's paths must stay inside the job's output.
    #[test]
    fn only_inside_the_output() {
        let out = Path::new("out/sky");
        assert!(inside(Path::new("out/sky"), out));
        assert!(inside(Path::new("out/sky/px.png"), out));
        assert!(!inside(Path::new("out/sky/../../etc/x"), out));
        assert!(!inside(Path::new("out/skyline.png"), out));
        assert!(!inside(Path::new("/etc/passwd"), out));
        assert!(inside(Path::new("out/sky.levels.json"), out));
        assert!(!inside(Path::new("out/sky."), out));
        assert!(!inside(Path::new("out/sky.x/../../y"), out));
    }
}
