//! Multi-file outputs land whole or not at all: new folders appear complete, failures and
//! signals leave neither temporaries nor empty folders, and two writers of one folder never
//! mix their files.

use cubeforge::io::{stage, write_all_atomic};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");

/// Every entry under `dir`, relative, sorted.
pub(crate) fn tree(dir: &Path) -> Vec<String> {
    fn walk(d: &Path, root: &Path, out: &mut Vec<String>) {
        let Ok(rd) = std::fs::read_dir(d) else { return };
        for e in rd.flatten() {
            let p = e.path();
            out.push(p.strip_prefix(root).unwrap().display().to_string());
            if p.is_dir() {
                walk(&p, root, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

fn files(list: &[(&Path, &str)]) -> Vec<(PathBuf, Vec<u8>)> {
    list.iter()
        .map(|(p, s)| (p.to_path_buf(), s.as_bytes().to_vec()))
        .collect()
}

#[test]
fn a_new_nested_folder_appears_whole() {
    let t = tempfile::tempdir().unwrap();
    let a = t.path().join("out/chain/m0/px.txt");
    let b = t.path().join("out/chain/levels.json");
    let staged = stage(&files(&[(&a, "a"), (&b, "b")])).unwrap();
    // Staged: only the temporary folder exists, under a hidden name.
    assert_eq!(tree(t.path()).len(), 5, "{:?}", tree(t.path()));
    assert!(!t.path().join("out").exists());
    staged.commit().unwrap();
    assert_eq!(
        tree(t.path()),
        [
            "out",
            "out/chain",
            "out/chain/levels.json",
            "out/chain/m0",
            "out/chain/m0/px.txt"
        ]
    );
    assert_eq!(std::fs::read_to_string(&a).unwrap(), "a");
}

#[test]
fn dropped_stage_leaves_nothing() {
    let t = tempfile::tempdir().unwrap();
    std::fs::write(t.path().join("keep"), "k").unwrap();
    let a = t.path().join("new/px.txt");
    let b = t.path().join("beside.txt");
    drop(stage(&files(&[(&a, "a"), (&b, "b")])).unwrap());
    assert_eq!(tree(t.path()), ["keep"]);
}

#[test]
fn a_failed_write_removes_the_folders_it_made() {
    let t = tempfile::tempdir().unwrap();
    std::fs::write(t.path().join("plain"), "p").unwrap();
    let a = t.path().join("made/deep/px.txt");
    // The second file's folder is a regular file: the write fails after the first landed
    // in its temporary folder.
    let b = t.path().join("plain/sub/nx.txt");
    let e = write_all_atomic(&files(&[(&a, "a"), (&b, "b")])).unwrap_err();
    assert!(e.to_string().contains("plain"), "{e}");
    assert_eq!(tree(t.path()), ["plain"]);
}

#[test]
fn an_existing_folder_gets_every_file_and_keeps_others() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path().join("faces");
    std::fs::create_dir(&d).unwrap();
    std::fs::write(d.join("notes.txt"), "mine").unwrap();
    std::fs::write(d.join("px.txt"), "old").unwrap();
    write_all_atomic(&files(&[
        (&d.join("px.txt"), "new"),
        (&d.join("nx.txt"), "n"),
    ]))
    .unwrap();
    assert_eq!(tree(&d), ["notes.txt", "nx.txt", "px.txt"]);
    assert_eq!(std::fs::read_to_string(d.join("px.txt")).unwrap(), "new");
}

/// A file replaced again and again is always there, whole, for a reader that keeps opening
/// it: old or new, never missing or partial; the replaced ones leave no names behind.
#[test]
fn a_replaced_file_is_never_missing_or_partial() {
    use std::sync::atomic::{AtomicBool, Ordering};
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join("px.txt");
    let body = |i: usize| format!("{i:06}").repeat(20_000);
    std::fs::write(&p, body(0)).unwrap();
    let (done, reading) = (AtomicBool::new(false), AtomicBool::new(false));
    std::thread::scope(|s| {
        let reader = s.spawn(|| {
            let mut reads = 0;
            while !done.load(Ordering::Relaxed) {
                let got = std::fs::read_to_string(&p).expect("the file is always there");
                assert_eq!(got.len(), 120_000, "a whole file");
                assert_eq!(got, got[..6].repeat(20_000), "one file's bytes");
                reads += 1;
                reading.store(true, Ordering::Relaxed);
            }
            reads
        });
        // On a loaded machine the reader may start late: the replacing waits for it.
        while !reading.load(Ordering::Relaxed) {
            std::thread::yield_now();
        }
        for i in 1..=200 {
            write_all_atomic(&[(p.clone(), body(i).into_bytes())]).unwrap();
        }
        done.store(true, Ordering::Relaxed);
        assert!(reader.join().unwrap() > 0);
    });
    assert_eq!(std::fs::read_to_string(&p).unwrap(), body(200));
    assert_eq!(tree(t.path()), ["px.txt"]);
}

/// A symbolic link in the way is replaced by the file, as a rename does; what it pointed to
/// is left alone.
#[cfg(unix)]
#[test]
fn a_link_in_the_way_is_replaced_not_followed() {
    let t = tempfile::tempdir().unwrap();
    let target = t.path().join("elsewhere.txt");
    std::fs::write(&target, "theirs").unwrap();
    let p = t.path().join("px.txt");
    std::os::unix::fs::symlink(&target, &p).unwrap();
    write_all_atomic(&files(&[(&p, "mine")])).unwrap();
    assert!(!p.is_symlink());
    assert_eq!(std::fs::read_to_string(&p).unwrap(), "mine");
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "theirs");
    assert_eq!(tree(t.path()), ["elsewhere.txt", "px.txt"]);
}

fn convert(out: &Path, yaw: &str, pause_ms: u64) -> Child {
    Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(["convert", SKY, "-o"])
        .arg(out)
        .args(["--size", "32", "--yaw", yaw])
        .env(
            "CUBEFORGE_TEST_PAUSE_BEFORE_COMMIT_MS",
            pause_ms.to_string(),
        )
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cubeforge runs")
}

fn wait_for(what: &str, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{what} never happened"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

#[cfg(unix)]
#[test]
fn sigterm_before_the_rename_leaves_nothing() {
    use std::os::unix::process::ExitStatusExt;
    for existing in [false, true] {
        let t = tempfile::tempdir().unwrap();
        let out = t.path().join("faces");
        if existing {
            std::fs::create_dir(&out).unwrap();
        }
        let child = convert(&out, "0", 20_000);
        // The temporaries are written when a hidden entry shows up.
        let hidden = |d: &Path| tree(d).iter().any(|e| e.contains(".cubeforge-"));
        wait_for("staging", || hidden(t.path()) && tree(t.path()).len() >= 6);
        let pid = child.id() as libc::pid_t;
        // SAFETY: kill only sends a signal to the child we started.
        unsafe { libc::kill(pid, libc::SIGTERM) };
        let out = child.wait_with_output().unwrap();
        let status = out.status;
        assert_eq!(status.signal(), Some(libc::SIGTERM), "{status:?}");
        // One line says what the stop left (issue 48).
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(
            err.lines().last(),
            Some("cubeforge: stopped (SIGTERM): nothing written"),
            "{err}"
        );
        let left = tree(t.path());
        let want: &[&str] = if existing { &["faces"] } else { &[] };
        assert_eq!(left, want, "existing folder: {existing}");
    }
}

#[test]
fn two_writers_never_mix_their_faces() {
    let dir = tempfile::tempdir().unwrap();
    // What each writer makes alone.
    let mut solo = Vec::new();
    for yaw in ["0", "90"] {
        let out = dir.path().join(format!("solo{yaw}"));
        let r = convert(&out, yaw, 0).wait_with_output().unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        solo.push(out);
    }
    let faces = ["px.png", "nx.png", "py.png", "ny.png", "pz.png", "nz.png"];
    let read = |d: &Path| -> Vec<Vec<u8>> {
        faces
            .iter()
            .map(|f| std::fs::read(d.join(f)).unwrap())
            .collect()
    };
    let (a, b) = (read(&solo[0]), read(&solo[1]));
    assert_ne!(a, b);
    for existing in [false, true] {
        let out = dir.path().join(format!("shared{existing}"));
        if existing {
            std::fs::create_dir(&out).unwrap();
        }
        // Both stage, then commit within a few milliseconds of each other.
        let p = convert(&out, "0", 400);
        let q = convert(&out, "90", 400);
        for c in [p, q] {
            let r = c.wait_with_output().unwrap();
            assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        }
        let got = read(&out);
        assert!(
            got == a || got == b,
            "faces from both writers (existing folder: {existing})"
        );
        assert_eq!(tree(&out).len(), 6, "{:?}", tree(&out));
        assert!(!tree(dir.path()).iter().any(|e| e.contains(".cubeforge-")));
    }
}
