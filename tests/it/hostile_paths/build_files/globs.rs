//! Item 5: file names that steered outputs (`...exr` has the stem `..`; a name holding
//! `{dir}` was filled again) and `**` globs that followed symlinked folders into loops.

use super::{cubeforge, ok, skies, stderr, stdout};
use std::path::Path;

fn table(inputs: &str, output: &str) -> String {
    format!(
        "[[job]]\ninputs = [{inputs}]\ncommand = \"prefilter\"\n\
         args = [\"--filter\", \"box\", \"--size\", \"8\"]\noutput = \"{output}\"\n"
    )
}

/// Every file under `dir`, relative to it, sorted.
fn files(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            if e.file_type().unwrap().is_dir() {
                todo.push(e.path());
            } else {
                let p = e.path();
                out.push(p.strip_prefix(dir).unwrap().display().to_string());
            }
        }
    }
    out.sort();
    out
}

/// A one-line error naming the manifest's line, and nothing written.
fn refused(d: &Path, manifest: &str, line: usize, says: &str) {
    std::fs::write(d.join("m.toml"), manifest).unwrap();
    let before = files(d);
    let o = cubeforge(&["batch", "m.toml"], d);
    assert_eq!(o.status.code(), Some(1), "{manifest}");
    let e = stderr(&o);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.starts_with(&format!("cubeforge: error: m.toml: line {line}: ")) && e.contains(says),
        "{manifest}: {e}"
    );
    assert_eq!(files(d), before);
}

#[test]
fn a_file_name_never_steers_an_output() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(&d.join("in"), &["...exr", "..exr", "sky.exr", "{dir}.exr"]);
    std::fs::write(
        d.join("m.toml"),
        table("\"in/*.exr\"", "build/{stem}/x.ktx2")
            + "\n"
            + &table("\"in/*.exr\"", "build/{dir}/{stem}.ktx2"),
    )
    .unwrap();
    let o = ok(cubeforge(&["batch", "m.toml"], d));
    let e = stderr(&o);
    // Each left out, told once (though two tables match it), with why.
    for (name, stem) in [("in/...exr", ".."), ("in/..exr", ".")] {
        let told = format!(
            "cubeforge: warning: m.toml: line 2: left out {name}: its stem is \"{stem}\", \
             which names no output of its own"
        );
        assert!(e.lines().any(|l| l == told), "{told}\n{e}");
    }
    assert_eq!(e.lines().count(), 2, "{e}");
    // `{dir}` in a name is taken as it is: the template is filled once.
    let mut want = vec![
        "build/in/sky.ktx2",
        "build/in/sky.ktx2.levels.json",
        "build/in/{dir}.ktx2",
        "build/in/{dir}.ktx2.levels.json",
        "build/sky/x.ktx2",
        "build/sky/x.ktx2.levels.json",
        "build/{dir}/x.ktx2",
        "build/{dir}/x.ktx2.levels.json",
        "in/...exr",
        "in/..exr",
        "in/sky.exr",
        "in/{dir}.exr",
        "m.state.json",
        "m.toml",
    ];
    want.sort();
    assert_eq!(files(d), want, "{}", stdout(&o));
    // Named as it is: an error naming the file and the line.
    refused(
        d,
        &table("\"in/...exr\"", "build/{stem}/x.ktx2"),
        2,
        "in/...exr: its stem is \"..\"",
    );
    // A template that leads out of its own folder, whatever the input.
    refused(
        d,
        &table("\"in/sky.exr\"", "build/{stem}/../../x.ktx2"),
        5,
        "is not inside the template's folder \"build/\"",
    );
    // A typo of a placeholder; a placeholder with nothing to fill it.
    refused(
        d,
        &table("\"in/sky.exr\"", "build/{steam}.ktx2"),
        5,
        "unknown placeholder {steam}",
    );
    refused(
        d,
        "[[job]]\ncommand = \"lut\"\noutput = \"build/{stem}.png\"\n",
        3,
        "lut reads no input",
    );
}

#[test]
fn double_star_globs_do_not_follow_symlinked_folders() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(&d.join("in"), &["a.exr"]);
    skies(&d.join("in/sub"), &["b.exr"]);
    // A folder that links to itself, and two that link to each other.
    std::os::unix::fs::symlink(".", d.join("in/loop")).unwrap();
    std::fs::create_dir_all(d.join("in/x")).unwrap();
    std::fs::create_dir_all(d.join("in/y")).unwrap();
    std::os::unix::fs::symlink("../y", d.join("in/x/l")).unwrap();
    std::os::unix::fs::symlink("../x", d.join("in/y/l")).unwrap();
    std::fs::write(
        d.join("m.toml"),
        table("\"in/**/*.exr\"", "build/{stem}.ktx2"),
    )
    .unwrap();
    // `cubeforge` kills a run past a minute: before, planning never ended.
    let o = ok(cubeforge(&["batch", "m.toml", "--dry-run"], d));
    let out = stdout(&o);
    assert!(out.contains("batch: 2 jobs: 2 would run"), "{out}");
    assert!(
        out.contains("would run   cubeforge prefilter in/a.exr"),
        "{out}"
    );
    assert!(
        out.contains("would run   cubeforge prefilter in/sub/b.exr"),
        "{out}"
    );
    // A link the pattern names itself is followed, one level.
    std::os::unix::fs::symlink("in/sub", d.join("linked")).unwrap();
    std::fs::write(
        d.join("m.toml"),
        table("\"linked/*.exr\"", "build/{stem}.ktx2"),
    )
    .unwrap();
    let out = stdout(&ok(cubeforge(&["batch", "m.toml", "--dry-run"], d)));
    assert!(out.contains("batch: 1 jobs: 1 would run"), "{out}");
}

#[test]
fn a_name_that_is_not_utf8_is_left_out() {
    use std::os::unix::ffi::OsStrExt;
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d, &["sky.exr"]);
    let bad = std::ffi::OsStr::from_bytes(b"sky\xff.exr");
    std::fs::copy(super::SKY_EXR, d.join(bad)).unwrap();
    std::fs::write(d.join("m.toml"), table("\"*.exr\"", "build/{stem}.ktx2")).unwrap();
    let o = ok(cubeforge(&["batch", "m.toml"], d));
    let e = stderr(&o);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.starts_with(
            "cubeforge: warning: m.toml: line 2: left out sky\u{fffd}.exr: its name is not UTF-8"
        ),
        "{e}"
    );
    assert!(
        stdout(&o).contains("batch: 1 jobs: 1 ran"),
        "{}",
        stdout(&o)
    );
}
