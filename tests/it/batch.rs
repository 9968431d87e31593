//! `cubeforge batch` (first slice): a manifest's jobs run as their command lines would, with
//! paths relative to the manifest; a failing job leaves the others whole and the exit status
//! non-zero; manifest errors name their line.

use crate::cli_options::{err, run, run_ok};

const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

#[test]
fn a_manifest_runs_each_job_as_its_command_line() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    std::fs::create_dir_all(d.join("proj/hdri")).unwrap();
    for name in ["a.exr", "b.exr"] {
        std::fs::copy(SKY_EXR, d.join("proj/hdri").join(name)).unwrap();
    }
    std::fs::write(
        d.join("proj/m.toml"),
        r#"
[[job]]
inputs = ["hdri/*.exr"]
command = "convert"
args = ["--size", "16"]
output = "build/{stem}/cross.exr"

[[job]]
inputs = ["hdri/a.exr", "hdri/missing.exr"]
command = "prefilter"
args = ["--filter", "box", "--size", "16"]
output = "build/{stem}/box.ktx2"
"#,
    )
    .unwrap();
    let o = run(&["batch", "proj/m.toml"], d);
    assert_eq!(o.status.code(), Some(1), "{}", err(&o));
    assert!(
        err(&o).contains("line 10: cubeforge prefilter hdri/missing.exr"),
        "{}",
        err(&o)
    );
    assert!(err(&o).contains("1 of 4 jobs failed"), "{}", err(&o));
    // The same bytes as the single commands.
    run_ok(
        &["convert", "proj/hdri/b.exr", "-o", "b.exr", "--size", "16"],
        d,
    );
    run_ok(
        &[
            "prefilter",
            "proj/hdri/a.exr",
            "-o",
            "a.ktx2",
            "--filter",
            "box",
            "--size",
            "16",
        ],
        d,
    );
    let read = |p: &str| std::fs::read(d.join(p)).unwrap();
    assert_eq!(read("proj/build/b/cross.exr"), read("b.exr"));
    assert_eq!(read("proj/build/a/box.ktx2"), read("a.ktx2"));
    assert!(d.join("proj/build/a/cross.exr").is_file());
    // --dry-run lists the command lines and writes nothing.
    let o = run_ok(&["batch", "proj/m.toml", "--dry-run"], d);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_eq!(text.lines().count(), 4, "{text}");
    assert!(
        text.contains("cubeforge convert hdri/a.exr -o build/a/cross.exr --size 16"),
        "{text}"
    );
}

#[test]
fn manifest_errors_name_their_line() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    for (text, needle) in [
        (
            "[[job]]\ninputs = [\"x\"]\ncomand = \"convert\"\n",
            "line 3: unknown field `comand`",
        ),
        (
            "[[job]]\ninputs = [\"x\"]\ncommand = \"info\"\noutput = \"o\"\n",
            "line 3: command \"info\": use one of convert",
        ),
        (
            "[[job]]\ninputs = [\"none/*.exr\"]\ncommand = \"convert\"\noutput = \"o\"\n",
            "line 2: no input matches",
        ),
    ] {
        std::fs::write(d.join("m.toml"), text).unwrap();
        let o = run(&["batch", "m.toml"], d);
        assert_eq!(o.status.code(), Some(1));
        assert!(err(&o).contains(needle), "{}", err(&o));
        assert_eq!(err(&o).lines().count(), 1, "{}", err(&o));
    }
}
