//! Item 10, the batch's part: planning linear in the manifest's tables, job lines that
//! never carry a control character to the terminal, and names starting with `-` that reach
//! the job as files, not options.

use super::{cubeforge, found, ok, skies, stderr, stdout, within};
use std::process::Command;
use std::time::Instant;

#[test]
fn ten_thousand_tables_plan_in_seconds() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let n = 10_000;
    let mut m = String::new();
    for i in 0..n {
        m.push_str(&format!(
            "[[job]]\ninputs = [\"in/a{i}.exr\"]\ncommand = \"prefilter\"\n\
             args = [\"--filter\", \"box\", \"--size\", \"8\"]\noutput = \"build/{{stem}}.ktx2\"\n\n"
        ));
    }
    std::fs::write(d.join("m.toml"), m).unwrap();
    // Before: 9 to 29 s before anything ran (a count of lines per table, a search of the
    // groups per job). The bound is a hang guard, far above the time it takes.
    for args in [&["--dry-run"][..], &["--emit", "ninja"]] {
        let start = Instant::now();
        let o = ok(cubeforge(&[&["batch", "m.toml"][..], args].concat(), d));
        let took = start.elapsed().as_secs_f64();
        eprintln!("{n} tables, batch {args:?}: {took:.2} s");
        assert!(took < 20.0, "{took:.2} s");
        if args == ["--dry-run"] {
            let out = stdout(&o);
            assert!(
                out.contains(&format!("batch: {n} jobs: {n} would run")),
                "{}",
                out.lines().last().unwrap_or("")
            );
        }
    }
    let text = std::fs::read_to_string(d.join("build.ninja")).unwrap();
    assert_eq!(text.matches("\nbuild build/a").count(), n);
    assert!(text.contains(&format!("# m.toml, line {}\n", 6 * (n - 1) + 3)));
}

#[test]
fn job_lines_write_control_characters_out() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    skies(d, &["sky.exr"]);
    // A decal named with a terminal's escape sequences (clear the screen, set the title).
    std::fs::write(
        d.join("m.toml"),
        "[[job]]\ninputs = [\"sky.exr\"]\ncommand = \"preview\"\n\
         args = [\"--size\", \"16\", \"--decal\", \"\\u001b[2J\\u001b]0;pwn\\u0007.png\"]\n\
         output = \"build/{stem}.png\"\n",
    )
    .unwrap();
    let shown = "'\\x1b[2J\\x1b]0;pwn\\x07.png'";
    let o = ok(cubeforge(&["batch", "m.toml", "--dry-run"], d));
    let out = stdout(&o);
    assert!(!out.contains(['\x1b', '\x07']), "{out:?}");
    assert!(
        out.contains(&format!(
            "would run   cubeforge preview sky.exr -o build/sky.png --size 16 --decal {shown} ("
        )),
        "{out}"
    );
    let o = cubeforge(&["batch", "m.toml"], d);
    assert_eq!(o.status.code(), Some(1));
    let (out, e) = (stdout(&o), stderr(&o));
    assert!(
        !out.contains(['\x1b', '\x07']) && !e.contains(['\x1b', '\x07']),
        "{out:?} {e:?}"
    );
    let failed: Vec<&str> = e.lines().filter(|l| l.contains("failed: line 3")).collect();
    assert_eq!(failed.len(), 1, "{e}");
    assert!(failed[0].contains(&format!("--decal {shown}: ")), "{e}");
}

#[test]
fn names_starting_with_a_dash_reach_the_job_as_files() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path();
    let names = ["-o.exr", "--help.exr", "-.exr"];
    skies(d, &names);
    let manifest = "[[job]]\ninputs = [\"*.exr\"]\ncommand = \"prefilter\"\n\
         args = [\"--filter\", \"box\", \"--size\", \"8\"]\noutput = \"{stem}.ktx2\"\n";
    std::fs::write(d.join("-m.toml"), manifest).unwrap();
    let o = ok(cubeforge(&["batch", "./-m.toml", "--depfiles"], d));
    let out = stdout(&o);
    for n in names {
        let stem = n.trim_end_matches(".exr");
        assert!(
            out.contains(&format!(
                "ran         cubeforge prefilter ./{n} -o ./{stem}.ktx2 --filter box --size 8 ("
            )),
            "{out}"
        );
        assert_eq!(
            std::fs::read_to_string(d.join(format!("{stem}.ktx2.d"))).unwrap(),
            format!("./{stem}.ktx2: \\\n  ./{n}\n")
        );
    }
    assert!(stdout(&o).contains("3 ran"), "{out}");
    // build.ninja names them so too, and runs; its manifest edge does not read `-m.toml` as
    // options either.
    let n = d.join("ninja");
    skies(&n, &names);
    std::fs::write(n.join("-m.toml"), manifest).unwrap();
    ok(cubeforge(&["batch", "./-m.toml", "--emit", "ninja"], &n));
    let text = std::fs::read_to_string(n.join("build.ninja")).unwrap();
    assert!(
        text.contains("  args = prefilter ./-o.exr -o ./-o.ktx2 --filter box --size 8\n"),
        "{text}"
    );
    if !found("ninja", "ninja-build") {
        return;
    }
    let ninja = || {
        let mut c = Command::new("ninja");
        c.current_dir(&n);
        ok(within(c, 120))
    };
    ninja();
    for n2 in names {
        let out = format!("{}.ktx2", n2.trim_end_matches(".exr"));
        assert_eq!(
            std::fs::read(n.join(&out)).unwrap(),
            std::fs::read(d.join(&out)).unwrap(),
            "{out}"
        );
    }
    std::thread::sleep(std::time::Duration::from_millis(20));
    std::fs::write(n.join("-m.toml"), format!("{manifest}# changed\n")).unwrap();
    let o = stdout(&ninja());
    assert!(o.contains("build.ninja from -m.toml"), "{o}");
}
