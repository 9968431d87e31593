//! Item 9: depfiles that GNU Make and Ninja (`deps = gcc`) both read back as the files that
//! were read, or none: a name one of them cannot read back is refused, the depfile is not
//! written and the command fails with one line naming the file.

use super::{cubeforge, found, ok, skies, stderr, stdout, within, SKY_EXR};
use cubeforge::internals::output::depfile;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, SystemTime};

/// Names both read back once escaped.
const HELD: &[&str] = &[
    "sky 12:30.exr",
    "a#b.exr",
    "$x.exr",
    "$(y) z.exr",
    "100%.exr",
    "sky (1).exr",
    "(x).exr",
    "$(y).exr",
    "a[b.exr",
    "a]b.exr",
    "{dir}.exr",
    "-o.exr",
    "é ü.exr",
    "a!b@c,d+e.exr",
    "x~y.exr",
    " lead.exr",
    "12:30/in:dir.exr",
];

/// Names one of them cannot read back.
const REFUSED: &[&str] = &[
    "a;b.exr",
    "a|b.exr",
    "a`b.exr",
    "a'b.exr",
    "a\"b.exr",
    "a&b.exr",
    "a*b.exr",
    "a?b.exr",
    "a<b.exr",
    "a>b.exr",
    "a^b.exr",
    "a=b.exr",
    "a\tb.exr",
    "a\nb.exr",
    "a\rb.exr",
    "a\x1bb.exr",
    "a\\b.exr",
    "ab\\",
    "~x.exr",
    "trailing ",
    "colon:",
    "x(1)",
    "a[1]b.exr",
];

fn set_time(p: &Path, t: SystemTime) {
    let f = std::fs::File::options().write(true).open(p).unwrap();
    f.set_modified(t).unwrap();
}

#[test]
fn make_and_ninja_read_a_depfile_back_as_the_files_read() {
    for n in REFUSED {
        let e = depfile::text(Path::new("out"), &[PathBuf::from(n)]).unwrap_err();
        assert!(
            e.to_string().contains("a depfile cannot name this file ("),
            "{n:?}: {e}"
        );
    }
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let names: Vec<PathBuf> = HELD.iter().map(PathBuf::from).collect();
    let old = SystemTime::now() - Duration::from_secs(3600);
    for n in &names {
        if let Some(p) = n.parent() {
            std::fs::create_dir_all(d.join(p)).unwrap();
        }
        std::fs::write(d.join(n), "x").unwrap();
        set_time(&d.join(n), old);
    }
    let text = depfile::text(Path::new("out"), &names).unwrap();
    std::fs::write(d.join("deps.txt"), &text).unwrap();
    if found("make", "make") {
        std::fs::write(d.join("Makefile"), "out:\n\t@touch out\n-include out.d\n").unwrap();
        std::fs::write(d.join("out.d"), &text).unwrap();
        std::fs::write(d.join("out"), "x").unwrap();
        let q = || {
            let mut c = Command::new("make");
            c.args(["-q", "out"]).current_dir(d);
            within(c, 30)
        };
        let o = q();
        assert_eq!(o.status.code(), Some(0), "{}{text}", stderr(&o));
        // Each name is the file Make watches: newer, and the target is out of date.
        for n in &names {
            set_time(&d.join(n), SystemTime::now() + Duration::from_secs(60));
            let o = q();
            assert_eq!(o.status.code(), Some(1), "{n:?}: {}", stderr(&o));
            set_time(&d.join(n), old);
        }
    }
    if found("ninja", "ninja-build") {
        std::fs::write(
            d.join("build.ninja"),
            "rule r\n  command = cp deps.txt $out.d && touch $out\n  depfile = $out.d\n  \
             deps = gcc\nbuild out2: r\n",
        )
        .unwrap();
        let ninja = |args: &[&str]| {
            let mut c = Command::new("ninja");
            c.args(args).current_dir(d);
            ok(within(c, 30))
        };
        ninja(&[]);
        let deps = stdout(&ninja(&["-t", "deps", "out2"]));
        let read: Vec<&str> = deps
            .lines()
            .filter_map(|l| l.strip_prefix("    "))
            .collect();
        assert_eq!(read, HELD, "{deps}");
        assert!(stdout(&ninja(&[])).contains("no work to do"));
    }
}

#[test]
fn a_depfile_that_cannot_name_a_file_read_fails_its_command() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d, &["a;b.exr", "sky.exr"]);
    // The input: one line naming it; the output is whole but no depfile is written.
    let o = cubeforge(
        &[
            "prefilter",
            "a;b.exr",
            "-o",
            "o.ktx2",
            "--filter",
            "box",
            "--size",
            "8",
        ]
        .iter()
        .chain(&["--depfile", "o.ktx2.d"])
        .copied()
        .collect::<Vec<_>>(),
        d,
    );
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.contains("a;b.exr: a depfile cannot name this file (Ninja ends a name at `;`)"),
        "{e}"
    );
    assert!(!d.join("o.ktx2.d").exists());
    // The target: `%` is a pattern to Make.
    let o = cubeforge(
        &["prefilter", "sky.exr", "-o", "100%.ktx2", "--filter", "box"]
            .iter()
            .chain(&["--size", "8", "--depfile", "p.d"])
            .copied()
            .collect::<Vec<_>>(),
        d,
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains(
            "100%.ktx2: a depfile cannot name this file (Make reads `%` in a target as a pattern)"
        ),
        "{}",
        stderr(&o)
    );
    assert!(!d.join("p.d").exists());
    // In a batch, a file the job reads that its name does not say (a decal): that job fails
    // with one line, and the others write their depfiles.
    std::fs::copy(SKY_EXR.replace("sky.exr", "sky.png"), d.join("d;x.png")).unwrap();
    std::fs::write(
        d.join("m.toml"),
        "[[job]]\ninputs = [\"sky.exr\"]\ncommand = \"preview\"\n\
         args = [\"--size\", \"16\", \"--decal\", \"d;x.png\", \"--material\", \"mirror-decal\"]\n\
         output = \"build/{stem}.png\"\n\n\
         [[job]]\ninputs = [\"sky.exr\"]\ncommand = \"prefilter\"\n\
         args = [\"--filter\", \"box\", \"--size\", \"8\"]\noutput = \"build/{stem}.ktx2\"\n",
    )
    .unwrap();
    let o = cubeforge(&["batch", "m.toml", "--depfiles"], d);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    let failed: Vec<&str> = e.lines().filter(|l| l.contains("failed: line")).collect();
    assert_eq!(failed.len(), 1, "{e}");
    assert!(
        failed[0].starts_with("cubeforge: batch: failed: line 3: cubeforge preview sky.exr")
            && failed[0].contains("d;x.png: a depfile cannot name this file"),
        "{e}"
    );
    assert!(!d.join("build/sky.png.d").exists());
    assert_eq!(
        std::fs::read_to_string(d.join("build/sky.ktx2.d")).unwrap(),
        "build/sky.ktx2: \\\n  sky.exr\n"
    );
}
