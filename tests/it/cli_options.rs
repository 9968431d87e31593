//! Options a careful user reaches for: exposure and tone curves on 8-bit outputs, one level
//! of a chain, --quiet, shell completions, standard input and output, progress counts.

use std::io::Write;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::sync::atomic::{AtomicU64, Ordering};

const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");
const SKY_PNG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.png");

pub(crate) fn run(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("cubeforge runs")
}

pub(crate) fn run_ok(args: &[&str], dir: &Path) -> Output {
    let o = run(args, dir);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

pub(crate) fn err(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn mean(path: &Path) -> f32 {
    let (d, _) = cubeforge::internals::convert::read(path, &Default::default()).unwrap();
    let cubeforge::internals::io::Decoded::Image(img) = d else {
        panic!("an image")
    };
    img.pixels.iter().map(|p| p.x + p.y + p.z).sum::<f32>() / img.pixels.len() as f32
}

#[test]
fn exposure_and_tonemap_change_8bit_outputs_only() {
    let t = tempfile::tempdir().unwrap();
    let base = ["convert", SKY_EXR, "--to", "equirect", "--size", "16"];
    let with = |extra: &[&str], out: &str| {
        let mut a = base.to_vec();
        a.extend_from_slice(&["-o", out]);
        a.extend_from_slice(extra);
        run_ok(&a, t.path())
    };
    with(&[], "plain.png");
    with(&["--exposure", "-2"], "dark.png");
    with(&["--tonemap", "reinhard"], "soft.png");
    let (plain, dark, soft) = (
        mean(&t.path().join("plain.png")),
        mean(&t.path().join("dark.png")),
        mean(&t.path().join("soft.png")),
    );
    assert!(dark < plain * 0.6, "{dark} vs {plain}");
    assert!(soft < plain, "{soft} vs {plain}");
    // A float output keeps radiance linear, and says the curve was ignored.
    let o = with(&["--tonemap", "aces"], "linear.exr");
    assert!(err(&o).contains("applies to 8-bit outputs"), "{}", err(&o));
    let o = with(&[], "plain.exr");
    assert!(err(&o).is_empty(), "{}", err(&o));
    let a = std::fs::read(t.path().join("linear.exr")).unwrap();
    let b = std::fs::read(t.path().join("plain.exr")).unwrap();
    assert_eq!(a, b);
    // Out of range or not a number: refused by the parser.
    for bad in ["nan", "40", "-inf"] {
        let o = run(
            &["convert", SKY_EXR, "-o", "x.png", "--exposure", bad],
            t.path(),
        );
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert_eq!(err(&o).lines().count(), 1, "{}", err(&o));
    }
    // Preview and irradiance have them too.
    let o = run_ok(
        &[
            "preview",
            SKY_EXR,
            "-o",
            "p.exr",
            "--size",
            "16",
            "--tonemap",
            "aces",
        ],
        t.path(),
    );
    assert!(err(&o).contains("applies to 8-bit outputs"), "{}", err(&o));
    run_ok(
        &[
            "irradiance",
            SKY_EXR,
            "-o",
            "irr",
            "--format",
            "png",
            "--size",
            "4",
            "--exposure",
            "1",
            "--tonemap",
            "aces",
        ],
        t.path(),
    );
    assert!(t.path().join("irr/px.png").is_file());
}

#[test]
fn convert_reads_one_level_of_a_chain() {
    let t = tempfile::tempdir().unwrap();
    run_ok(
        &[
            "prefilter",
            SKY_EXR,
            "-o",
            "chain.ktx2",
            "--size",
            "16",
            "--filter",
            "gaussian",
            "--min-size",
            "1",
        ],
        t.path(),
    );
    run_ok(
        &[
            "convert",
            "chain.ktx2",
            "-o",
            "l2.ktx2",
            "--level",
            "2",
            "--levels",
            "1",
        ],
        t.path(),
    );
    let (d, _) =
        cubeforge::internals::convert::read(&t.path().join("l2.ktx2"), &Default::default())
            .unwrap();
    let cubeforge::internals::io::Decoded::Cube(c) = d else {
        panic!("a cube")
    };
    assert_eq!(c.size(), 4);
    let o = run(
        &["convert", "chain.ktx2", "-o", "x.ktx2", "--level", "9"],
        t.path(),
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        err(&o).contains("no level 9: it holds 5 levels"),
        "{}",
        err(&o)
    );
    // A chain folder gives its mN faces.
    run_ok(
        &[
            "prefilter",
            SKY_EXR,
            "-o",
            "chaindir",
            "--size",
            "8",
            "--filter",
            "box",
            "--min-size",
            "1",
        ],
        t.path(),
    );
    run_ok(
        &["convert", "chaindir", "-o", "l1", "--level", "1"],
        t.path(),
    );
    assert!(t.path().join("l1/px.exr").is_file());
}

#[test]
fn quiet_prints_errors_only() {
    let t = tempfile::tempdir().unwrap();
    let o = run_ok(
        &[
            "-q", "convert", SKY_EXR, "-o", "a.exr", "--to", "equirect", "--size", "8", "--levels",
            "3",
        ],
        t.path(),
    );
    assert!(o.stderr.is_empty() && o.stdout.is_empty(), "{}", err(&o));
    let o = run_ok(
        &[
            "prefilter",
            SKY_EXR,
            "-o",
            "c.ktx2",
            "--size",
            "8",
            "--filter",
            "box",
            "--quiet",
        ],
        t.path(),
    );
    assert!(o.stderr.is_empty() && o.stdout.is_empty(), "{}", err(&o));
    let o = run(&["-q", "convert", "missing.png", "-o", "b.png"], t.path());
    assert_eq!(o.status.code(), Some(1));
    assert!(err(&o).contains("missing.png"), "{}", err(&o));
    assert_eq!(
        run(&["-q", "-v", "info", SKY_PNG], t.path()).status.code(),
        Some(2)
    );
}

#[test]
fn completions_for_every_shell() {
    let t = tempfile::tempdir().unwrap();
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let o = run_ok(&["completions", shell], t.path());
        let text = String::from_utf8(o.stdout).unwrap();
        assert!(
            text.contains("cubeforge") && text.contains("prefilter"),
            "{shell}"
        );
        assert!(text.contains("tonemap"), "{shell}: options of the commands");
        // The project's own hidden commands are not offered (issue 48, item 16).
        assert!(
            !text.contains("fixtures") && !text.contains("man pages"),
            "{shell}: hidden commands"
        );
        // --material completes the presets' names, not files.
        assert!(
            text.contains("mirror-decal") && text.contains("plastic-glossy"),
            "{shell}: material names"
        );
    }
    assert_eq!(
        run(&["completions", "tcsh"], t.path()).status.code(),
        Some(2)
    );
}

#[test]
fn standard_input_and_output() {
    let t = tempfile::tempdir().unwrap();
    run_ok(
        &[
            "convert", SKY_PNG, "-o", "file.png", "--to", "equirect", "--size", "8",
        ],
        t.path(),
    );
    let want = std::fs::read(t.path().join("file.png")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args([
            "convert", "-", "-o", "-", "--format", "png", "--to", "equirect", "--size", "8",
        ])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let input = std::fs::read(SKY_PNG).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(&input));
    let o = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(o.status.success(), "{}", err(&o));
    assert_eq!(o.stdout, want, "the same bytes through the pipes");
    // Without --format the output's type is unknown.
    let o = run(&["convert", SKY_PNG, "-o", "-"], t.path());
    assert_eq!(o.status.code(), Some(1));
    assert!(err(&o).contains("needs --format"), "{}", err(&o));
    // Bad bytes on standard input are named as such.
    let o = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(["info", "-"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(err(&o).contains("standard input"), "{}", err(&o));
    // A preview to standard output.
    let o = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args([
            "preview", SKY_EXR, "-o", "-", "--format", "png", "--size", "16",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", err(&o));
    assert!(o.stdout.starts_with(b"\x89PNG"));
}

#[test]
fn progress_is_reported_row_by_row() {
    use cubeforge::internals::filter::{irradiance_with_progress, IrradianceMethod};
    let cube = cubeforge::internals::cube::CubeMap::from_fn(8, |d| {
        glam::Vec4::new(d.x.max(0.0), 0.5, 0.2, 1.0)
    });
    let rows = AtomicU64::new(0);
    irradiance_with_progress(&cube, 5, IrradianceMethod::Brute, &|n| {
        rows.fetch_add(n, Ordering::Relaxed);
    });
    assert_eq!(rows.load(Ordering::Relaxed), 6 * 5);
}

#[test]
fn an_oversized_control_map_names_where_its_size_came_from() {
    let t = tempfile::tempdir().unwrap();
    std::fs::write(
        t.path().join("r.toml"),
        "# big\nsize = \"65536x65536\"\n[reflectivity]\nconstant = 0.5\n",
    )
    .unwrap();
    std::fs::write(
        t.path().join("r.json"),
        "{\n  \"reflectivity\": {\"constant\": 1},\n  \"size\": \"40000x40000\"\n}",
    )
    .unwrap();
    let cases: [(&[&str], &str); 3] = [
        (
            &["control", "r.toml", "-o", "a.png"],
            "r.toml: line 2: a 65536x65536 map",
        ),
        (
            &["control", "r.json", "-o", "a.png"],
            "r.json: line 3: a 40000x40000 map",
        ),
        (
            &["control", "r.toml", "-o", "a.png", "--size", "60000x60000"],
            "--size: a 60000x60000 map",
        ),
    ];
    for (args, want) in cases {
        let o = run(args, t.path());
        assert_eq!(o.status.code(), Some(1));
        assert!(err(&o).contains(want), "{}", err(&o));
        assert_eq!(err(&o).lines().count(), 1);
    }
}

#[test]
fn library_errors_have_kinds() {
    use cubeforge::internals::convert::read;
    use cubeforge::internals::io::{Limits, ReadOptions};
    use cubeforge::Error;
    let t = tempfile::tempdir().unwrap();
    let missing = t.path().join("missing.exr");
    match read(&missing, &ReadOptions::default()) {
        Err(Error::Io { path, source }) => {
            assert_eq!(path, missing);
            assert_eq!(source.kind(), std::io::ErrorKind::NotFound);
        }
        other => panic!("{:?}", other.map(|_| ())),
    }
    let tiny = ReadOptions {
        limits: Limits {
            max_pixels: 16,
            ..Limits::default()
        },
        ..ReadOptions::default()
    };
    let e = read(Path::new(SKY_PNG), &tiny).unwrap_err();
    assert!(
        matches!(
            e,
            Error::Limit {
                kind: cubeforge::LimitKind::Pixels,
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(e.path(), Some(Path::new(SKY_PNG)));
    // The library names the limit, not a command-line flag.
    assert!(!e.to_string().contains("--"), "{e}");
    let junk = t.path().join("junk.bin");
    std::fs::write(&junk, b"not an image").unwrap();
    let e = read(&junk, &ReadOptions::default()).unwrap_err();
    assert!(matches!(e, Error::Unsupported { .. }), "{e:?}");
    assert!(e.to_string().starts_with(&format!("{}: ", junk.display())));
    let recipe = t.path().join("bad.toml");
    std::fs::write(
        &recipe,
        "size = \"8x8\"\n[reflectivity]\nconstant = [1, 2]\n",
    )
    .unwrap();
    match cubeforge::internals::control::load(&recipe, &Limits::default()) {
        Err(e @ Error::Recipe { line: Some(3), .. }) => {
            assert!(e.to_string().contains("bad.toml: line 3: "), "{e}")
        }
        other => panic!("{:?}", other.map(|_| ())),
    }
}

#[test]
fn outputs_into_missing_folders_are_made() {
    let t = tempfile::tempdir().unwrap();
    run_ok(
        &[
            "irradiance",
            SKY_EXR,
            "-o",
            "a/b/irr.ktx2",
            "--size",
            "4",
            "--sh",
            "c/d/sh.json",
        ],
        t.path(),
    );
    assert!(t.path().join("a/b/irr.ktx2").is_file());
    assert!(t.path().join("c/d/sh.json").is_file());
}
