//! Item 1: build.ninja. A line break in a name never reaches the file (it rebound
//! `$cubeforge`), `|`, space, `:` and `$` in its paths are escaped, and every word of a
//! command line reaches the command as it was, through Ninja's parser and then the shell.

use super::{cubeforge, found, no_canary, ok, skies, stderr, toml_str, within, CUBEFORGE};
use std::path::Path;
use std::process::Command;

const CANARY: &str = "p\ncubeforge = touch PWNED #.exr";

fn manifest(inputs: &str, args: &[&str]) -> String {
    let args: Vec<String> = args.iter().map(|a| toml_str(a)).collect();
    format!(
        "[[job]]\ninputs = [{inputs}]\ncommand = \"prefilter\"\nargs = [{}]\noutput = \"build/{{stem}}.ktx2\"\n",
        args.join(", ")
    )
}

fn ninja(dir: &Path, args: &[&str]) -> std::process::Output {
    let mut c = Command::new("ninja");
    c.args(args).current_dir(dir);
    within(c, 120)
}

#[test]
fn a_line_break_in_a_name_never_reaches_build_ninja() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d, &["sky.exr", CANARY]);
    let box8 = ["--filter", "box", "--size", "8"];
    // Matched by a glob: left out, with one warning naming it.
    std::fs::write(d.join("m.toml"), manifest("\"*.exr\"", &box8)).unwrap();
    let o = ok(cubeforge(&["batch", "m.toml", "--emit", "ninja"], d));
    let e = stderr(&o);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(
        e.contains("m.toml: line 2: left out p\\ncubeforge = touch PWNED #.exr: build.ninja cannot hold a line break"),
        "{e}"
    );
    let text = std::fs::read_to_string(d.join("build.ninja")).unwrap();
    assert_eq!(
        text.lines()
            .filter(|l| l.starts_with("cubeforge ="))
            .count(),
        1,
        "{text}"
    );
    assert!(!text.contains("PWNED"), "{text}");
    if found("ninja", "ninja-build") {
        ok(ninja(d, &[]));
        assert!(d.join("build/sky.ktx2").is_file());
    }
    // Named as it is: an error naming the manifest's line and the file wherever a build file
    // names it, and no build.ninja; a plain batch, which writes none, runs it.
    std::fs::remove_file(d.join("build.ninja")).unwrap();
    std::fs::write(d.join("m.toml"), manifest(&toml_str(CANARY), &box8)).unwrap();
    for extra in [&["--emit", "ninja"][..], &["--depfiles"]] {
        let o = cubeforge(&[&["batch", "m.toml"][..], extra].concat(), d);
        assert_eq!(o.status.code(), Some(1), "{extra:?}");
        let e = stderr(&o);
        assert_eq!(e.lines().count(), 1, "{e}");
        assert!(
            e.starts_with("cubeforge: error: m.toml: line 2: p\\ncubeforge = touch PWNED #.exr: build.ninja cannot hold a line break"),
            "{e}"
        );
    }
    assert!(!d.join("build.ninja").exists());
    ok(cubeforge(&["batch", "m.toml"], d));
    assert!(!d.join("PWNED").exists());
    // A line break in args: the same for build.ninja (a plain batch runs it as it is).
    let args = ["--filter", "box\ncubeforge = touch PWNED #", "--size", "8"];
    std::fs::write(d.join("m.toml"), manifest("\"sky.exr\"", &args)).unwrap();
    let o = cubeforge(&["batch", "m.toml", "--emit", "ninja"], d);
    assert_eq!(o.status.code(), Some(1));
    let e = stderr(&o);
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("m.toml: line 3: box\\ncubeforge"), "{e}");
    assert!(e.contains("cannot hold a line break"), "{e}");
    assert!(!d.join("build.ninja").exists());
    no_canary(d);
}

/// The words a hostile manifest's args hold: each must reach the command as it is.
const WORDS: &[&str] = &[
    "a;b",
    "|x",
    "&&",
    "'q'",
    "\"dq\"",
    "`touch PWNED`",
    "$(touch PWNED)",
    "$HOME",
    "${cubeforge}",
    "$",
    "$$",
    "#c",
    "tab\there",
    "%",
    "~",
    "*",
    "?",
    "<",
    ">",
    "^",
    "()",
    "{}",
    "[]",
    "\\",
    "\\n",
    "!",
    "é",
    " spaced ",
    "",
    "-",
    "--x",
    "=",
    "a=b",
    ":",
    "a:b",
    "|",
    "x y:z$w|",
];

#[test]
fn every_word_reaches_the_command_through_ninja_and_the_shell() {
    if !found("ninja", "ninja-build") {
        return;
    }
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d, &["sky.exr"]);
    std::fs::write(d.join("m.toml"), manifest("\"sky.exr\"", WORDS)).unwrap();
    ok(cubeforge(&["batch", "m.toml", "--emit", "ninja"], d));
    // The command Ninja runs, by the shell, is a stand-in that writes down its words.
    let printer = d.join("printer.sh");
    std::fs::write(
        &printer,
        "#!/bin/sh\nprintf '%s\\0' \"$@\" > argv.bin\nexit 1\n",
    )
    .unwrap();
    Command::new("chmod")
        .arg("+x")
        .arg(&printer)
        .status()
        .unwrap();
    let text = std::fs::read_to_string(d.join("build.ninja")).unwrap();
    let text: String = text
        .lines()
        .map(|l| {
            if l.starts_with("cubeforge =") {
                format!("cubeforge = {}\n", printer.display())
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    std::fs::write(d.join("build.ninja"), text).unwrap();
    let o = ninja(d, &["build/sky.ktx2"]);
    assert!(!o.status.success());
    let got = std::fs::read(d.join("argv.bin")).unwrap();
    let got: Vec<String> = got
        .split(|&b| b == 0)
        .map(|w| String::from_utf8(w.to_vec()).unwrap())
        .collect();
    let mut want: Vec<String> = ["-q", "prefilter", "sky.exr", "-o", "build/sky.ktx2"]
        .iter()
        .chain(WORDS)
        .map(|w| w.to_string())
        .collect();
    want.push("--depfile=build/sky.ktx2.d".into());
    // printf's last NUL ends the last word.
    want.push(String::new());
    assert_eq!(got, want);
    no_canary(d);
}

#[test]
fn pipes_spaces_colons_and_dollars_in_build_lines() {
    if !found("ninja", "ninja-build") {
        return;
    }
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    // The cubeforge program in a folder whose name needs every escape (Ninja names it on
    // every edge), and a manifest whose name does (the edge that writes build.ninja again).
    let bin = d.join("bin|x y:z$w");
    std::fs::create_dir_all(&bin).unwrap();
    let exe = bin.join("cubeforge");
    if std::fs::hard_link(CUBEFORGE, &exe).is_err() {
        std::fs::copy(CUBEFORGE, &exe).unwrap();
    }
    let p = d.join("proj");
    skies(&p, &["sky.exr"]);
    let name = "m|x y:z$w.toml";
    std::fs::write(
        p.join(name),
        manifest("\"*.exr\"", &["--filter", "box", "--size", "8"]),
    )
    .unwrap();
    let mut c = Command::new(&exe);
    c.args(["batch", name, "--emit", "ninja"]).current_dir(&p);
    ok(within(c, 60));
    let text = std::fs::read_to_string(p.join("build.ninja")).unwrap();
    assert!(
        text.contains("build build.ninja: manifest m${pipe}x$ y$:z$$w.toml\n"),
        "{text}"
    );
    assert!(text.contains("bin${pipe}x$ y$:z$$w/cubeforge\n"), "{text}");
    ok(ninja(&p, &[]));
    assert!(p.join("build/sky.ktx2").is_file());
    assert!(super::stdout(&ok(ninja(&p, &[]))).contains("no work to do"));
    // The manifest changed: Ninja writes build.ninja again through `./$in`.
    std::thread::sleep(std::time::Duration::from_millis(20));
    let mut text = std::fs::read_to_string(p.join(name)).unwrap();
    text.push_str("# changed\n");
    std::fs::write(p.join(name), text).unwrap();
    let o = super::stdout(&ok(ninja(&p, &[])));
    assert!(o.contains("build.ninja from"), "{o}");
    no_canary(d);
}
