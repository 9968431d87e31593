//! Reruns: nothing changed does nothing; a changed input, decal or recipe image reruns only
//! the jobs that read it; a deleted output reruns its job; --force reruns all; the state
//! file is safe to delete.

use super::{project, ran};
use crate::cli_options::run_ok;
use std::path::Path;

fn batch(d: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec!["batch", "proj/m.toml"];
    args.extend_from_slice(extra);
    run_ok(&args, d)
}

fn stdout(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Replaces `file` with other bytes: the same picture one stop brighter.
fn change(d: &Path, file: &str) {
    let tmp = d.join(format!("changed.{}", file.rsplit('.').next().unwrap()));
    run_ok(
        &[
            "convert",
            &d.join("proj").join(file).display().to_string(),
            "-o",
            &tmp.display().to_string(),
            "--exposure",
            "1",
            "-q",
        ],
        d,
    );
    std::fs::rename(&tmp, d.join("proj").join(file)).unwrap();
}

#[test]
fn a_rerun_does_only_what_changed() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    project(d);
    let first = batch(d, &[]);
    assert_eq!(ran(&first).len(), 7, "{}", stdout(&first));
    assert!(d.join("proj/m.state.json").is_file());
    let made = d.join("proj/build/a/box.ktx2");
    let when = std::fs::metadata(&made).unwrap().modified().unwrap();

    // Nothing changed: nothing runs, nothing is written, and it is quick.
    let start = std::time::Instant::now();
    let again = batch(d, &[]);
    assert!(start.elapsed().as_secs_f64() < 5.0);
    assert!(ran(&again).is_empty(), "{}", stdout(&again));
    assert!(
        stdout(&again).contains("batch: 7 jobs: 0 ran, 7 up to date, 0 failed"),
        "{}",
        stdout(&again)
    );
    assert_eq!(std::fs::metadata(&made).unwrap().modified().unwrap(), when);
    // Touched, not changed: keys are the bytes read.
    let f = std::fs::File::options()
        .append(true)
        .open(d.join("proj/hdri/b.exr"))
        .unwrap();
    f.set_modified(std::time::SystemTime::now()).unwrap();
    assert!(ran(&batch(d, &[])).is_empty());

    // One input changed: its two jobs, and those alone.
    change(d, "hdri/a.exr");
    let dry = stdout(&batch(d, &["--dry-run"]));
    assert!(
        dry.contains(
            "would run   cubeforge prefilter hdri/a.exr -o build/a/box.ktx2 --filter box --size \
             16 (hdri/a.exr changed)"
        ),
        "{dry}"
    );
    assert!(dry.contains("2 would run, 5 up to date"), "{dry}");
    let mut r = ran(&batch(d, &[]));
    r.sort();
    assert_eq!(
        r,
        [
            "prefilter hdri/a.exr -o build/a/box.ktx2 --filter box --size 16",
            "preview hdri/a.exr -o build/a/preview.png --size 24 --decal decal.png --material mirror-decal",
        ]
    );

    // The recipe's mask changed: the control map alone.
    change(d, "masks/m.png");
    assert_eq!(ran(&batch(d, &[])), ["control r.toml -o build/control.png"]);
    // The decal changed: the three previews.
    change(d, "decal.png");
    let r = ran(&batch(d, &[]));
    assert_eq!(r.len(), 3, "{r:?}");
    assert!(r.iter().all(|l| l.starts_with("preview ")), "{r:?}");

    // A deleted output: its job.
    std::fs::remove_file(d.join("proj/build/b/box.ktx2")).unwrap();
    let dry = stdout(&batch(d, &["--dry-run"]));
    assert!(dry.contains("(build/b/box.ktx2 is missing)"), "{dry}");
    assert_eq!(
        ran(&batch(d, &[])),
        ["prefilter hdri/b.exr -o build/b/box.ktx2 --filter box --size 16"]
    );

    // Other options are another job.
    let m = std::fs::read_to_string(d.join("proj/m.toml")).unwrap();
    std::fs::write(d.join("proj/m.toml"), m.replace("\"24\"", "\"20\"")).unwrap();
    assert_eq!(ran(&batch(d, &[])).len(), 3);

    // --force runs everything; a deleted state file too.
    assert_eq!(ran(&batch(d, &["--force"])).len(), 7);
    std::fs::remove_file(d.join("proj/m.state.json")).unwrap();
    assert_eq!(ran(&batch(d, &[])).len(), 7);
    // A state file that is not one: a warning, and everything runs.
    std::fs::write(d.join("proj/m.state.json"), "not json").unwrap();
    let o = batch(d, &[]);
    assert_eq!(ran(&o).len(), 7);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("not a cubeforge state file"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

/// A batch stopped by a signal keeps what it finished: the state file is written as jobs end
/// (within a second), so a rerun does not redo a job that ended before the signal.
#[test]
fn an_interrupted_batch_keeps_the_jobs_it_finished() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    super::skies(d, &["quick.exr", "slow.exr"]);
    // One quick job, and one that takes many seconds (a 512 px GGX chain of 16384 samples).
    std::fs::write(
        d.join("proj/m.toml"),
        r#"
[[job]]
inputs = ["hdri/quick.exr"]
command = "convert"
args = ["--to", "hcross"]
output = "build/quick.exr"

[[job]]
inputs = ["hdri/slow.exr"]
command = "prefilter"
args = ["--filter", "ggx", "--size", "512", "--samples", "16384"]
output = "build/slow.ktx2"
"#,
    )
    .unwrap();
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(["batch", "proj/m.toml"])
        .current_dir(d)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let state = d.join("proj/m.state.json");
    let start = std::time::Instant::now();
    while !state.exists() && start.elapsed().as_secs() < 60 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(state.exists(), "no state file while the batch runs");
    // SAFETY: kill only sends a signal to the child we started.
    unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGINT) };
    let status = child.wait().unwrap();
    assert!(!status.success(), "the slow job ended before the signal");
    assert!(!d.join("proj/build/slow.ktx2").exists());
    let dry = stdout(&batch(d, &["--dry-run"]));
    assert!(
        dry.contains("batch: 2 jobs: 1 would run, 1 up to date"),
        "{dry}"
    );
    assert!(dry.contains("would run   cubeforge prefilter"), "{dry}");
}
