//! The hot loops' AVX2 build (chosen at run time) against the portable one: same bytes.

use crate::common;
use std::process::Command;

/// Runs cubeforge with `args`, with or without the AVX2 build, and returns the output file's
/// bytes (every file, in name order, for a folder).
fn bytes(args: &[&str], out: &std::path::Path, portable: bool) -> Vec<u8> {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubeforge"));
    cmd.args(args).args(["-o", out.to_str().unwrap(), "-q"]);
    if portable {
        cmd.env("CUBEFORGE_NO_AVX2", "1");
    } else {
        cmd.env_remove("CUBEFORGE_NO_AVX2");
    }
    let o = cmd.output().expect("cubeforge runs");
    assert!(o.status.success(), "{args:?}: {}", common::stderr(&o));
    if out.is_dir() {
        let mut names: Vec<_> = std::fs::read_dir(out)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        names.sort();
        names
            .iter()
            .flat_map(|p| std::fs::read(p).unwrap())
            .collect()
    } else {
        std::fs::read(out).unwrap()
    }
}

#[test]
fn wide_and_portable_loops_write_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let sky = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");
    let cross = dir.path().join("cross.exr");
    let o = common::run([
        "convert",
        sky,
        "-o",
        cross.to_str().unwrap(),
        "--to",
        "hcross",
        "--size",
        "64",
    ]);
    assert!(o.status.success(), "{}", common::stderr(&o));
    let cross = cross.to_str().unwrap();
    // Panorama lookups, peaks and RGBE rows; cube lookups; exact cosine sums; GGX taps.
    let jobs: [&[&str]; 4] = [
        &[
            "convert", sky, "--to", "faces", "--format", "hdr", "--size", "96",
        ],
        &["convert", cross, "--to", "equirect", "--yaw", "30"],
        &["prefilter", cross, "--filter", "cosine", "--size", "32"],
        &["prefilter", cross, "--filter", "ggx", "--size", "32"],
    ];
    for (i, job) in jobs.iter().enumerate() {
        let name = |k: &str| {
            let ext = if job[0] == "prefilter" {
                "ktx2"
            } else if i == 0 {
                ""
            } else {
                "exr"
            };
            let base = dir.path().join(format!("{k}{i}"));
            if ext.is_empty() {
                base
            } else {
                base.with_extension(ext)
            }
        };
        let wide = bytes(job, &name("wide"), false);
        let portable = bytes(job, &name("portable"), true);
        assert!(!wide.is_empty(), "{job:?}");
        assert!(
            wide == portable,
            "{job:?}: the AVX2 and portable builds differ"
        );
    }
}
