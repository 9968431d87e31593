//! Issue 48, item 16: every command that writes files says what it wrote (the paths on
//! standard output, silenced by --quiet), and `help --help` is help, not an error.

use crate::common::{run, stderr};

const SKY: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

#[test]
fn every_writing_command_prints_what_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let d = |n: &str| dir.path().join(n).to_str().unwrap().to_owned();
    let control = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/fixtures/control/frosted_glass.toml"
    );
    let cases: Vec<(Vec<String>, Vec<String>)> = vec![
        (
            vec!["convert", SKY, "-o", d("sky.ktx2").as_str(), "--size", "8"],
            vec![d("sky.ktx2")],
        ),
        (
            vec![
                "convert",
                SKY,
                "-o",
                d("faces").as_str(),
                "--to",
                "faces",
                "--size",
                "8",
            ],
            vec![format!("{}/ (6 files", d("faces"))],
        ),
        (
            vec![
                "prefilter",
                SKY,
                "-o",
                d("ggx.dds").as_str(),
                "--filter",
                "ggx",
                "--size",
                "8",
                "--samples",
                "4",
            ],
            vec![d("ggx.dds"), d("ggx.dds.levels.json")],
        ),
        (
            vec![
                "irradiance",
                SKY,
                "-o",
                d("irr.exr").as_str(),
                "--size",
                "4",
                "--sh",
                d("sh.json").as_str(),
            ],
            vec![d("irr.exr"), d("sh.json")],
        ),
        (
            vec![
                "ibl",
                SKY,
                "-o",
                d("bevy").as_str(),
                "--target",
                "bevy",
                "--size",
                "8",
                "--samples",
                "4",
            ],
            vec![d("bevy/env_specular.ktx2"), d("bevy/env_diffuse.ktx2")],
        ),
        (
            vec!["lut", "-o", d("dfg.png").as_str(), "--size", "8"],
            vec![d("dfg.png")],
        ),
        (
            vec![
                "control",
                control,
                "-o",
                d("c.png").as_str(),
                "--size",
                "8x8",
            ],
            vec![d("c.png")],
        ),
        (
            vec!["preview", SKY, "-o", d("p.png").as_str(), "--size", "8"],
            vec![d("p.png")],
        ),
        (vec!["view", SKY, "-o", d("page").as_str()], vec![d("page")]),
    ]
    .into_iter()
    .map(|(a, w)| (a.into_iter().map(String::from).collect(), w))
    .collect();
    for (args, wrote) in cases {
        let r = run(&args);
        assert!(r.status.success(), "{args:?}: {}", stderr(&r));
        let said = String::from_utf8_lossy(&r.stdout);
        for w in wrote {
            assert!(said.contains(&w), "{args:?} does not say {w}: {said}");
        }
        // --quiet: nothing.
        let mut quiet = args.clone();
        quiet.push("--quiet".into());
        let r = run(&quiet);
        assert!(r.status.success(), "{quiet:?}: {}", stderr(&r));
        assert!(r.stdout.is_empty(), "{quiet:?}");
    }
}

#[test]
fn help_of_help_is_help() {
    for args in [
        &["help", "--help"][..],
        &["help", "-h"],
        &["help", "convert", "--help"],
    ] {
        let r = run(args);
        assert!(r.status.success(), "{args:?}: {}", stderr(&r));
        let text = String::from_utf8_lossy(&r.stdout);
        assert!(text.contains("Usage: cubeforge"), "{args:?}: {text}");
    }
    let r = run(["help", "convert", "--help"]);
    assert!(String::from_utf8_lossy(&r.stdout).contains("Usage: cubeforge convert"));
}
