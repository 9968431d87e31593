//! The state file: for each job that ran, the cubeforge build that ran it, every file it read
//! with a hash of its bytes, and the files it wrote. A job is up to date when its record says
//! the same build read the same bytes and its outputs are all still there. The file is JSON,
//! written whole (atomically) at the end of a batch; deleting it only makes the next batch
//! run everything.

use crate::error::{Error, Result};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use xxhash_rust::xxh3::Xxh3;

/// The state file's format version: a record of another version is not trusted. 2: a
/// record's key holds its outputs.
const FORMAT: u32 = 2;

/// What one job's last successful run read and wrote.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize, PartialEq)]
pub(crate) struct Record {
    /// The hash of the build, the job's id, every (file, bytes' hash) it read and the files it
    /// wrote: a record edited by hand does not match it.
    pub key: String,
    /// The cubeforge build that ran it.
    pub cubeforge: String,
    /// Each file read, in the order first read, with its bytes' hash.
    pub reads: Vec<(PathBuf, String)>,
    /// The files written.
    pub outputs: Vec<PathBuf>,
}

#[derive(Debug, Default, serde::Serialize, serde::Deserialize)]
pub(crate) struct State {
    format: u32,
    pub jobs: BTreeMap<String, Record>,
}

/// Why a job runs.
#[derive(Clone, Debug, PartialEq)]
pub enum Why {
    /// `--force`.
    Forced,
    /// No record of a run with these options (a new job, or its last run failed).
    NeverRan,
    /// A file it wrote is gone.
    OutputMissing(PathBuf),
    /// A file it read changed (or is gone).
    Changed(PathBuf),
    /// Another cubeforge build ran it.
    NewBuild,
}

impl std::fmt::Display for Why {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Why::Forced => write!(f, "--force"),
            Why::NeverRan => write!(f, "no record of a run with these options"),
            Why::OutputMissing(p) => write!(f, "{} is missing", p.display()),
            Why::Changed(p) => write!(f, "{} changed", p.display()),
            Why::NewBuild => write!(f, "another cubeforge build ran it"),
        }
    }
}

impl State {
    /// The state in `path`; an absent, unreadable or foreign file is an empty state (and
    /// the warning that says so, unless it is simply absent). A FIFO or a device is never
    /// opened in a way that waits ([`crate::io::atomic::open_regular`]).
    pub fn load(path: &Path) -> (State, Option<String>) {
        let read = crate::io::atomic::open_regular(path).and_then(|mut f| {
            let mut b = Vec::new();
            std::io::Read::read_to_end(&mut f, &mut b).map(|_| b)
        });
        let bytes = match read {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return (State::default(), None),
            Err(e) => {
                let w = format!("{}: {e}; every job runs", path.display());
                return (State::default(), Some(w));
            }
        };
        match serde_json::from_slice::<State>(&bytes) {
            Ok(s) if s.format == FORMAT => (s, None),
            _ => (
                State::default(),
                Some(format!(
                    "{}: not a cubeforge state file of this version; every job runs",
                    path.display()
                )),
            ),
        }
    }

    /// The state's bytes: pretty JSON, jobs in id order.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let mut s = serde_json::to_vec_pretty(&State {
            format: FORMAT,
            jobs: self.jobs.clone(),
        })
        .map_err(|e| Error::usage(format!("cannot write the state file: {e}")))?;
        s.push(b'\n');
        Ok(s)
    }
}

/// Hashes of files' bytes, each file read once per batch.
#[derive(Default)]
pub(crate) struct Hashes(std::sync::Mutex<HashMap<PathBuf, Option<String>>>);

impl Hashes {
    /// The hash of `path`'s bytes (None when it cannot be read).
    pub fn of(&self, path: &Path) -> Option<String> {
        if let Some(h) = self.0.lock().unwrap_or_else(|e| e.into_inner()).get(path) {
            return h.clone();
        }
        let h = hash_file(path);
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .insert(path.to_path_buf(), h.clone());
        h
    }

    /// Forgets `path`'s hash (a job may have rewritten it).
    pub fn forget(&self, path: &Path) {
        self.0
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remove(path);
    }
}

/// Feeds a regular file's bytes to `each` a megabyte at a time (None: not one, or
/// unreadable): what the state's hash and the cache's key read a file through.
pub(super) fn stream_file(path: &Path, mut each: impl FnMut(&[u8])) -> Option<()> {
    use std::io::Read;
    let mut f = crate::io::atomic::open_regular(path).ok()?;
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let n = f.read(&mut buf).ok()?;
        if n == 0 {
            return Some(());
        }
        each(&buf[..n]);
    }
}

/// The hash of a regular file's bytes (None: not one, or unreadable: the job runs).
fn hash_file(path: &Path) -> Option<String> {
    let mut h = Xxh3::new();
    stream_file(path, |b| h.update(b))?;
    Some(format!("{:032x}", h.digest128()))
}

/// The cubeforge build: its version, and the size and time of the program that runs it (a
/// rebuilt cubeforge may write other bytes under the same version).
pub(crate) fn build() -> &'static str {
    static BUILD: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    BUILD.get_or_init(|| {
        let stamp = std::env::current_exe()
            .and_then(std::fs::metadata)
            .ok()
            .map(|m| {
                let t = m
                    .modified()
                    .ok()
                    .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
                    .map_or(0, |d| d.as_nanos());
                format!(" {}-{t}", m.len())
            })
            .unwrap_or_default();
        format!("{}{stamp}", env!("CARGO_PKG_VERSION"))
    })
}

/// The key of a job `id` run by `build` that read `reads` and wrote `outputs`.
pub(crate) fn key(
    build: &str,
    id: &str,
    reads: &[(PathBuf, String)],
    outputs: &[PathBuf],
) -> String {
    let mut h = Xxh3::new();
    for part in [build, id] {
        h.update(&(part.len() as u64).to_le_bytes());
        h.update(part.as_bytes());
    }
    for (path, hash) in reads {
        let p = path.to_string_lossy();
        h.update(&(p.len() as u64).to_le_bytes());
        h.update(p.as_bytes());
        h.update(hash.as_bytes());
    }
    h.update(&(outputs.len() as u64).to_le_bytes());
    for path in outputs {
        let p = path.to_string_lossy();
        h.update(&(p.len() as u64).to_le_bytes());
        h.update(p.as_bytes());
    }
    format!("{:032x}", h.digest128())
}

/// Why the job `id` must run, given its last record (None: it is up to date).
pub(crate) fn why(id: &str, record: Option<&Record>, hashes: &Hashes) -> Option<Why> {
    let Some(r) = record else {
        return Some(Why::NeverRan);
    };
    if r.cubeforge != build() {
        return Some(Why::NewBuild);
    }
    if let Some(p) = r.outputs.iter().find(|p| !p.exists()) {
        return Some(Why::OutputMissing(p.clone()));
    }
    for (path, hash) in &r.reads {
        if hashes.of(path).as_deref() != Some(hash.as_str()) {
            return Some(Why::Changed(path.clone()));
        }
    }
    // A record edited by hand (or of another job) is not trusted.
    (key(build(), id, &r.reads, &r.outputs) != r.key).then_some(Why::NeverRan)
}

/// The record of a run of `id` that read `reads` and wrote `outputs`; None when a file it read
/// cannot be hashed now (gone already: the next batch runs the job again).
pub(crate) fn record(
    id: &str,
    reads: Vec<PathBuf>,
    outputs: Vec<PathBuf>,
    hashes: &Hashes,
) -> Option<Record> {
    let reads: Vec<(PathBuf, String)> = reads
        .into_iter()
        .map(|p| hashes.of(&p).map(|h| (p, h)))
        .collect::<Option<_>>()?;
    Some(Record {
        key: key(build(), id, &reads, &outputs),
        cubeforge: build().to_owned(),
        reads,
        outputs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seeded mutations of a state file (bytes flipped, set, cut, spliced; numbers and
    /// nesting made extreme): it loads or is set aside with a warning naming it, and every
    /// record it keeps is judged (`why`) without a panic. `CUBEFORGE_STATE_ROUNDS=n`: n
    /// times as many.
    #[test]
    fn mutated_state_files_load_or_are_set_aside() {
        let t = tempfile::tempdir().unwrap();
        let (input, out) = (t.path().join("in.exr"), t.path().join("out.ktx2"));
        std::fs::write(&input, b"in").unwrap();
        std::fs::write(&out, b"out").unwrap();
        let hashes = Hashes::default();
        let mut state = State::default();
        for id in ["sky", "sky/bevy"] {
            let r = record(id, vec![input.clone()], vec![out.clone()], &hashes).unwrap();
            state.jobs.insert(id.into(), r);
        }
        let src = state.to_bytes().unwrap();
        let path = t.path().join("m.state.json");
        let scale: usize = std::env::var("CUBEFORGE_STATE_ROUNDS")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(1);
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let (mut kept, mut refused) = (0, 0);
        for round in 0..1000 * scale {
            let mut b = src.clone();
            for _ in 0..1 + next() % 3 {
                let at = (next() as usize) % b.len().max(1);
                match next() % 7 {
                    0 if at < b.len() => b[at] ^= 1 << (next() % 8),
                    1 if at < b.len() => b[at] = b"\"{}[],:0\\\n"[(next() % 10) as usize],
                    2 => b.truncate(at),
                    3 => {
                        let n: &[u8] = [&b"1e400"[..], b"-1", b"18446744073709551616", b"null"]
                            [(next() % 4) as usize];
                        b.splice(at..at, n.iter().copied()).for_each(drop);
                    }
                    4 => {
                        let deep = "[".repeat(1 + (next() % 5000) as usize);
                        b.splice(at..at, deep.bytes()).for_each(drop);
                    }
                    5 => {
                        let end = (at + 1 + (next() % 64) as usize).min(b.len());
                        let span = b[at..end].to_vec();
                        b.splice(at..at, span).for_each(drop);
                    }
                    _ if at < b.len() => b[at] = next() as u8,
                    _ => {}
                }
            }
            std::fs::write(&path, &b).unwrap();
            let (loaded, warning) = State::load(&path);
            if let Some(w) = warning {
                assert!(
                    w.contains("m.state.json") && !w.contains('\n'),
                    "round {round}: {w}"
                );
                refused += 1;
            } else {
                kept += 1;
            }
            for (id, r) in &loaded.jobs {
                let _ = why(id, Some(r), &hashes);
            }
        }
        println!("mutated state files: {kept} loaded, {refused} set aside");
    }
}
