//! Staging and committing: new folders appear complete, failures leave neither temporaries
//! nor empty folders, replaced files are never missing or partial.

use super::{stage_replacing, Staged};
use crate::error::Result;
use std::path::{Path, PathBuf};

/// The files and folder outputs staged, no other run's files known.
fn stage_with(files: &[(PathBuf, Vec<u8>)], folders: &[PathBuf]) -> Result<Staged> {
    stage_replacing(files, folders, &[])
}

#[path = "../../../tests/it/tree.rs"]
mod tree;
use tree::tree;

/// Staged and committed: all or none.
fn write_all(files: &[(PathBuf, Vec<u8>)]) -> Result<()> {
    stage_with(files, &[])?.commit()
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
    let staged = stage_with(&files(&[(&a, "a"), (&b, "b")]), &[]).unwrap();
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
    drop(stage_with(&files(&[(&a, "a"), (&b, "b")]), &[]).unwrap());
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
    let e = write_all(&files(&[(&a, "a"), (&b, "b")])).unwrap_err();
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
    write_all(&files(&[
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
            write_all(&[(p.clone(), body(i).into_bytes())]).unwrap();
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
    write_all(&files(&[(&p, "mine")])).unwrap();
    assert!(!p.is_symlink());
    assert_eq!(std::fs::read_to_string(&p).unwrap(), "mine");
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "theirs");
    assert_eq!(tree(t.path()), ["elsewhere.txt", "px.txt"]);
}
