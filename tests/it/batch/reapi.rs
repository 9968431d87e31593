//! The team cache's entries are Bazel's (issue 51): what a batch stores in nginx is read by
//! REAPI's own generated classes (buildgrid's `remote_execution_pb2`, tests/tools/reapi_cache.py)
//! as Bazel reads it, every `ac/` entry an `ActionResult` whose outputs are in `cas/` with their
//! hash and size; entries that class writes are hits for cubeforge; a malformed entry is a
//! warning and a local run; and a batch after a partial cache sends only the blobs it lacks.

use super::cache::{batch, clone, text, TOKEN};
use super::nginx::Nginx;
use super::ran;
use std::path::Path;
use std::process::Command;

const TOOL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/tools/reapi_cache.py");

/// The tool's `mode` over the cache at `url` (its files under `store`): its output, or None
/// (after a SKIPPED line; a failure under CI) when buildgrid's classes are missing.
fn tool(mode: &str, url: &str, store: &Path) -> Option<String> {
    let o = Command::new("python3")
        .args([TOOL, mode, url])
        .arg(store)
        .env("CUBEFORGE_CACHE_TOKEN", TOKEN)
        .output();
    let o = match o {
        Ok(o) if o.status.code() != Some(3) => o,
        _ => {
            assert!(
                std::env::var_os("CI").is_none(),
                "buildgrid's REAPI classes are missing (pip install --no-deps buildgrid; pip \
                 install protobuf)"
            );
            eprintln!("SKIPPED: python3 with buildgrid and protobuf is not installed");
            return None;
        }
    };
    let out = text(&o);
    assert!(o.status.success(), "{mode}: {out}");
    Some(out)
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn bazel_reads_the_cache_and_cubeforge_reads_bazels_entries() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let Some(server) = Nginx::start(&d.join("nginx"), TOKEN) else {
        return;
    };
    let (url, store) = (server.url(), server.root());
    let cache = ["--cache", url.as_str(), "-v"];
    for c in ["a", "b", "c", "e"] {
        clone(&d.join(c));
    }
    let first = batch(&d.join("a"), &cache, TOKEN);
    let out = text(&first);
    assert!(out.contains("10 ran, 0 from the cache"), "{out}");
    // Every entry as Bazel reads it: 10 jobs, two entries each.
    let Some(checked) = tool("check", &url, &store) else {
        return;
    };
    assert!(
        checked.contains("reapi: 20 ActionResult entries, 10 lists of inputs"),
        "{checked}"
    );
    let built = super::contents(&d.join("a/proj/build"));

    // A partial cache (no entries, every other blob gone): every job runs, and only the
    // blobs the cache lacks are sent (HEAD finds the others).
    let ac = files(&store.join("ac"));
    let blobs = files(&store.join("cas"));
    for k in &ac {
        std::fs::remove_file(store.join("ac").join(k)).unwrap();
    }
    let gone: Vec<&String> = blobs.iter().step_by(2).collect();
    for b in &gone {
        std::fs::remove_file(store.join("cas").join(b)).unwrap();
    }
    let puts = server.puts();
    let again = batch(&d.join("b"), &cache, TOKEN);
    let out = text(&again);
    assert!(out.contains("10 ran, 0 from the cache"), "{out}");
    // Each job's files and its list of inputs asked for, only the missing sent.
    let line = format!(
        "cache: {} blobs uploaded, {} already there",
        gone.len(),
        built.len() + 10 - gone.len()
    );
    assert!(out.contains(&line), "{line}\n{out}");
    assert_eq!(files(&store.join("cas")), blobs, "{out}");
    assert_eq!(server.puts() - puts, gone.len() + ac.len(), "{out}");
    println!(
        "cache: after a partial cache ({} of {} blobs gone), {} PUTs ({} blobs, {} entries)",
        gone.len(),
        blobs.len(),
        server.puts() - puts,
        gone.len(),
        ac.len()
    );

    // Entries written by REAPI's own class, for the keys cubeforge computed: every job a hit.
    let rewritten = tool("rewrite", &url, &store).unwrap();
    assert!(rewritten.contains("20 entries rewritten"), "{rewritten}");
    let served = batch(&d.join("c"), &cache, TOKEN);
    let out = text(&served);
    assert!(out.contains("0 ran, 10 from the cache"), "{out}");
    assert!(ran(&served).is_empty(), "{out}");
    assert!(built == super::contents(&d.join("c/proj/build")));

    // A malformed entry: a warning naming it, and that job runs here.
    let bad = store.join("ac").join(&ac[0]);
    // The JSON manifest an earlier cubeforge wrote.
    std::fs::write(&bad, br#"{"folder":false,"outputs":[]}"#).unwrap();
    let refused = batch(&d.join("e"), &cache, TOKEN);
    let out = text(&refused);
    assert!(refused.status.success(), "{out}");
    assert!(out.contains("is refused"), "{out}");
    assert!(out.contains("not an ActionResult"), "{out}");
    assert!(out.contains("1 ran, 9 from the cache"), "{out}");
    assert!(built == super::contents(&d.join("e/proj/build")));
}
