//! A cache many machines share, in Bazel's HTTP remote-cache layout: a job's outputs are a
//! pure function of cubeforge's build, its command line and the bytes it reads, so a result
//! one machine computed is fetched, not computed again, by every other.
//!
//! Two action-cache entries per job, as ccache's direct mode keeps them, each a Bazel
//! `ActionResult` ([`super::reapi`]): `ac/` of the build and the job's id alone names one
//! output, `inputs.json`, the list of files the job read (paths relative to the manifest), and
//! `ac/` of the build, the id and the SHA-256 of each of those files names the job's outputs
//! (paths relative to the folder of the job's output, and their SHA-256); every file's bytes
//! are under `cas/SHA256`, uploaded before the entries that name them (a server that checks
//! that an entry's blobs exist takes it) and only when a `HEAD` says the cache lacks them. A
//! list that is stale (another variant's) only misses: the second key covers the bytes of
//! every file it names, and a file that decides which others are read is itself one of them.
//! Blobs are checked against their hash, outputs only land in the job's own output (or a
//! sidecar named after it, `OUTPUT.levels.json`), and every failure of the store, or entry
//! cubeforge cannot use, is a warning: the job runs here.

use super::reapi::{self, Output};
use crate::error::{Error, Result};
use crate::output::{self, Destination, Files};
use sha2::{Digest, Sha256};
use std::collections::{HashMap, HashSet};
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;

/// Where the cache's entries live: `get` and `put` of `ac/KEY` and `cas/SHA256` under one
/// root (an HTTP server in [`super::http`], a folder or a map in tests).
pub trait Store: Send + Sync {
    /// The bytes under `path`; `Ok(None)` when there are none (a miss, not a failure). A body
    /// longer than `most` bytes comes back cut after `most + 1` of them (too long to be what
    /// the caller expects, which it refuses, never held whole: a store may send anything).
    fn get(&self, path: &str, most: u64) -> std::result::Result<Option<Vec<u8>>, String>;
    /// Stores `bytes` under `path`.
    fn put(&self, path: &str, bytes: &[u8]) -> std::result::Result<(), String>;
    /// The store in one short phrase for warnings, never with credentials.
    fn name(&self) -> String;
    /// Whether the store has `path` (HTTP `HEAD`), so a blob it has is not sent again; a
    /// store that cannot tell says no, and every blob is sent.
    fn has(&self, path: &str) -> std::result::Result<bool, String> {
        let _ = path;
        Ok(false)
    }
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
    /// Blobs this batch sent or found in the store (not asked about again).
    blobs: Mutex<HashSet<String>>,
    /// Blobs refused as damaged: sent again even though the store has them.
    damaged: Mutex<HashSet<String>>,
    uploaded: AtomicUsize,
    present: AtomicUsize,
}

/// The name of the one output of a job's first entry: the files it read.
const INPUTS: &str = "inputs.json";

/// The most bytes an `ac/` entry may have: cubeforge's name a few files in a few hundred
/// bytes; a store that sends more is refused before it fills the memory.
const ENTRY_BYTES: u64 = 1 << 20;

/// The files a job read, as its first entry's `inputs.json` keeps them.
#[derive(serde::Serialize, serde::Deserialize)]
struct Reads {
    reads: Vec<PathBuf>,
}

/// One output of a job's entry, where this batch writes it.
struct Blob {
    path: PathBuf,
    digest: Output,
}

/// A job's entry found: the files it reads and its outputs.
pub(crate) struct Entry {
    pub reads: Vec<PathBuf>,
    outputs: Vec<Blob>,
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
            blobs: Mutex::new(HashSet::new()),
            damaged: Mutex::new(HashSet::new()),
            uploaded: AtomicUsize::new(0),
            present: AtomicUsize::new(0),
        }
    }

    /// The blobs uploaded so far, and those not sent because the store had them.
    pub fn blob_counts(&self) -> (usize, usize) {
        (
            self.uploaded.load(Ordering::Relaxed),
            self.present.load(Ordering::Relaxed),
        )
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

    fn get(&self, path: &str, most: u64) -> Option<Vec<u8>> {
        if self.dead.load(Ordering::Relaxed) {
            return None;
        }
        self.store.get(path, most).unwrap_or_else(|e| {
            self.failed("cannot read", e);
            None
        })
    }

    /// A warning that the cache's entry for job `id` cannot be used (the job runs here).
    fn refuse(&self, id: &str, why: impl std::fmt::Display) {
        self.warn(format!(
            "cache {}: the entry of `{id}` is refused: {why}; the job runs here",
            self.store.name()
        ));
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

    /// The outputs named by the `ActionResult` under `key` (None: a miss, or an entry
    /// cubeforge cannot use, with a warning).
    fn entry(&self, key: &str, id: &str) -> Option<Vec<Output>> {
        let bytes = self.get(key, ENTRY_BYTES)?;
        reapi::decode(&bytes)
            .map_err(|e| self.refuse(id, format!("{key} is {e}")))
            .ok()
    }

    /// The bytes of `blob`, checked against its hash and size (a blob that does not match is
    /// refused with a warning).
    fn blob(&self, blob: &Output, id: &str, name: &Path) -> Option<Vec<u8>> {
        // A size beyond what this process may hold is refused before the body is read.
        let most = crate::io::Limits::default().max_memory;
        if blob.size > most {
            self.refuse(
                id,
                format!(
                    "the blob of {} claims {} bytes, more than this process may hold",
                    name.display(),
                    blob.size
                ),
            );
            return None;
        }
        let bytes = self.get(&format!("cas/{}", blob.sha256), blob.size)?;
        if sha_hex(&bytes) != blob.sha256 || bytes.len() as u64 != blob.size {
            self.damaged
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .insert(blob.sha256.clone());
            self.warn(format!(
                "cache {}: the blob of {} (`{id}`) does not match its hash {}; refused, \
                 the job runs here",
                self.store.name(),
                name.display(),
                blob.sha256
            ));
            return None;
        }
        Some(bytes)
    }

    /// The entry of job `id` writing `output`, if the cache has one for the bytes its files
    /// hold now (an entry that names anything outside `output` is refused).
    pub(crate) fn lookup(&self, id: &str, output: &Path) -> Option<Entry> {
        let list = self.entry(&reads_key(id), id)?;
        let [inputs] = list.as_slice() else {
            self.refuse(id, "its list of files read is not one file");
            return None;
        };
        let bytes = self.blob(inputs, id, Path::new(INPUTS))?;
        let reads = match serde_json::from_slice::<Reads>(&bytes) {
            Ok(r) if inputs.path == INPUTS => r.reads,
            _ => {
                self.refuse(id, format!("its list of files read is not {INPUTS}"));
                return None;
            }
        };
        let shas: Vec<String> = reads.iter().map(|p| self.sha(p)).collect::<Option<_>>()?;
        let mut outputs = Vec::new();
        for digest in self.entry(&outputs_key(id, &reads, &shas), id)? {
            let Some(path) = place(&digest.path, output) else {
                let at = output.display();
                self.refuse(id, format!("{:?} is not inside {at}", digest.path));
                return None;
            };
            outputs.push(Blob { path, digest });
        }
        Some(Entry { reads, outputs })
    }

    /// The outputs of job `id`, fetched and each checked against its hash (a blob that does
    /// not match is refused with a warning: the job runs here).
    pub(crate) fn fetch(&self, id: &str, output: &Path) -> Option<Hit> {
        let entry = self.lookup(id, output)?;
        let mut files = Vec::new();
        for b in &entry.outputs {
            let bytes = self.blob(&b.digest, id, &b.path)?;
            files.push((b.path.clone(), bytes));
        }
        Some(Hit {
            reads: entry.reads,
            folder: files
                .iter()
                .any(|(p, _)| p != output && p.starts_with(output)),
            files,
        })
    }

    /// Sends `bytes` to `cas/SHA`, unless this batch already did or the store has it.
    fn put_blob(&self, sha: &str, bytes: &[u8]) -> std::result::Result<(), String> {
        let new = self
            .blobs
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(sha.to_string());
        let path = format!("cas/{sha}");
        let damaged = self
            .damaged
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .contains(sha);
        if !new || (!damaged && self.store.has(&path) == Ok(true)) {
            self.present.fetch_add(1, Ordering::Relaxed);
            return Ok(());
        }
        let sent = self.store.put(&path, bytes);
        match &sent {
            Ok(()) => self.uploaded.fetch_add(1, Ordering::Relaxed),
            Err(_) => {
                let mut blobs = self.blobs.lock().unwrap_or_else(|e| e.into_inner());
                blobs.remove(sha);
                0
            }
        };
        sent
    }

    /// Uploads the outputs of job `id`, which read `reads` and wrote `written` inside
    /// `output`: blobs first, then the entries that name them. A failure is a warning.
    pub(crate) fn upload(&self, id: &str, output: &Path, reads: &[PathBuf], written: &[PathBuf]) {
        if self.read_only || self.dead.load(Ordering::Relaxed) || written.is_empty() {
            return;
        }
        // A job that wrote beside its output is not kept: a hit could not write it.
        let Some(names) = written
            .iter()
            .map(|p| relative(p, output))
            .collect::<Option<Vec<_>>>()
        else {
            return;
        };
        let Some(shas) = reads
            .iter()
            .map(|p| self.sha(p))
            .collect::<Option<Vec<_>>>()
        else {
            return;
        };
        let list = Reads {
            reads: reads.to_vec(),
        };
        let Ok(list) = serde_json::to_vec(&list) else {
            return;
        };
        let mut outputs = Vec::new();
        for (p, path) in written.iter().zip(names) {
            let Ok(bytes) = std::fs::read(p) else { return };
            outputs.push((path, bytes));
        }
        outputs.push((INPUTS.to_string(), list));
        let mut digests = Vec::new();
        for (path, bytes) in &outputs {
            let sha = sha_hex(bytes);
            if let Err(e) = self.put_blob(&sha, bytes) {
                return self.put_failed(id, e);
            }
            digests.push(Output {
                path: path.clone(),
                sha256: sha,
                size: bytes.len() as u64,
            });
        }
        let inputs = digests.split_off(written.len());
        let entries = [
            (outputs_key(id, reads, &shas), reapi::encode(&digests)),
            (reads_key(id), reapi::encode(&inputs)),
        ];
        for (key, bytes) in entries {
            if let Err(e) = self.store.put(&key, &bytes) {
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

/// `path` (one of a job's outputs) relative to the folder of the job's `output`, `/`-separated,
/// as an entry names it (None: not inside the output, or not UTF-8).
fn relative(path: &Path, output: &Path) -> Option<String> {
    if !inside(path, output) {
        return None;
    }
    let rest = path.strip_prefix(output.parent()?).ok()?;
    let parts: Option<Vec<&str>> = rest
        .components()
        .map(|c| match c {
            Component::Normal(n) => n.to_str(),
            _ => None,
        })
        .collect();
    Some(parts?.join("/"))
}

/// Where an entry's `name` (relative to the folder of the job's `output`) is written: only
/// plain names, and only inside `output` or a sidecar of it.
fn place(name: &str, output: &Path) -> Option<PathBuf> {
    let mut path = output.parent()?.to_path_buf();
    for part in name.split('/') {
        if part.is_empty() || part == "." || part == ".." || part.contains('\\') {
            return None;
        }
        path.push(part);
    }
    inside(&path, output).then_some(path)
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
#[path = "cache_tests.rs"]
mod tests;
