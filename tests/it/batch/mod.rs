//! `cubeforge batch` (issue 29): a manifest's jobs run as their command lines would (the same
//! bytes), with paths relative to the manifest; a rerun does only what changed, by the bytes
//! each job read; a failing job leaves the others whole and the exit status non-zero;
//! manifest errors name their line; depfiles list exactly what was read; the emitted
//! build.ninja runs under real Ninja; shards split the jobs with no overlap.

mod cache;
mod incremental;
mod k8s;
pub(crate) mod nginx;
mod reapi;
mod runners;
mod slurm;

use crate::cli_options::{err, run, run_ok};
use std::path::Path;

pub(crate) const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");
pub(crate) const SKY_PNG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");

/// `d/proj/hdri/NAME` for each of `names`, each a copy of the bundled sky.
pub(crate) fn skies(d: &Path, names: &[&str]) {
    std::fs::create_dir_all(d.join("proj/hdri")).unwrap();
    for name in names {
        std::fs::copy(SKY_EXR, d.join("proj/hdri").join(name)).unwrap();
    }
}

/// The test project under `d/proj`: three panoramas (hdri/a, b, c.exr), a decal, a recipe
/// that names a mask, and a manifest of seven jobs: a box chain and a decal preview of each
/// panorama, and the control map.
pub(crate) fn project(d: &Path) {
    let p = d.join("proj");
    skies(d, &["a.exr", "b.exr", "c.exr"]);
    std::fs::create_dir_all(p.join("masks")).unwrap();
    std::fs::copy(SKY_PNG, p.join("decal.png")).unwrap();
    std::fs::copy(SKY_PNG, p.join("masks/m.png")).unwrap();
    std::fs::write(
        p.join("r.toml"),
        "size = \"16x16\"\n[reflectivity]\nimage = { path = \"masks/m.png\", channel = \"r\" }\n",
    )
    .unwrap();
    std::fs::write(
        p.join("m.toml"),
        r#"
[[job]]
inputs = ["hdri/*.exr"]
command = "prefilter"
args = ["--filter", "box", "--size", "16"]
output = "build/{stem}/box.ktx2"

[[job]]
inputs = ["hdri/*.exr"]
command = "preview"
args = ["--size", "24", "--decal", "decal.png", "--material", "mirror-decal"]
output = "build/{stem}/preview.png"

[[job]]
inputs = ["r.toml"]
command = "control"
output = "build/control.png"
"#,
    )
    .unwrap();
}

/// The command lines (after `cubeforge`) a batch's standard output says it ran.
/// Every file under `dir`, relative and sorted, with its bytes: two builds compared whole.
pub(crate) fn contents(dir: &Path) -> Vec<(String, Vec<u8>)> {
    crate::tree::tree(dir)
        .into_iter()
        .filter(|rel| dir.join(rel).is_file())
        .map(|rel| {
            let bytes = std::fs::read(dir.join(&rel)).unwrap();
            (rel, bytes)
        })
        .collect()
}

pub(crate) fn ran(o: &std::process::Output) -> Vec<String> {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| l.strip_prefix("ran "))
        .map(|l| {
            let l = l.trim_start().trim_start_matches("cubeforge ");
            l[..l.rfind(" (").unwrap_or(l.len())].to_owned()
        })
        .collect()
}

#[test]
fn a_manifest_runs_each_job_as_its_command_line() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d, &["a.exr", "b.exr"]);
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

[[job]]
inputs = ["hdri/b.exr"]
command = "ibl"
args = ["--target", "gltf", "--samples", "4"]
output = "build/{stem}/gltf"

[[job]]
command = "lut"
args = ["--size", "16"]
output = "build/lut.png"
"#,
    )
    .unwrap();
    let o = run(&["batch", "proj/m.toml"], d);
    assert_eq!(o.status.code(), Some(1), "{}", err(&o));
    let e = err(&o);
    assert!(
        e.contains("failed: line 10: cubeforge prefilter hdri/missing.exr"),
        "{e}"
    );
    assert!(e.contains("1 of 6 jobs failed"), "{e}");
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains("batch: 6 jobs: 5 ran, 0 up to date, 1 failed"),
        "{text}"
    );
    // The others' outputs are whole: the same bytes as the single commands.
    let single: [&[&str]; 4] = [
        &["convert", "proj/hdri/b.exr", "-o", "b.exr", "--size", "16"],
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
        &[
            "ibl",
            "proj/hdri/b.exr",
            "-o",
            "gltf",
            "--target",
            "gltf",
            "--samples",
            "4",
        ],
        &["lut", "-o", "lut.png", "--size", "16"],
    ];
    for args in single {
        run_ok(args, d);
    }
    let read = |p: &str| std::fs::read(d.join(p)).unwrap();
    assert_eq!(read("proj/build/b/cross.exr"), read("b.exr"));
    assert_eq!(read("proj/build/a/box.ktx2"), read("a.ktx2"));
    assert_eq!(read("proj/build/lut.png"), read("lut.png"));
    for f in ["env_ggx.ktx2", "env_lambertian.ktx2", "lut_ggx.png"] {
        assert_eq!(
            read(&format!("proj/build/b/gltf/{f}")),
            read(&format!("gltf/{f}")),
            "{f}"
        );
    }
    assert!(d.join("proj/build/a/cross.exr").is_file());
    assert!(!d.join("proj/build/missing").exists());
    // --dry-run says what would run, and why, and writes nothing: only the failed job.
    let o = run_ok(&["batch", "proj/m.toml", "--dry-run"], d);
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains(
            "would run   cubeforge prefilter hdri/missing.exr -o build/missing/box.ktx2 --filter \
             box --size 16 (no record of a run with these options)"
        ),
        "{text}"
    );
    assert!(
        text.contains("batch: 6 jobs: 1 would run, 5 up to date"),
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
        (
            "[[job]]\ninputs = [\"a.exr\"]\ncommand = \"convert\"\nargs = [\"-o\", \"x\"]\noutput = \"o\"\n",
            "line 3: the output goes in `output`",
        ),
        (
            "[[job]]\ninputs = [\"a.exr\", \"a.exr\"]\ncommand = \"convert\"\noutput = \"o.exr\"\n",
            "two jobs are one: convert a.exr -o o.exr",
        ),
        (
            "[[job]]\ninputs = [\"a.exr\", \"b.exr\"]\ncommand = \"convert\"\noutput = \"o.exr\"\n",
            "two jobs write o.exr",
        ),
    ] {
        std::fs::write(d.join("m.toml"), text).unwrap();
        let o = run(&["batch", "m.toml"], d);
        assert_eq!(o.status.code(), Some(1));
        assert!(err(&o).contains(needle), "{}", err(&o));
        assert_eq!(err(&o).lines().count(), 1, "{}", err(&o));
    }
}

/// A job's warnings in a batch name the flags the manifest's args take (`--tonemap`), as the
/// command line's do, not the library's fields (`` `tonemap` ``).
#[test]
fn batch_warnings_name_flags() {
    let d = tempfile::tempdir().unwrap();
    skies(d.path(), &["a.exr"]);
    std::fs::write(
        d.path().join("proj/m.toml"),
        "[[job]]\ninputs = [\"hdri/a.exr\"]\ncommand = \"convert\"\n\
         args = [\"--tonemap\", \"aces\", \"--size\", \"8\"]\noutput = \"o/{stem}.exr\"\n",
    )
    .unwrap();
    let o = run_ok(&["batch", "m.toml"], &d.path().join("proj"));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("--tonemap applies to 8-bit outputs"), "{e}");
    assert!(!e.contains('`'), "{e}");
}
