//! Issue 44, items 2, 4, 6 and 7: outputs that cannot be turned against the user. A FIFO or a
//! device named as an output or a depfile is refused and left as it was (never replaced by a
//! regular file); a depfile never lands on the command's output, a file of its output
//! folder or its `--sh` file; two outputs of one command are never one file. The batch's
//! cases (state files and records naming FIFOs, jobs that write each other's files) are in
//! `batch.rs`. Every run that could block on a FIFO is killed after a timeout, failing the
//! test.

mod batch;

use crate::fault_campaign::{ok, refused, BIN};
use std::ffi::CString;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::{Command, Output};
use std::time::Duration;

pub(crate) const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

/// A run that blocks longer than this is a hang: the test kills it and fails.
const HANG: Duration = Duration::from_secs(60);

/// Runs cubeforge in `dir`, killed and the test failed if it runs past [`HANG`] (blocked on a
/// FIFO, say).
pub(crate) fn run_within(dir: &Path, args: &[&str]) -> Output {
    let mut c = Command::new(BIN);
    c.args(args).current_dir(dir);
    super::within(c, HANG.as_secs())
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

/// A character device like `/dev/null` (1, 3) at `path`, when the tests run as root (None:
/// they do not, and cannot make one).
fn null_device(path: &Path) -> Option<()> {
    let c = CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a NUL-terminated path that outlives the call.
    let r = unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) };
    (r == 0).then_some(())
}

/// Every entry under `dir` (links not followed) with a regular file's bytes: equal before and
/// after a refused run when nothing was written.
pub(crate) fn snapshot(dir: &Path) -> Vec<(String, Option<Vec<u8>>)> {
    fn walk(d: &Path, root: &Path, out: &mut Vec<(String, Option<Vec<u8>>)>) {
        for e in std::fs::read_dir(d).unwrap().flatten() {
            let p = e.path();
            let t = e.file_type().unwrap();
            let bytes = t.is_file().then(|| std::fs::read(&p).unwrap());
            out.push((p.strip_prefix(root).unwrap().display().to_string(), bytes));
            if t.is_dir() {
                walk(&p, root, out);
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
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
fn a_depfile_that_is_a_fifo_or_a_device_is_refused_before_the_work() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    mkfifo(&d.join("pipe.d"));
    std::os::unix::fs::symlink("pipe.d", d.join("link.d")).unwrap();
    let mut nodes = vec![("pipe.d", "is a FIFO"), ("link.d", "is a FIFO")];
    if null_device(&d.join("null")).is_some() {
        nodes.push(("null", "is a character device"));
    }
    for (node, what) in &nodes {
        refused(
            &run_within(d, &convert("o.ktx2", &["--depfile", node])),
            &[node, what, "not a regular file"],
        );
        assert!(!d.join("o.ktx2").exists(), "refused before the work");
    }
    assert!(is_fifo(&d.join("pipe.d")));
    if nodes.len() == 3 {
        let m = std::fs::metadata(d.join("null")).unwrap();
        assert!(m.file_type().is_char_device(), "still a device");
    }
}

#[test]
fn a_depfile_never_overwrites_an_output() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    std::fs::create_dir(d.join("sub")).unwrap();
    // The output itself, however spelled: refused before the work, the old output kept.
    ok(&run_within(d, &convert("o.ktx2", &[])));
    let before = std::fs::read(d.join("o.ktx2")).unwrap();
    for dep in ["o.ktx2", "./o.ktx2", "sub/../o.ktx2"] {
        refused(
            &run_within(d, &convert("o.ktx2", &["--depfile", dep])),
            &[dep, "is the command's output"],
        );
    }
    assert_eq!(std::fs::read(d.join("o.ktx2")).unwrap(), before);
    // A face of a faces folder, and a file of an ibl folder: inside the output.
    ok(&run_within(d, &convert("faces", &["--to", "faces"])));
    let ibl = [
        "ibl",
        SKY_EXR,
        "-o",
        "gl",
        "--target",
        "gltf",
        "--samples",
        "4",
        "--size",
        "16",
    ];
    ok(&run_within(d, &ibl));
    let faces = snapshot(&d.join("faces"));
    let gl = std::fs::read(d.join("gl/env_ggx.ktx2")).unwrap();
    refused(
        &run_within(
            d,
            &convert("faces", &["--to", "faces", "--depfile", "faces/px.exr"]),
        ),
        &["faces/px.exr", "inside the output folder faces"],
    );
    let mut with_dep = ibl.to_vec();
    with_dep.extend(["--depfile", "sub/../gl/env_ggx.ktx2"]);
    refused(&run_within(d, &with_dep), &["inside the output folder gl"]);
    assert_eq!(snapshot(&d.join("faces")), faces);
    assert!(
        cubeforge::internals::convert::read(&d.join("faces/px.exr"), &Default::default()).is_ok()
    );
    assert_eq!(std::fs::read(d.join("gl/env_ggx.ktx2")).unwrap(), gl);
    // The --sh file, which only the run names: the depfile is refused, the file whole.
    let irr = |dep: &str| {
        run_within(
            d,
            &[
                "irradiance",
                SKY_EXR,
                "-o",
                "irr.exr",
                "--size",
                "8",
                "--sh",
                "sh.json",
                "--depfile",
                dep,
            ],
        )
    };
    refused(&irr("sub/../sh.json"), &["is a file the command wrote"]);
    let sh: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("sh.json")).unwrap()).unwrap();
    assert!(sh.get("bands").is_some(), "{sh}");
    // An input named as the depfile stays refused, and whole.
    std::fs::copy(SKY_EXR, d.join("in.exr")).unwrap();
    let o = run_within(
        d,
        &[
            "convert",
            "in.exr",
            "-o",
            "x.ktx2",
            "--size",
            "8",
            "--depfile",
            "in.exr",
        ],
    );
    refused(&o, &["refusing to overwrite an input file"]);
    assert_eq!(
        std::fs::read(d.join("in.exr")).unwrap(),
        std::fs::read(SKY_EXR).unwrap()
    );
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
