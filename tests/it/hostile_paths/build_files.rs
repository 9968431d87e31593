//! Issue 44, build files: file names that become build.ninja lines, depfiles, output paths
//! and command lines. The acceptance test is here: a folder of hostile names builds alike
//! under `cubeforge batch`, under Ninja on the emitted file and under Make with the
//! depfiles, and no command but cubeforge runs. Each item's own tests are in the children.

mod depfiles;
mod globs;
mod ninja;
mod planning;

use super::within;
use cubeforge::internals::output::depfile;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, SystemTime};

pub(super) const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");
pub(super) const CUBEFORGE: &str = env!("CARGO_BIN_EXE_cubeforge");

/// `cubeforge ARGS` in `dir`, killed after a minute.
pub(super) fn cubeforge(args: &[&str], dir: &Path) -> Output {
    let mut c = Command::new(CUBEFORGE);
    c.args(args).current_dir(dir);
    within(c, 60)
}

pub(super) fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

pub(super) fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// `o`, which must have succeeded.
pub(super) fn ok(o: Output) -> Output {
    assert!(o.status.success(), "{}{}", stdout(&o), stderr(&o));
    o
}

/// Whether `tool --version` runs; where it does not, a skip line (a failure under CI).
pub(super) fn found(tool: &str, package: &str) -> bool {
    let runs = Command::new(tool)
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok();
    crate::common::reader_found(tool, &format!("apt-get install {package}"), runs)
}

/// A copy of the bundled sky as each of `names` in `dir`.
pub(super) fn skies(dir: &Path, names: &[&str]) {
    std::fs::create_dir_all(dir).unwrap();
    for n in names {
        std::fs::copy(SKY_EXR, dir.join(n)).unwrap_or_else(|e| panic!("{n:?}: {e}"));
    }
}

/// `s` as a TOML basic string.
pub(super) fn toml_str(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if c.is_control() => out.push_str(&format!("\\u{:04X}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// Fails when a file named PWNED (the canary that hostile names try to create) is anywhere
/// under `root`.
pub(super) fn no_canary(root: &Path) {
    let mut todo = vec![root.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            assert_ne!(e.file_name(), "PWNED", "a command other than cubeforge ran");
            if e.file_type().unwrap().is_dir() {
                todo.push(e.path());
            }
        }
    }
}

/// Sets `p`'s time `secs` seconds ahead: it is newer than anything built.
pub(super) fn touch_ahead(p: &Path, secs: u64) {
    let f = std::fs::File::options().write(true).open(p).unwrap();
    f.set_modified(SystemTime::now() + Duration::from_secs(secs))
        .unwrap();
}

/// The names the acceptance test puts in its folder: those that build, and those that no
/// build file can hold (left out of every plan with one warning each).
const BUILT: &[&str] = &[
    "sky.exr",
    "sky 12:30.exr",
    "$(touch PWNED).exr",
    "$HOME.exr",
    "{dir}.exr",
    "-o.exr",
    "--help.exr",
    "a#b.exr",
    "sky (1).exr",
];
const LEFT_OUT: &[&str] = &[
    "p\ncubeforge = touch PWNED #.exr",
    "a|b.exr",
    "a;touch PWNED.exr",
    "x`touch PWNED`.exr",
    "...exr",
    "..exr",
    "e\x1b[31mred.exr",
    "100%.exr",
    "x=y.exr",
    "~tilde.exr",
];

const MANIFEST: &str = r#"[[job]]
inputs = ["*.exr"]
command = "prefilter"
args = ["--filter", "box", "--size", "8"]
output = "build/{stem}.ktx2"
"#;

/// A project folder `dir` of every name above and the manifest `m.toml`.
fn hostile_project(dir: &Path) {
    skies(dir, BUILT);
    skies(dir, LEFT_OUT);
    std::fs::write(dir.join("m.toml"), MANIFEST).unwrap();
}

/// Each built name's input as its command line names it, and its output.
fn jobs() -> Vec<(String, String)> {
    BUILT
        .iter()
        .map(|n| {
            let input = if n.starts_with('-') {
                format!("./{n}")
            } else {
                n.to_string()
            };
            (input, format!("build/{}.ktx2", n.trim_end_matches(".exr")))
        })
        .collect()
}

/// The files under `dir/build`, sorted, with their bytes.
fn built(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<_> = std::fs::read_dir(dir.join("build"))
        .unwrap()
        .flatten()
        .map(|e| (e.path().strip_prefix(dir).unwrap().to_path_buf(), e.path()))
        .map(|(name, p)| (name, std::fs::read(p).unwrap()))
        .collect();
    v.sort();
    v
}

/// The left-out warnings of a plan of the hostile project: one line each, escaped.
fn assert_left_out_told(o: &Output) {
    let e = stderr(o);
    assert!(!e.contains('\x1b'), "{e}");
    let told: Vec<&str> = e.lines().filter(|l| l.contains("left out")).collect();
    assert_eq!(told.len(), LEFT_OUT.len(), "{e}");
    for n in LEFT_OUT {
        let shown = cubeforge::internals::error::escape_text(n).into_owned();
        assert!(
            told.iter().any(
                |l| l.starts_with("cubeforge: warning: m.toml: line 2: left out ")
                    && l.contains(&shown)
            ),
            "{n:?} not told: {e}"
        );
    }
}

#[test]
fn a_folder_of_hostile_names_builds_alike_under_batch_ninja_and_make() {
    let t = tempfile::tempdir().unwrap();
    let root = t.path();
    let (b, n, m) = (root.join("batch"), root.join("ninja"), root.join("make"));
    for d in [&b, &n, &m] {
        hostile_project(d);
    }
    // cubeforge batch: the names that can be held build, each other one is told once.
    let o = ok(cubeforge(&["batch", "m.toml", "--depfiles"], &b));
    assert_left_out_told(&o);
    assert!(!stdout(&o).contains('\x1b'));
    assert!(
        stdout(&o).contains(&format!("batch: {} jobs: {} ran", BUILT.len(), BUILT.len())),
        "{}",
        stdout(&o)
    );
    let want = built(&b);
    let mut names: Vec<PathBuf> = jobs()
        .iter()
        .flat_map(|(_, out)| {
            // Each chain, its depfile and its levels description.
            ["", ".d", ".levels.json"].map(|s| PathBuf::from(format!("{out}{s}")))
        })
        .collect();
    names.sort();
    assert_eq!(
        want.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>(),
        names
    );
    no_canary(root);

    if found("ninja", "ninja-build") {
        let o = ok(cubeforge(&["batch", "m.toml", "--emit", "ninja"], &n));
        assert_left_out_told(&o);
        let text = std::fs::read_to_string(n.join("build.ninja")).unwrap();
        assert!(!text.contains("PWNED #"), "{text}");
        let ninja = |args: &[&str]| {
            let mut c = Command::new("ninja");
            c.args(args).current_dir(&n);
            ok(within(c, 120))
        };
        ninja(&["-j", "2"]);
        // The same bytes as batch's (Ninja reads the depfiles into its log and deletes them).
        let ktx2 = |v: Vec<(PathBuf, Vec<u8>)>| {
            v.into_iter()
                .filter(|(p, _)| p.extension().is_some_and(|e| e == "ktx2"))
                .collect::<Vec<_>>()
        };
        assert_eq!(ktx2(built(&n)), ktx2(want.clone()));
        // Every depfile read back as the files read: nothing dirty for ever.
        assert!(stdout(&ninja(&[])).contains("no work to do"));
        touch_ahead(&n.join("sky 12:30.exr"), 10);
        let again = stdout(&ninja(&["-n"]));
        assert!(
            again.contains("[1/1] cubeforge prefilter 'sky 12:30.exr'"),
            "{again}"
        );
        no_canary(root);
    }

    if found("make", "make") {
        make_builds_alike(&m, &want);
        no_canary(root);
    }
}

/// Make, with a rule per job (its first line a depfile's, from the library) and the
/// depfiles the commands write included: the same outputs as batch's `want`, up to date on
/// the next run, and one job again when one input is newer.
fn make_builds_alike(m: &Path, want: &[(PathBuf, Vec<u8>)]) {
    let quote = |s: &str| format!("'{}'", s.replace('$', "$$"));
    let mut mk = String::from("all:");
    let mut rules = String::new();
    for (input, out) in jobs() {
        mk.push(' ');
        mk.push_str(&depfile::escape(Path::new(&out), false).unwrap());
        let rule = depfile::text(Path::new(&out), &[PathBuf::from(&input)]).unwrap();
        rules.push_str(&format!(
            "{rule}\t{} -q prefilter {} -o {} --filter box --size 8 --depfile {}\n",
            quote(CUBEFORGE),
            quote(&input),
            quote(&out),
            quote(&format!("{out}.d"))
        ));
    }
    mk.push('\n');
    mk.push_str(&rules);
    mk.push_str("-include deps.mk\n");
    std::fs::write(m.join("Makefile"), mk).unwrap();
    let make = |args: &[&str]| {
        let mut c = Command::new("make");
        c.args(args).current_dir(m);
        within(c, 120)
    };
    ok(make(&[]));
    assert_eq!(built(m), want, "make's outputs and depfiles are batch's");
    // Make reads the depfiles back: every file they name is the one read.
    let mut deps = String::new();
    for (_, out) in jobs() {
        deps.push_str(&std::fs::read_to_string(m.join(format!("{out}.d"))).unwrap());
    }
    std::fs::write(m.join("deps.mk"), deps).unwrap();
    let q = make(&["-q"]);
    assert_eq!(q.status.code(), Some(0), "{}{}", stdout(&q), stderr(&q));
    touch_ahead(&m.join("$(touch PWNED).exr"), 10);
    let q = make(&["-q"]);
    assert_eq!(q.status.code(), Some(1), "{}", stderr(&q));
    let n = ok(make(&["-n"]));
    let runs: Vec<String> = stdout(&n)
        .lines()
        .filter(|l| l.contains("prefilter"))
        .map(str::to_owned)
        .collect();
    assert_eq!(runs.len(), 1, "{runs:?}");
    assert!(runs[0].contains("'$(touch PWNED).exr'"), "{runs:?}");
}

/// A plain batch writes no build file, so the names only Make or Ninja cannot hold run there
/// (`...exr` and `..exr` still name no output of their own); no command but cubeforge runs.
#[test]
fn a_plain_batch_runs_the_names_only_build_files_cannot_hold() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    hostile_project(d);
    skies(d, &["Tom's sky.exr"]);
    let o = ok(cubeforge(&["batch", "m.toml"], d));
    let runs = BUILT.len() + LEFT_OUT.len() + 1 - 2;
    assert!(
        stdout(&o).contains(&format!("batch: {runs} jobs: {runs} ran")),
        "{}",
        stdout(&o)
    );
    let e = stderr(&o);
    assert_eq!(
        e.lines().filter(|l| l.contains("left out")).count(),
        2,
        "{e}"
    );
    for name in [
        "a|b",
        "a;touch PWNED",
        "Tom's sky",
        "x=y",
        "p\ncubeforge = touch PWNED #",
    ] {
        assert!(d.join(format!("build/{name}.ktx2")).is_file(), "{name:?}");
    }
    no_canary(d);
}
