//! The team cache (issue 51) against a real server, nginx as a Bazel HTTP cache: a second
//! clone with no state file is served every job (no compute, the same bytes, no upload); a
//! damaged blob is refused and the job recomputed; a stopped server is a warning and the
//! build completes; the token is never printed.

use super::nginx::Nginx;
use super::{project, ran};
use std::path::Path;
use std::process::{Command, Output};
use std::time::Instant;

pub(super) const TOKEN: &str = "s3cret-t0ken";

/// The test project with one heavier job per panorama: an ibl delivery, a folder output.
pub(super) fn clone(d: &Path) {
    project(d);
    let m = d.join("proj/m.toml");
    let mut text = std::fs::read_to_string(&m).unwrap();
    text.push_str(
        "\n[[job]]\ninputs = [\"hdri/*.exr\"]\ncommand = \"ibl\"\nargs = [\"--target\", \
         \"bevy\"]\noutput = \"build/{stem}/bevy\"\n",
    );
    std::fs::write(m, text).unwrap();
}

pub(super) fn batch(dir: &Path, args: &[&str], token: &str) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .arg("batch")
        .arg("m.toml")
        .args(args)
        .current_dir(dir.join("proj"))
        .env("CUBEFORGE_CACHE_TOKEN", token)
        .env_remove("CUBEFORGE_CACHE")
        .output()
        .expect("cubeforge runs")
}

pub(super) fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Every file under `dir`, relative, with its bytes.
#[test]
fn a_second_clone_is_served_by_the_cache() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let Some(mut server) = Nginx::start(&d.join("nginx"), TOKEN) else {
        return;
    };
    let url = server.url();
    let cache = ["--cache", url.as_str(), "-v"];
    for c in ["a", "b", "c", "e"] {
        clone(&d.join(c));
    }
    // The first clone computes every job and uploads it.
    let start = Instant::now();
    let first = batch(&d.join("a"), &cache, TOKEN);
    let first_s = start.elapsed().as_secs_f64();
    let out = text(&first);
    assert!(first.status.success(), "{out}");
    assert!(out.contains("10 ran, 0 from the cache"), "{out}");
    assert_eq!(out.matches("cache miss  cubeforge").count(), 10, "{out}");
    let uploads = server.puts();
    let log = std::fs::read_to_string(d.join("nginx/access.log")).unwrap();
    assert!(uploads >= 30, "{uploads} PUTs\n{log}");
    // A dry run of the second clone says the cache would serve every job.
    let dry = text(&batch(&d.join("b"), &["--cache", &url, "--dry-run"], TOKEN));
    assert!(
        dry.contains("0 would run, 10 from the cache, 0 up to date"),
        "{dry}"
    );
    // The second clone, no state file: every job served, byte for byte, nothing uploaded.
    let start = Instant::now();
    let second = batch(&d.join("b"), &cache, TOKEN);
    let second_s = start.elapsed().as_secs_f64();
    let out = text(&second);
    assert!(second.status.success(), "{out}");
    assert!(out.contains("0 ran, 10 from the cache"), "{out}");
    assert!(ran(&second).is_empty(), "{out}");
    assert_eq!(server.puts(), uploads, "the second clone uploaded\n{out}");
    let built = super::contents(&d.join("a/proj/build"));
    assert_eq!(
        built.len(),
        17,
        "{:?}",
        built.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert!(
        built == super::contents(&d.join("b/proj/build")),
        "the bytes differ"
    );
    println!("cache: first clone {first_s:.2} s (10 jobs ran), second clone {second_s:.2} s (10 from the cache)");
    assert!(
        second_s < first_s / 2.0,
        "{second_s:.2} s vs {first_s:.2} s"
    );
    // Its state file now knows the jobs: a rerun is up to date without asking the cache.
    let again = text(&batch(&d.join("b"), &cache, TOKEN));
    assert!(
        again.contains("0 ran, 0 from the cache, 10 up to date"),
        "{again}"
    );

    // A damaged blob is refused, its job recomputed (and its blob uploaded again).
    // The control map's blob: the only job with those bytes (the skies are copies of one).
    let control = std::fs::read(d.join("a/proj/build/control.png")).unwrap();
    let sha: String =
        sha2::Digest::finalize(<sha2::Sha256 as sha2::Digest>::new_with_prefix(&control))
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
    let blob = server.root().join("cas").join(sha);
    let good = std::fs::read(&blob).unwrap();
    std::fs::write(&blob, b"not the bytes the hash names").unwrap();
    let damaged = batch(&d.join("c"), &cache, TOKEN);
    let out = text(&damaged);
    assert!(damaged.status.success(), "{out}");
    assert!(out.contains("does not match its hash"), "{out}");
    assert!(out.contains("1 ran, 9 from the cache"), "{out}");
    assert!(
        built == super::contents(&d.join("c/proj/build")),
        "the bytes differ"
    );
    assert_eq!(
        std::fs::read(&blob).unwrap(),
        good,
        "the blob was not uploaded again"
    );

    // A wrong token: one warning, the build goes on locally (read only: nothing uploaded).
    let puts = server.puts();
    std::fs::remove_file(d.join("c/proj/m.state.json")).unwrap();
    let denied = batch(
        &d.join("c"),
        &["--cache", &url, "--cache-read-only"],
        "wrong",
    );
    let out = text(&denied);
    assert!(denied.status.success(), "{out}");
    assert!(out.contains("HTTP 401"), "{out}");
    assert!(out.contains("10 ran, 0 from the cache"), "{out}");
    assert_eq!(server.puts(), puts);

    // The server stopped: a warning, and the build completes.
    server.stop();
    let dead = batch(&d.join("e"), &cache, TOKEN);
    let out = text(&dead);
    assert!(dead.status.success(), "{out}");
    assert_eq!(out.matches("warning").count(), 1, "{out}");
    assert!(out.contains("10 ran, 0 from the cache"), "{out}");
    assert!(
        built == super::contents(&d.join("e/proj/build")),
        "the bytes differ"
    );
    for o in [&first, &second, &damaged, &denied, &dead] {
        assert!(!text(o).contains(TOKEN), "the token was printed");
    }
}

/// A cache URL that cannot be used is one line naming the problem and a non-zero exit before
/// any job: credentials in it, another scheme, https:// in a build without the feature.
#[test]
fn unusable_cache_urls_are_refused() {
    let t = tempfile::tempdir().unwrap();
    clone(t.path());
    let mut cases = vec![
        ("http://me:pw@cache.lan:8080", "holds credentials"),
        ("ftp://cache.lan", "http:// or https://"),
    ];
    if cfg!(not(feature = "https")) {
        cases.push(("https://cache.lan", "the cargo feature `https`"));
    }
    for (url, says) in cases {
        let o = batch(t.path(), &["--cache", url], "");
        let out = text(&o);
        assert!(!o.status.success(), "{url}: {out}");
        assert!(out.contains(says), "{url}: {out}");
        assert!(!out.contains("pw@"), "{url}: {out}");
        assert!(!t.path().join("proj/build").exists(), "{url}: a job ran");
    }
}

/// A cache that answers every GET with an endless body: the hostile sweep found the HTTP store
/// read any body whole (`limit(u64::MAX)`), so such a server filled the machine's memory. An
/// entry is read to 1 MiB and refused (a warning; the jobs run here), the connection dropped:
/// the server gets to send little more than that and what the socket buffers hold.
#[test]
fn a_cache_that_sends_an_endless_body_is_refused() {
    use std::io::{Read, Write};
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::sync::Arc;
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    clone(&d.join("a"));
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let url = format!("http://{}", listener.local_addr().unwrap());
    let most = Arc::new(AtomicU64::new(0));
    let seen = most.clone();
    std::thread::spawn(move || {
        for conn in listener.incoming() {
            let Ok(mut s) = conn else { break };
            let seen = seen.clone();
            std::thread::spawn(move || {
                let mut head = [0u8; 4096];
                let n = s.read(&mut head).unwrap_or(0);
                if !head[..n].starts_with(b"GET ") {
                    let _ = s.write_all(b"HTTP/1.1 404 Not Found\r\ncontent-length: 0\r\n\r\n");
                    return;
                }
                let _ = s.write_all(b"HTTP/1.1 200 OK\r\nconnection: close\r\n\r\n");
                let chunk = vec![0x0au8; 1 << 16];
                let mut sent = 0u64;
                // At most 256 MiB: enough to tell a bounded reader from one that is not.
                while sent < 256 << 20 && s.write_all(&chunk).is_ok() {
                    sent += chunk.len() as u64;
                }
                seen.fetch_max(sent, Ordering::Relaxed);
            });
        }
    });
    let o = batch(&d.join("a"), &["--cache", url.as_str()], TOKEN);
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(out.contains("not an ActionResult"), "{out}");
    let sent = most.load(Ordering::Relaxed);
    assert!(
        sent < 32 << 20,
        "the server sent {} MiB before the reader stopped",
        sent >> 20
    );
}
