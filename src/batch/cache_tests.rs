//! The team cache's unit tests: hits, names kept inside the output, and entries a hostile
//! store sends. Test code only (the source checks read a file up to its first
//! `#[cfg(test)]`).

#[cfg(test)]
use super::*;

/// A store in memory, counting its writes.
#[derive(Default)]
struct Memory(
    Mutex<HashMap<String, Vec<u8>>>,
    std::sync::atomic::AtomicUsize,
);

impl Store for std::sync::Arc<Memory> {
    fn get(&self, path: &str, most: u64) -> std::result::Result<Option<Vec<u8>>, String> {
        let cut = |b: &Vec<u8>| b[..b.len().min(most as usize + 1)].to_vec();
        Ok(self.0.lock().unwrap().get(path).map(cut))
    }
    fn put(&self, path: &str, bytes: &[u8]) -> std::result::Result<(), String> {
        self.1.fetch_add(1, Ordering::Relaxed);
        self.0.lock().unwrap().insert(path.into(), bytes.to_vec());
        Ok(())
    }
    fn name(&self) -> String {
        "memory".into()
    }
    fn has(&self, path: &str) -> std::result::Result<bool, String> {
        Ok(self.0.lock().unwrap().contains_key(path))
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
    // The output's blob and the list's, then the two entries that name them.
    let cache = Cache::new(mem.clone(), false);
    cache.upload("job", &out, &reads, &written);
    assert_eq!(mem.1.load(Ordering::Relaxed), 4);
    assert_eq!(cache.blob_counts(), (2, 0));
    // Again (another machine): the store has both blobs, and only the entries are sent.
    let again = Cache::new(mem.clone(), false);
    again.upload("job", &out, &reads, &written);
    assert_eq!(mem.1.load(Ordering::Relaxed), 6);
    assert_eq!(again.blob_counts(), (0, 2));
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
    // An entry's names are relative to the output's folder, plain names only.
    assert_eq!(
        relative(Path::new("out/sky/px.png"), out).unwrap(),
        "sky/px.png"
    );
    assert_eq!(
        place("sky/px.png", out).unwrap(),
        Path::new("out/sky/px.png")
    );
    assert_eq!(
        place("sky.levels.json", out).unwrap(),
        Path::new("out/sky.levels.json")
    );
    for bad in [
        "../sky/px.png",
        "sky/../../x",
        "/etc/passwd",
        "skyline.png",
        "sky//x",
        "",
    ] {
        assert!(place(bad, out).is_none(), "{bad}");
    }
    assert_eq!(
        relative(Path::new("a.png"), Path::new("a.png")).unwrap(),
        "a.png"
    );
    assert_eq!(
        place("a.png", Path::new("a.png")).unwrap(),
        Path::new("a.png")
    );
}

/// A store with `job`'s upload (one input, one output) in it, and the paths.
fn uploaded(t: &Path) -> (std::sync::Arc<Memory>, PathBuf) {
    let (input, out) = (t.join("in.txt"), t.join("out.png"));
    std::fs::write(&input, b"one").unwrap();
    std::fs::write(&out, b"result").unwrap();
    let mem = std::sync::Arc::new(Memory::default());
    Cache::new(mem.clone(), false).upload("job", &out, &[input], std::slice::from_ref(&out));
    (mem, out)
}

/// The hostile sweep's finding: the HTTP store read any body whole (`limit(u64::MAX)`), so a
/// cache that sent an endless entry or blob took the machine's memory. An entry longer than
/// an entry can be, a blob longer than its digest says, and a digest claiming more than this
/// process may hold are refused with a warning (the job runs here), none read whole.
#[test]
fn a_store_that_sends_too_much_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let (mem, out) = uploaded(t.path());
    let keys: Vec<String> = mem.0.lock().unwrap().keys().cloned().collect();
    let fetch = |mem: &std::sync::Arc<Memory>| {
        let cache = Cache::new(mem.clone(), false);
        let hit = cache.fetch("job", &out);
        (hit.is_some(), cache.take_warnings().join("\n"))
    };
    assert!(fetch(&mem).0);
    // Each `ac/` entry followed by megabytes: cut after ENTRY_BYTES + 1, refused.
    for key in keys.iter().filter(|k| k.starts_with("ac/")) {
        let (mem, _) = uploaded(t.path());
        let mut long = mem.0.lock().unwrap()[key].clone();
        long.resize(3 << 20, 0x0a);
        mem.0.lock().unwrap().insert(key.clone(), long);
        let (hit, warnings) = fetch(&mem);
        assert!(
            !hit && warnings.contains("not an ActionResult"),
            "{warnings}"
        );
    }
    // A blob longer than its digest: cut after size + 1, refused as damaged.
    for key in keys.iter().filter(|k| k.starts_with("cas/")) {
        let (mem, _) = uploaded(t.path());
        let mut long = mem.0.lock().unwrap()[key].clone();
        long.resize(1 << 20, 0);
        mem.0.lock().unwrap().insert(key.clone(), long);
        let (hit, warnings) = fetch(&mem);
        assert!(
            !hit && warnings.contains("does not match its hash"),
            "{warnings}"
        );
    }
    // A digest claiming 2^62 bytes: refused before the body is asked for.
    for key in keys.iter().filter(|k| k.starts_with("ac/")) {
        let (mem, _) = uploaded(t.path());
        let entry = mem.0.lock().unwrap()[key].clone();
        let mut outputs = reapi::decode(&entry).unwrap();
        outputs[0].size = 1 << 62;
        mem.0
            .lock()
            .unwrap()
            .insert(key.clone(), reapi::encode(&outputs));
        let (hit, warnings) = fetch(&mem);
        assert!(
            !hit && warnings.contains("more than this process may hold"),
            "{warnings}"
        );
    }
}

/// Seeded mutations of the `ac/` entries (bit flips, bytes set, cut, spliced, lengths made
/// extreme): a fetch never panics, and a hit only holds files inside the output whose bytes
/// match the hashes the entry names. `CUBEFORGE_CACHE_ROUNDS=n`: n times as many.
#[test]
fn mutated_entries_never_panic() {
    let t = tempfile::tempdir().unwrap();
    let (mem, out) = uploaded(t.path());
    let originals: Vec<(String, Vec<u8>)> = mem
        .0
        .lock()
        .unwrap()
        .iter()
        .filter(|(k, _)| k.starts_with("ac/"))
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    let scale: usize = std::env::var("CUBEFORGE_CACHE_ROUNDS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut hits, mut misses) = (0, 0);
    for round in 0..1000 * scale {
        let (key, original) = &originals[round % originals.len()];
        let mut b = original.clone();
        for _ in 0..1 + next() % 3 {
            let at = (next() as usize) % b.len().max(1);
            match next() % 6 {
                0 if !b.is_empty() => b[at] ^= 1 << (next() % 8),
                1 if !b.is_empty() => b[at] = [0, 0xff, 0x7f, 0x80][(next() % 4) as usize],
                2 => b.truncate(at),
                3 => b
                    .splice(
                        at..at,
                        [0xff; 10].iter().copied().take(1 + (next() % 10) as usize),
                    )
                    .for_each(drop),
                4 => {
                    let span = b[at..]
                        .iter()
                        .take(1 + (next() % 32) as usize)
                        .copied()
                        .collect::<Vec<_>>();
                    b.splice(at..at, span).for_each(drop);
                }
                _ if !b.is_empty() => b[at] = next() as u8,
                _ => {}
            }
        }
        let mem2 = std::sync::Arc::new(Memory::default());
        *mem2.0.lock().unwrap() = mem.0.lock().unwrap().clone();
        mem2.0.lock().unwrap().insert(key.clone(), b);
        let hit = std::panic::catch_unwind(|| Cache::new(mem2.clone(), false).fetch("job", &out))
            .unwrap_or_else(|_| panic!("round {round}: fetch panicked"));
        match hit {
            Some(hit) => {
                hits += 1;
                for (path, bytes) in &hit.files {
                    assert!(inside(path, &out), "round {round}: {}", path.display());
                    assert_eq!(bytes, b"result", "round {round}");
                }
            }
            None => misses += 1,
        }
    }
    println!("mutated cache entries: {hits} hits, {misses} refused or missed");
}
