//! Careless use ends in one clear line, never a panic or a hang: closed or full standard
//! output, non-finite and out-of-range numbers, pipes and devices given as files, and clap's
//! usage errors.

use crate::common;

use common::{run, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn sky() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/sky.exr")
}

/// Exactly one line on stderr, starting "cubeforge: error: ", a non-zero exit, no panic.
fn one_error_line(args: &[&str]) -> String {
    let out = run(args);
    let err = stderr(&out);
    assert!(!out.status.success(), "{args:?} succeeded");
    assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err:?}");
    assert!(err.starts_with("cubeforge: error: "), "{args:?}: {err:?}");
    err
}

#[test]
fn non_finite_and_out_of_range_numbers_are_refused() {
    let sky = sky();
    let sky = sky.to_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.exr");
    let out = out.to_str().unwrap();
    let ktx = dir.path().join("x.ktx2");
    let ktx = ktx.to_str().unwrap();
    let png = dir.path().join("x.png");
    let png = png.to_str().unwrap();
    // (option, value, words the error must hold)
    let cases: &[(&[&str], &str)] = &[
        (&["convert", sky, "-o", out, "--yaw", "nan"], "--yaw"),
        (&["convert", sky, "-o", out, "--pitch", "inf"], "--pitch"),
        (&["convert", sky, "-o", out, "--roll", "-inf"], "--roll"),
        (&["convert", sky, "-o", out, "--yaw", "1e30"], "--yaw"),
        (
            &["prefilter", sky, "-o", ktx, "--gloss-scale", "nan"],
            "--gloss-scale",
        ),
        (
            &["prefilter", sky, "-o", ktx, "--gloss-bias", "1e9"],
            "--gloss-bias",
        ),
        (
            &["prefilter", sky, "-o", ktx, "--samples", "2147483648"],
            "--samples",
        ),
        (
            &["prefilter", sky, "-o", ktx, "--samples", "0"],
            "--samples",
        ),
        (&["preview", sky, "-o", png, "--fov", "nan"], "--fov"),
        (
            &["preview", sky, "-o", png, "--distance", "inf"],
            "--distance",
        ),
        (
            &["preview", sky, "-o", png, "--exposure", "nan"],
            "--exposure",
        ),
        (
            &["preview", sky, "-o", png, "--lod-bias", "-inf"],
            "--lod-bias",
        ),
        (
            &["preview", sky, "-o", png, "--grid-bias", "0,nan"],
            "--grid-bias",
        ),
    ];
    for (args, flag) in cases {
        let err = one_error_line(args);
        assert!(err.contains(flag), "{args:?}: {err}");
    }
    assert!(!dir.path().join("x.exr").exists());
}

#[test]
fn usage_errors_are_one_line_with_clap_tip() {
    let sky = sky();
    let err = one_error_line(&["preview", sky.to_str().unwrap(), "--fo", "3"]);
    assert!(err.contains("'--fo'") && err.contains("--fov"), "{err}");
    one_error_line(&["convert"]);
    one_error_line(&["no-such-command"]);
}

#[cfg(unix)]
#[test]
fn pipes_and_devices_are_refused_as_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe.exr");
    let made = Command::new("mkfifo").arg(&fifo).status();
    let sky = sky();
    let sky = sky.to_str().unwrap();
    let out = dir.path().join("o.png");
    let out = out.to_str().unwrap();
    let mut cases: Vec<Vec<String>> = vec![
        vec!["info".into(), "/dev/zero".into()],
        vec![
            "convert".into(),
            "/dev/zero".into(),
            "-o".into(),
            out.into(),
        ],
    ];
    if made.is_ok_and(|s| s.success()) {
        let f = fifo.to_str().unwrap().to_owned();
        cases.push(vec!["info".into(), f.clone()]);
        cases.push(vec!["convert".into(), f.clone(), "-o".into(), out.into()]);
        for opt in ["--material", "--decal", "--control"] {
            cases.push(vec![
                "preview".into(),
                sky.into(),
                "-o".into(),
                out.into(),
                opt.into(),
                f.clone(),
            ]);
        }
    }
    for args in cases {
        // A reader that blocked would hang here: the timeout makes that a failure.
        let mut child = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
            .args(&args)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            if start.elapsed().as_secs() > 20 {
                let _ = child.kill();
                panic!("{args:?} hung");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        let mut err = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut err).unwrap();
        assert!(!status.success(), "{args:?}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains("not a regular file"), "{args:?}: {err}");
    }
}

#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_quietly_and_a_full_disk_is_one_line() {
    let sky = sky();
    let sky = sky.to_str().unwrap();
    // Many files, JSON: far more than a pipe buffer, read by nobody.
    let mut args = vec!["info", "--json"];
    args.extend(std::iter::repeat_n(sky, 400));
    let mut child = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.is_empty(), "{err}");

    if Path::new("/dev/full").exists() {
        let full = std::fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let out = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
            .args(["info", sky])
            .stdout(full)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success());
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains("standard output"), "{err}");
    }
}

/// CRC-32 (PNG's) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// A PNG of only a header claiming 32768 x 16384 RGBA 16-bit (4 GiB of pixels) and an end.
fn huge_png_header() -> Vec<u8> {
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        png.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut body = kind.to_vec();
        body.extend_from_slice(data);
        png.extend_from_slice(&body);
        png.extend_from_slice(&crc32(&body).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&32768u32.to_be_bytes());
    ihdr.extend_from_slice(&16384u32.to_be_bytes());
    ihdr.extend_from_slice(&[16, 6, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IEND", &[]);
    png
}

#[test]
fn plans_over_the_memory_budget_are_refused_before_they_start() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("huge.png");
    std::fs::write(&png, huge_png_header()).unwrap();
    let png = png.to_str().unwrap();
    let sky = sky();
    let sky = sky.to_str().unwrap();
    let out = |n: &str| dir.path().join(n).to_str().unwrap().to_owned();
    let (o1, o2, o3, o4) = (out("a.exr"), out("b.png"), out("c.ktx2"), out("d.exr"));
    let cases: Vec<Vec<&str>> = vec![
        vec!["info", png, "--max-memory", "1G"],
        vec!["convert", png, "-o", &o1, "--max-memory", "1G"],
        vec![
            "convert",
            sky,
            "-o",
            &o1,
            "--to",
            "equirect",
            "--size",
            "8192",
            "--max-memory",
            "1G",
        ],
        vec![
            "preview",
            sky,
            "-o",
            &o2,
            "--size",
            "16384",
            "--max-memory",
            "1G",
        ],
        vec![
            "prefilter",
            sky,
            "-o",
            &o3,
            "--filter",
            "box",
            "--size",
            "8192",
            "--max-memory",
            "1G",
        ],
    ];
    for args in cases {
        let err = one_error_line(&args);
        assert!(err.contains("memory"), "{args:?}: {err}");
        assert!(err.contains("--max-memory"), "{args:?}: {err}");
    }
    // Within the budget the same option works.
    let ok = run([
        "convert",
        sky,
        "-o",
        &o4,
        "--to",
        "equirect",
        "--size",
        "16",
        "--max-memory",
        "1G",
    ]);
    assert!(ok.status.success(), "{}", stderr(&ok));
    let bad = run(["info", sky, "--max-memory", "lots"]);
    assert!(!bad.status.success());
}

#[test]
fn ignored_or_impossible_options_are_said() {
    let dir = tempfile::tempdir().unwrap();
    let sky = sky();
    let sky = sky.to_str().unwrap();
    let out = |n: &str| dir.path().join(n).to_str().unwrap().to_owned();
    let err = one_error_line(&["convert", sky, "-o", &out("a.ktx2"), "--levels", "20"]);
    assert!(err.contains("1 to 8 levels"), "{err}");
    let err = one_error_line(&["convert", sky, "-o", &out("a.ktx2"), "--levels", "0"]);
    assert!(err.contains("--levels 0"), "{err}");
    let png = out("b.png");
    let r = run([
        "convert",
        sky,
        "-o",
        &png,
        "--levels",
        "3",
        "--gpu-format",
        "rgba32f",
    ]);
    let err = stderr(&r);
    assert!(r.status.success(), "{err}");
    assert!(err.contains("--levels applies to KTX2 and DDS"), "{err}");
    assert!(
        err.contains("--gpu-format applies to KTX2 and DDS"),
        "{err}"
    );
    let folder = out("noext");
    let r = run(["convert", sky, "-o", &folder]);
    assert!(r.status.success());
    assert!(stderr(&r).contains("no file extension"), "{}", stderr(&r));
    assert!(Path::new(&folder).join("px.exr").exists());
}
