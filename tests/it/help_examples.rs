//! The examples that `--help` and the man pages print after the options run.
//!
//! Each command's help (and the top level's) ends with an "Examples" section: indented lines,
//! `#` comments and `cubeforge ...` commands, some inside a line of shell (`source <(cubeforge
//! completions bash)`, `cubeforge completions zsh > FILE`: the command ends at `)`, `|` or
//! `>`). Every command has at least two. They run in order, each command's examples in a
//! fresh folder holding only the inputs they name: `panorama.hdr` (the bundled demo sky as a
//! Radiance file), `ball.exr` (a mirror ball of it), `recipe.toml` (a bundled control
//! recipe) and `assets.toml` (a batch manifest over panorama.hdr); no example may write an output (`-o`, `--sh`) that is an input or an earlier
//! output.

use std::path::Path;
use std::process::Command;

fn cubeforge(args: &[&str], dir: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("cubeforge runs")
}

fn help(command: Option<&str>) -> String {
    let args: Vec<&str> = command.into_iter().chain(["--help"]).collect();
    let out = cubeforge(&args, Path::new(env!("CARGO_MANIFEST_DIR")));
    assert!(out.status.success());
    String::from_utf8(out.stdout).unwrap()
}

/// The commands of a help's "Examples" section, each as its words after `cubeforge`.
fn examples(help: &str) -> Result<Vec<Vec<String>>, String> {
    let section = help
        .split("\nExamples")
        .nth(1)
        .ok_or("no Examples section")?;
    let mut out = Vec::new();
    for line in section.lines().skip(1) {
        if !line.starts_with("  ") {
            break;
        }
        let line = line.trim();
        if line.starts_with('#') {
            continue;
        }
        let start = line
            .find("cubeforge ")
            .ok_or_else(|| format!("an example line without a cubeforge command: {line}"))?;
        let rest = &line[start..];
        let command = &rest[..rest.find([')', '|', '>']).unwrap_or(rest.len())];
        if let Some(c) = command.chars().find(|c| "'\"$<;*?`~(){}&#\\".contains(*c)) {
            return Err(format!("examples are plain words (found {c:?}): {line}"));
        }
        out.push(
            command
                .split_whitespace()
                .skip(1)
                .map(String::from)
                .collect(),
        );
    }
    Ok(out)
}

/// The visible commands the top-level help lists.
fn commands() -> Vec<String> {
    let top = help(None);
    let listed = top.split("Commands:\n").nth(1).expect("a Commands section");
    listed
        .lines()
        .take_while(|l| l.starts_with("  "))
        // A description wrapped to the terminal goes on under its own column.
        .filter(|l| !l[2..].starts_with(' '))
        .map(|l| l.split_whitespace().next().unwrap().to_owned())
        .filter(|c| c != "help")
        .collect()
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn every_help_example_runs() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = tempfile::tempdir().unwrap();
    let inputs = tmp.path().join("inputs");
    std::fs::create_dir(&inputs).unwrap();
    let sky = repo.join("fixtures/sky.exr");
    let sky = sky.to_str().unwrap();
    for args in [
        &["convert", sky, "-o", "panorama.hdr", "--to", "equirect"][..],
        &[
            "convert", sky, "-o", "ball.exr", "--to", "sphere", "--size", "64",
        ],
    ] {
        assert!(cubeforge(args, &inputs).status.success(), "{args:?}");
    }
    std::fs::copy(
        repo.join("fixtures/control/chrome_and_paint.toml"),
        inputs.join("recipe.toml"),
    )
    .unwrap();
    std::fs::write(
        inputs.join("assets.toml"),
        "[[job]]\ninputs = [\"*.hdr\"]\ncommand = \"ibl\"\nargs = [\"--target\", \"bevy\", \
         \"--size\", \"16\"]\noutput = \"build/{stem}/bevy\"\n",
    )
    .unwrap();

    let mut names: Vec<Option<String>> = vec![None];
    names.extend(commands().into_iter().map(Some));
    assert!(names.len() >= 9, "{names:?}");
    let mut ran = 0;
    for name in &names {
        let label = name.as_deref().unwrap_or("cubeforge");
        let list = examples(&help(name.as_deref())).unwrap_or_else(|e| panic!("{label}: {e}"));
        assert!(
            list.len() >= 2,
            "{label} --help shows {} examples",
            list.len()
        );
        let dir = tmp.path().join(format!("run_{label}"));
        copy_dir(&inputs, &dir);
        for args in &list {
            if let Some(name) = name {
                assert_eq!(
                    args.first(),
                    Some(name),
                    "an example of {label} runs {args:?}"
                );
            }
            for (flag, value) in args.iter().zip(args.iter().skip(1)) {
                if ["-o", "--output", "--sh"].contains(&flag.as_str()) {
                    assert!(
                        !dir.join(value).exists(),
                        "{label} --help: {value} is an input or an earlier example's output"
                    );
                }
            }
            let words: Vec<&str> = args.iter().map(String::as_str).collect();
            let out = cubeforge(&words, &dir);
            assert!(
                out.status.success(),
                "{label} --help: cubeforge {} failed:\n{}",
                args.join(" "),
                String::from_utf8_lossy(&out.stderr)
            );
            ran += 1;
        }
    }
    println!("{ran} help examples ran");
}

/// `ibl --help` shows the one-line recipe of every engine `--target` takes.
#[test]
fn ibl_help_shows_every_target() {
    let text = help(Some("ibl"));
    let after = text.split("\n      --target <TARGET>").nth(1).unwrap();
    let targets: Vec<&str> = after
        .lines()
        .skip(1)
        .take_while(|l| !l.trim_start().starts_with("--"))
        .filter_map(|l| l.trim().strip_prefix("- "))
        .filter_map(|l| l.split(':').next())
        .collect();
    assert!(targets.len() >= 8, "{targets:?}");
    let shown: Vec<Vec<String>> = examples(&text).unwrap();
    for t in targets {
        assert!(
            shown
                .iter()
                .any(|a| a.windows(2).any(|w| w[0] == "--target" && w[1] == t)),
            "ibl --help has no example for --target {t}"
        );
    }
}

/// The extraction itself, on a made-up help.
#[test]
fn examples_are_read_as_documented() {
    let text = "Usage: x\n\nExamples:\n  # one\n  cubeforge info a.exr\n  source <(cubeforge \
                completions bash)\n  cubeforge completions zsh > ~/f\n\nafter\n";
    let words = |s: &str| s.split(' ').map(String::from).collect::<Vec<_>>();
    assert_eq!(
        examples(text).unwrap(),
        vec![
            words("info a.exr"),
            words("completions bash"),
            words("completions zsh")
        ]
    );
    assert!(examples("Examples:\n  cubeforge info $HOME/a.exr\n").is_err());
    assert!(examples("Examples:\n  ls\n").is_err());
    assert!(examples("no section").is_err());
}

/// Help is wrapped to the terminal (100 columns when it is not one), so no paragraph runs on
/// as one line; the examples fit whole (issue 48, item 14).
#[test]
fn help_is_wrapped_and_examples_fit() {
    for c in commands() {
        let text = help(Some(&c));
        let long: Vec<&str> = text.lines().filter(|l| l.chars().count() > 100).collect();
        assert!(long.is_empty(), "{c}: {long:?}");
        let section = text.split("\nExamples").nth(1).unwrap_or_default();
        for line in section.lines().skip(1).take_while(|l| l.starts_with("  ")) {
            let l = line.trim_start();
            assert!(
                l.starts_with('#') || l.starts_with("cubeforge ") || l.starts_with("source "),
                "{c}: an example wrapped: {line:?}"
            );
        }
    }
}
