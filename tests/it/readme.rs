//! The examples of the README and of `docs/*.md` run, in order, on a fresh copy of the
//! repository, and their links lead somewhere.
//!
//! The convention: in the ```sh blocks of README.md and docs/*.md, every line that starts with `cubeforge ` is an
//! example (a trailing `\` continues it on the next line, `&&` chains commands, `#` starts a
//! comment); lines that start with `cargo ` are set-up and are not run here. Any other line in an
//! sh block is an error, so nothing there goes untested. The examples run with the built binary
//! in a temporary folder that holds a copy of `fixtures/`, a copy of `examples/` when it exists
//! (`cubeforge batch examples/pipeline/assets.toml`) and, when it exists, a link to
//! `../shared`; lines that read `../shared/fixtures/real` are skipped without it. Each file runs
//! in a fresh folder of its own. Each example must exit 0, and no example may write an output
//! (`-o`, `--sh`) that an earlier one of its file wrote. Examples with an ASTC format
//! (`astc-...`) are skipped in a build without the cargo feature `astc`, and UASTC lines
//! (`uastc-...`) without `uastc`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// One example: its README line and its commands (each the arguments after `cubeforge`).
struct Example {
    line: usize,
    text: String,
    commands: Vec<Vec<String>>,
    /// The comment after it (what it says the command does: counts a test can hold it to).
    comment: String,
}

/// The examples of a README text, by the convention above, or what breaks the convention.
fn examples(file: &str, readme: &str) -> Result<Vec<Example>, String> {
    let mut out = Vec::new();
    let mut fence: Option<String> = None;
    let mut pending: Option<(usize, String)> = None;
    for (i, raw) in readme.lines().enumerate() {
        let line_no = i + 1;
        let trimmed = raw.trim();
        if pending.is_none() && trimmed.starts_with("```") {
            fence = match fence {
                None => Some(trimmed.trim_start_matches('`').trim().to_owned()),
                Some(_) => None,
            };
            continue;
        }
        if fence.as_deref() != Some("sh") {
            continue;
        }
        let code = strip_comment(raw);
        let comment = raw[code.len()..].trim_start_matches('#').trim().to_owned();
        let (start, mut text) = pending.take().unwrap_or((line_no, String::new()));
        text.push(' ');
        match code.trim_end().strip_suffix('\\') {
            Some(more) => {
                text.push_str(more);
                pending = Some((start, text));
                continue;
            }
            None => text.push_str(code),
        }
        let text = text.split_whitespace().collect::<Vec<_>>().join(" ");
        if text.is_empty() || text.starts_with("cargo ") {
            continue;
        }
        if !text.starts_with("cubeforge ") {
            return Err(format!(
                "{file}:{start}: a line of an sh block that is neither a cubeforge example nor \
                 a cargo set-up line: {text}"
            ));
        }
        if let Some(c) = text.chars().find(|c| "'\"$|<>;*?`~(){}".contains(*c)) {
            return Err(format!(
                "{file}:{start}: examples are plain words (found {c:?}): {text}"
            ));
        }
        let mut commands = Vec::new();
        for part in text.split("&&") {
            let words: Vec<String> = part.split_whitespace().map(str::to_owned).collect();
            if words.first().map(String::as_str) != Some("cubeforge") {
                return Err(format!(
                    "{file}:{start}: every command of a chain is a cubeforge command: {text}"
                ));
            }
            commands.push(words[1..].to_vec());
        }
        out.push(Example {
            line: start,
            text,
            commands,
            comment,
        });
    }
    if pending.is_some() {
        return Err(format!("{file}: an example ends with '\\'"));
    }
    if fence.is_some() {
        return Err(format!("{file}: a code block is not closed"));
    }
    Ok(out)
}

/// What a batch example's comment says its summary line holds: `N jobs` (`batch: N jobs`),
/// `N up to date`, `N left to other shards`, and `nothing would run` / `nothing runs`.
fn batch_claims(comment: &str) -> Vec<String> {
    let words: Vec<&str> = comment
        .split(|c: char| c.is_whitespace() || c == ';' || c == ',' || c == ':')
        .filter(|w| !w.is_empty())
        .collect();
    let mut out = Vec::new();
    for (i, w) in words.iter().enumerate() {
        let Ok(n) = w.parse::<usize>() else {
            continue;
        };
        let next = |k: usize| words.get(i + k).copied().unwrap_or_default();
        match (next(1), next(2)) {
            ("jobs", _) => out.push(format!("batch: {n} jobs")),
            ("up", "to") => out.push(format!("{n} up to date")),
            ("left", "to") => out.push(format!("{n} left to other shards")),
            _ => {}
        }
    }
    if comment.contains("nothing would run") {
        out.push(" 0 would run".into());
    }
    if comment.contains("nothing runs") || comment.contains("nothing changed") {
        out.push(" 0 ran".into());
    }
    out
}

/// The line without its comment (`#` at the start or after a space).
fn strip_comment(line: &str) -> &str {
    let bytes = line.as_bytes();
    for (i, &b) in bytes.iter().enumerate() {
        if b == b'#' && (i == 0 || bytes[i - 1].is_ascii_whitespace()) {
            return &line[..i];
        }
    }
    line
}

/// Copies a folder, leaving out what running an example leaves behind (its outputs, state
/// file and Ninja's files, which examples/pipeline/.gitignore lists): the copy is fresh.
fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let name = e.file_name().to_string_lossy().into_owned();
        if ["build", "build.ninja", ".ninja_log", ".ninja_deps"].contains(&name.as_str())
            || name.ends_with(".state.json")
        {
            continue;
        }
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), &target).unwrap();
        }
    }
}

/// README.md, then docs/*.md in name order, each with its text.
fn documents(repo: &Path) -> Vec<(String, String)> {
    let mut docs: Vec<String> = std::fs::read_dir(repo.join("docs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".md"))
        .map(|n| format!("docs/{n}"))
        .collect();
    docs.sort();
    std::iter::once("README.md".to_string())
        .chain(docs)
        .map(|name| {
            let text = std::fs::read_to_string(repo.join(&name)).unwrap();
            (name, text)
        })
        .collect()
}

/// The set-up: install once, the main job with the installed binary, the tests on that build.
#[test]
fn readme_setup_is_install_main_job_tests() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(repo.join("README.md")).unwrap();
    let setup = readme
        .split("## Set-up")
        .nth(1)
        .and_then(|s| s.split("```sh").nth(1))
        .and_then(|s| s.split("```").next())
        .expect("README.md has a Set-up section with an sh block");
    let setup: Vec<&str> = setup
        .lines()
        .map(|l| strip_comment(l).trim())
        .filter(|l| !l.is_empty())
        .collect();
    assert_eq!(setup.len(), 3, "install, main job, tests: {setup:?}");
    assert_eq!(setup[0], "cargo install --locked --path .");
    assert!(
        setup[1].starts_with("cubeforge ") && setup[1].contains(" fixtures/"),
        "the main job runs the installed binary on a bundled input: {setup:?}"
    );
    assert_eq!(setup[2], "cargo test --release");
    // `ibl` is named in the opening lines, before the set-up.
    let opening = readme.split("## Set-up").next().unwrap();
    assert!(opening
        .lines()
        .take(8)
        .any(|l| l.contains("`cubeforge ibl`")));
    let lines = readme.lines().count();
    assert!(
        lines < 450,
        "README.md has {lines} lines: move reference material into docs/"
    );
}

#[test]
fn readme_and_docs_examples_run_in_order_on_a_fresh_copy() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let shared = repo.join("../shared");
    let have_shared = cfg!(unix) && shared.join("fixtures/real").is_dir();
    let start = Instant::now();
    let (mut ran, mut skipped) = (0, 0);
    for (file, text) in documents(repo) {
        let examples = examples(&file, &text).unwrap_or_else(|e| panic!("{e}"));
        if file == "README.md" {
            assert!(examples.len() >= 15, "{} examples", examples.len());
        }
        if examples.is_empty() {
            continue;
        }
        // A fresh copy: the bundled fixtures, the examples (batch manifests) when there are
        // any, and ../shared beside it when this checkout has one.
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path().join("cubeforge");
        copy_dir(&repo.join("fixtures"), &root.join("fixtures"));
        if repo.join("examples").is_dir() {
            copy_dir(&repo.join("examples"), &root.join("examples"));
        }
        #[cfg(unix)]
        if have_shared {
            std::os::unix::fs::symlink(shared.canonicalize().unwrap(), tmp.path().join("shared"))
                .unwrap();
        }
        for ex in &examples {
            // ASTC needs the cargo feature `astc`, UASTC `uastc` (CI builds both): skipped in
            // a build without.
            if (ex.text.contains("astc-") && !cfg!(feature = "astc"))
                || (ex.text.contains("uastc-") && !cfg!(feature = "uastc"))
            {
                skipped += 1;
                continue;
            }
            if ex.text.contains("../shared/") && !have_shared {
                use std::io::Write;
                let _ = writeln!(
                    std::io::stderr(),
                    "SKIPPED {file}:{}: ../shared/fixtures/real not found",
                    ex.line
                );
                skipped += 1;
                continue;
            }
            for args in &ex.commands {
                for (flag, value) in args.iter().zip(args.iter().skip(1)) {
                    if ["-o", "--output", "--sh"].contains(&flag.as_str()) {
                        assert!(
                            !root.join(value).exists(),
                            "{file}:{}: {value} was written by an earlier example: {}",
                            ex.line,
                            ex.text
                        );
                    }
                }
                let t = Instant::now();
                let out = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
                    .args(args)
                    .current_dir(&root)
                    .output()
                    .expect("cubeforge runs");
                println!(
                    "{:6.2} s  {file}:{}: cubeforge {}",
                    t.elapsed().as_secs_f64(),
                    ex.line,
                    args.join(" ")
                );
                assert!(
                    out.status.success(),
                    "{file}:{}: {} failed:\n{}",
                    ex.line,
                    ex.text,
                    String::from_utf8_lossy(&out.stderr)
                );
                if args.first().map(String::as_str) == Some("batch") {
                    let said = String::from_utf8_lossy(&out.stdout);
                    for claim in batch_claims(&ex.comment) {
                        assert!(
                            said.contains(&claim),
                            "{file}:{}: {} says \"{}\", but printed:\n{said}",
                            ex.line,
                            ex.text,
                            ex.comment
                        );
                    }
                }
                ran += 1;
            }
        }
        let outputs: Vec<PathBuf> = std::fs::read_dir(root.join("out"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        assert!(!outputs.is_empty(), "{file}");
    }
    println!(
        "{ran} commands in {:.2} s, {skipped} examples skipped",
        start.elapsed().as_secs_f64()
    );
}

/// The anchor GitHub gives a heading: lower case, punctuation other than `-` and `_` dropped,
/// spaces as `-`.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter(|c| c.is_alphanumeric() || matches!(c, ' ' | '-' | '_'))
        .map(|c| if c == ' ' { '-' } else { c })
        .collect()
}

/// The anchors of a Markdown text's headings (outside code blocks).
fn anchors(text: &str) -> Vec<String> {
    let mut fenced = false;
    let mut out = Vec::new();
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced && line.starts_with('#') {
            out.push(slug(line.trim_start_matches('#')));
        }
    }
    out
}

/// The targets of a Markdown text's inline links and images, `](target)`.
fn links(text: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find("](") {
        rest = &rest[i + 2..];
        if let Some(end) = rest.find(')') {
            out.push(rest[..end].to_string());
        }
    }
    out
}

/// Every relative link of README.md and docs/*.md leads to a file that exists (and to one of
/// its headings, for `#anchor`), and every page of docs/ is reachable from the README.
#[test]
fn readme_and_docs_links_lead_somewhere() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let documents = documents(repo);
    let mut checked = 0;
    for (file, text) in &documents {
        let dir = repo.join(file).parent().unwrap().to_path_buf();
        for link in links(text) {
            if link.starts_with("http://") || link.starts_with("https://") {
                continue;
            }
            let (path, anchor) = match link.split_once('#') {
                Some((p, a)) => (p, Some(a)),
                None => (link.as_str(), None),
            };
            let target = if path.is_empty() {
                repo.join(file)
            } else {
                dir.join(path)
            };
            assert!(target.exists(), "{file}: the link {link} leads nowhere");
            if let Some(anchor) = anchor {
                let text = std::fs::read_to_string(&target).unwrap();
                assert!(
                    anchors(&text).iter().any(|a| a == anchor),
                    "{file}: the link {link} names no heading of {}",
                    target.display()
                );
            }
            checked += 1;
        }
    }
    assert!(checked >= 20, "{checked} links");
    let readme = &documents[0].1;
    for (file, _) in &documents[1..] {
        assert!(
            links(readme).iter().any(|l| l == file),
            "README.md does not link {file}"
        );
    }
    assert_eq!(
        slug("Physically based preview (`--material pbr`)"),
        "physically-based-preview---material-pbr"
    );
}

/// The convention itself, on a made-up README.
#[test]
fn examples_follow_the_convention() {
    let text = "intro\n```sh\ncargo test   # set-up\n# a comment\ncubeforge info a.exr  # why\n\
                cubeforge convert a.exr \\\n    -o b.exr && cubeforge info b.exr\n```\n\
                ```text\nnot run\n```\n";
    let ex = examples("README.md", text).unwrap();
    assert_eq!(ex.len(), 2);
    assert_eq!(
        (ex[0].line, ex[0].commands.clone()),
        (5, vec![vec!["info".to_string(), "a.exr".into()]])
    );
    assert_eq!(ex[1].line, 6);
    assert_eq!(
        ex[1].commands,
        vec![
            vec!["convert", "a.exr", "-o", "b.exr"],
            vec!["info", "b.exr"]
        ]
        .into_iter()
        .map(|c| c.into_iter().map(String::from).collect::<Vec<_>>())
        .collect::<Vec<_>>()
    );
    for bad in [
        "```sh\nls out/\n```\n",
        "```sh\ncubeforge info *.exr\n```\n",
        "```sh\ncubeforge info a.exr && ls\n```\n",
        "```sh\ncubeforge info a.exr\n",
    ] {
        assert!(examples("README.md", bad).is_err(), "{bad}");
    }
}
