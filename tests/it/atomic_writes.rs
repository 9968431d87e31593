//! Multi-file outputs land whole or not at all: signals leave neither temporaries nor empty
//! folders, and two writers of one folder never mix their files (the staging itself is
//! tested beside it, in src/io/atomic/tests.rs).

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");

pub(crate) use crate::tree::tree;

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
