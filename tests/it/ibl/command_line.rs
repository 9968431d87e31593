//! The command's own reports: bad requests as one-line errors, BC6H quality with --verbose;
//! its folder read back by `info` and `preview`.

use super::*;

#[test]
fn bad_ibl_requests_are_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let inp = input.to_str().unwrap();
    let out = dir.path().join("o");
    let o = out.to_str().unwrap();
    for (args, needle) in [
        (
            vec![
                "ibl",
                inp,
                "-o",
                o,
                "--target",
                "bevy",
                "--min-size",
                "64",
                "--size",
                "32",
            ],
            "min size",
        ),
        (
            vec!["ibl", inp, "-o", o, "--target", "bevy", "--name", "../x"],
            "name",
        ),
        (vec!["ibl", inp, "-o", o, "--target", "nope"], "nope"),
        (
            vec!["ibl", inp, "-o", o, "--target", "babylon", "--zstd"],
            "zstd",
        ),
        (
            vec![
                "ibl",
                inp,
                "-o",
                o,
                "--target",
                "filament",
                "--gpu-format",
                "bc6h",
            ],
            "KTX 1",
        ),
    ] {
        let r = run(&args);
        assert!(!r.status.success());
        let e = stderr(&r);
        assert_eq!(e.lines().count(), 1, "{e}");
        assert!(e.contains(needle), "{e}");
    }
    assert!(!out.exists());
    // Without --min-size a size under the target's floor is simply a one-level chain.
    ibl(&input, &out, "bevy", &["--size", "4", "--samples", "4"]);
    assert_eq!(read_cube(&out.join("env_specular.ktx2")).levels.len(), 1);
}

#[test]
fn bc6h_quality_is_reported_with_verbose() {
    let dir = tempfile::tempdir().unwrap();
    let input = marker_panorama(dir.path());
    let out = dir.path().join("bc6h");
    let mut args = vec![
        "ibl",
        input.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--target",
        "gltf",
        "--gpu-format",
        "bc6h",
        "-v",
    ];
    args.extend_from_slice(&SMALL);
    let r = run(&args);
    assert!(r.status.success(), "{}", stderr(&r));
    let e = stderr(&r);
    let line = e.lines().find(|l| l.contains("PSNR")).expect("a PSNR line");
    let db: f64 = line
        .split("PSNR ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap();
    assert!(db > 35.0, "{line}");
    assert!(e.contains("encode"), "{e}");
}

/// Every reading command takes the folder `ibl` wrote (issue 48, item 11): `info` describes its
/// specular chain and `preview` draws with it, as `view` shows it.
#[test]
fn info_and_preview_read_an_ibl_folder() {
    let dir = tempfile::tempdir().unwrap();
    let sky = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/sky.exr");
    for target in ["bevy", "gltf", "filament", "babylon"] {
        let out = dir.path().join(target);
        super::ibl(&sky, &out, target, &["--size", "32"]);
        let o = run(["info", out.to_str().unwrap()]);
        assert!(o.status.success(), "{target}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("mip levels"), "{target}: {text}");
        let png = dir.path().join(format!("{target}.png"));
        let o = run([
            "preview",
            out.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{target}: {}", stderr(&o));
        assert!(png.is_file());
    }
}
