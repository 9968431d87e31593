//! Issue 44, items 2, 4, 6 and 7: outputs that cannot be turned against the user. A FIFO or a
//! device named as an output or a depfile is refused and left as it was (never replaced by a
//! regular file); a depfile never lands on the command's output, a file of its output
//! folder or its `--sh` file; two outputs of one command are never one file. The batch's
//! cases (state files and records naming FIFOs, jobs that write each other's files) are in
//! `batch.rs`. Every run that could block on a FIFO is killed after a timeout, failing the
//! test.

use crate::fault_campaign::{refused, BIN};
use std::ffi::CString;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

pub(crate) const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

/// A run that blocks longer than this is a hang: the test kills it and fails.
const HANG: Duration = Duration::from_secs(60);

/// Runs cubeforge in `dir`, killed and the test failed if it runs past [`HANG`] (blocked on a
/// FIFO, say).
pub(crate) fn run_within(dir: &Path, args: &[&str]) -> Output {
    use std::io::Read;
    let mut child = Command::new(BIN)
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cubeforge starts");
    let drain = |mut r: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut v = Vec::new();
            r.read_to_end(&mut v).ok();
            v
        })
    };
    let out = drain(Box::new(child.stdout.take().unwrap()));
    let err = drain(Box::new(child.stderr.take().unwrap()));
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > HANG {
            child.kill().ok();
            child.wait().ok();
            panic!("cubeforge {args:?} still ran after {HANG:?}: it blocked");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    Output {
        status,
        stdout: out.join().unwrap(),
        stderr: err.join().unwrap(),
    }
}

/// Makes a FIFO at `path`.
pub(crate) fn mkfifo(path: &Path) {
    let c = CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a NUL-terminated path that outlives the call.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0, "mkfifo");
}

/// Whether `path` itself (not followed) is still a FIFO.
pub(crate) fn is_fifo(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_fifo())
}

fn convert<'a>(out: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["convert", SKY_EXR, "-o", out, "--size", "8"];
    a.extend_from_slice(extra);
    a
}

#[test]
fn an_output_that_is_a_fifo_is_refused_and_left_a_fifo() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    mkfifo(&d.join("pipe.ktx2"));
    std::os::unix::fs::symlink("pipe.ktx2", d.join("link.ktx2")).unwrap();
    for out in ["pipe.ktx2", "link.ktx2"] {
        refused(
            &run_within(d, &convert(out, &[])),
            &[out, "is a FIFO, not a regular file", "regular files only"],
        );
    }
    // A FIFO where a face goes.
    std::fs::create_dir(d.join("faces")).unwrap();
    mkfifo(&d.join("faces/px.exr"));
    refused(
        &run_within(d, &convert("faces", &["--to", "faces"])),
        &["faces", "FIFO"],
    );
    assert!(is_fifo(&d.join("pipe.ktx2")));
    assert!(is_fifo(&d.join("faces/px.exr")));
    assert!(std::fs::symlink_metadata(d.join("link.ktx2"))
        .unwrap()
        .file_type()
        .is_symlink());
}

#[test]
fn two_outputs_of_one_command_are_never_one_file() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let o = run_within(
        d,
        &[
            "irradiance",
            SKY_EXR,
            "-o",
            "irr.exr",
            "--size",
            "8",
            "--sh",
            "./irr.exr",
        ],
    );
    refused(&o, &["another output of this command"]);
    assert!(!d.join("irr.exr").exists());
}
