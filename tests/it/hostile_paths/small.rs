//! Issue 44, items 10 and 11: the smaller defects, each with the input that showed it.

use crate::fault_campaign::{ok, refused, BIN};
use std::path::Path;
use std::process::{Command, Stdio};

const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

/// Item 11: a program started with standard output on a read-write /dev/null (Python's
/// `stdout=subprocess.DEVNULL`, build systems, test harnesses) runs every command; only a
/// standard output closed for real (`>&-`) refuses `-o -` and `info`, whose data goes there,
/// while the commands that write files still write them.
#[cfg(unix)]
#[test]
fn standard_output_on_dev_null_is_no_error() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let devnull = || {
        std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open("/dev/null")
            .unwrap()
    };
    let jobs: [&[&str]; 5] = [
        &[
            "prefilter",
            SKY_EXR,
            "-o",
            "p.ktx2",
            "--filter",
            "box",
            "--size",
            "8",
        ],
        &["irradiance", SKY_EXR, "-o", "i.ktx2", "--size", "4"],
        &[
            "ibl", SKY_EXR, "-o", "bevy", "--target", "bevy", "--size", "8",
        ],
        &[
            "convert", SKY_EXR, "-o", "-", "--format", "ktx2", "--size", "8",
        ],
        &["info", SKY_EXR],
    ];
    for args in jobs {
        let out = Command::new(BIN)
            .current_dir(d)
            .args(args)
            .stdin(Stdio::null())
            .stdout(devnull())
            .output()
            .unwrap();
        ok(&out);
    }
    for f in ["p.ktx2", "i.ktx2", "bevy/env_specular.ktx2"] {
        assert!(d.join(f).is_file(), "{f}");
    }
    // The same under Python, as the issue found it.
    let py = "import subprocess, sys; sys.exit(subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL).returncode)";
    if Command::new("python3").arg("--version").output().is_ok() {
        let out = Command::new("python3")
            .current_dir(d)
            .args(["-c", py, BIN, "prefilter", SKY_EXR, "-o", "py.ktx2"])
            .args(["--filter", "box", "--size", "8"])
            .output()
            .unwrap();
        ok(&out);
        assert!(d.join("py.ktx2").is_file());
    }
    // Closed for real: the files are written, the data that had to go there is refused.
    let closed = |args: &str| {
        Command::new("sh")
            .current_dir(d)
            .arg("-c")
            .arg(format!("exec \"$0\" {args} >&-"))
            .arg(BIN)
            .output()
            .unwrap()
    };
    ok(&closed(&format!(
        "prefilter {SKY_EXR} -o closed.ktx2 --filter box --size 8"
    )));
    assert!(Path::new(d).join("closed.ktx2").is_file());
    refused(
        &closed(&format!("convert {SKY_EXR} -o - --format ktx2 --size 8")),
        &["standard output", "closed"],
    );
    refused(
        &closed(&format!("info {SKY_EXR}")),
        &["standard output", "closed"],
    );
}

/// Item 10: an UltraHDR file whose gain map is broken or over a limit is named in the error,
/// with which of its pictures failed (the inner JPEG was named `-`).
#[test]
fn ultrahdr_errors_name_the_file_and_its_picture() {
    let dir = tempfile::tempdir().unwrap();
    use crate::ultrahdr::jpeg;
    let mut meta = ultrahdr_rs::GainMapMetadata::default();
    meta.gain_map_max = [4.0; 3];
    meta.alternate_hdr_headroom = 4.0;
    let mut cut = jpeg(8);
    cut.truncate(cut.len() / 2);
    let bytes = |gain: &[u8]| {
        ultrahdr_rs::encode_ultrahdr(&jpeg(8), gain, &meta, ultrahdr_rs::ColorGamut::Bt709).unwrap()
    };
    let cases = [
        ("cut.jpg", bytes(&cut), &[][..]),
        ("big.jpg", bytes(&jpeg(16)), &["--max-pixels", "100"][..]),
    ];
    for (name, file, extra) in cases {
        let path = dir.path().join(name);
        std::fs::write(&path, file).unwrap();
        let p = path.to_str().unwrap();
        let out = Command::new(BIN)
            .args(["info", p])
            .args(extra)
            .output()
            .unwrap();
        let err = refused(&out, &[p, "its gain map"]);
        assert!(!err.contains(" -: ") && !err.contains(": -:"), "{err}");
    }
}

/// A `w` x 2 PNG of `color` at `depth`, with a tEXt chunk for each of `texts`
/// (cubeforge.hdrEncoding).
fn marked_png(path: &Path, color: png::ColorType, depth: png::BitDepth, texts: &[&str]) {
    let w = 4u32;
    let channels = color.samples();
    let bytes = (depth as usize).div_ceil(8);
    let data = vec![200u8; w as usize * 2 * channels * bytes];
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, 2);
        enc.set_color(color);
        enc.set_depth(depth);
        for t in texts {
            enc.add_text_chunk("cubeforge.hdrEncoding".into(), (*t).into())
                .unwrap();
        }
        enc.write_header().unwrap().write_image_data(&data).unwrap();
    }
    std::fs::write(path, out).unwrap();
}

/// Item 10: the PNG text that names an HDR encoding is obeyed only where the encoding fits
/// (8-bit RGBA); texts that disagree are refused; a refusal names `--decode` only when it
/// was given.
#[test]
fn png_encoding_texts_are_obeyed_only_where_they_fit() {
    use png::{BitDepth, ColorType};
    let dir = tempfile::tempdir().unwrap();
    let info = |name: &str, extra: &[&str]| {
        Command::new(BIN)
            .args(["info", dir.path().join(name).to_str().unwrap(), "--json"])
            .args(extra)
            .output()
            .unwrap()
    };
    // Grey, RGB and 16-bit PNGs cannot hold RGBM: read as the colours they are.
    for (name, color, depth) in [
        ("grey.png", ColorType::Grayscale, BitDepth::Eight),
        ("rgb.png", ColorType::Rgb, BitDepth::Eight),
        ("rgba16.png", ColorType::Rgba, BitDepth::Sixteen),
    ] {
        marked_png(&dir.path().join(name), color, depth, &["rgbm6"]);
        let out = info(name, &[]);
        ok(&out);
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(!text.contains("RGBM"), "{name}: {text}");
    }
    // An 8-bit RGBA PNG: obeyed.
    marked_png(
        &dir.path().join("rgbm.png"),
        ColorType::Rgba,
        BitDepth::Eight,
        &["rgbm6"],
    );
    let out = info("rgbm.png", &[]);
    ok(&out);
    assert!(String::from_utf8_lossy(&out.stdout).contains("RGBM"));
    // Two texts that disagree: refused, naming the file; --decode settles it.
    let two = dir.path().join("two.png");
    marked_png(&two, ColorType::Rgba, BitDepth::Eight, &["rgbm6", "rgbd"]);
    refused(
        &info("two.png", &[]),
        &[two.to_str().unwrap(), "disagree", "--decode"],
    );
    ok(&info("two.png", &["--decode", "rgbd"]));
    // --decode on a 16-bit PNG names the flag that was given.
    refused(
        &info("rgba16.png", &["--decode", "rgbm6"]),
        &["--decode rgbm6", "8-bit RGBA"],
    );
}

/// A 16 x 8 RGB EXR of two parts named `names` (bytes as stored), ZIP16 in 16 x 16 tiles when
/// `tiled`.
fn two_parts(names: [&[u8]; 2], tiled: bool) -> Vec<u8> {
    use exr::prelude::*;
    let part = |name: &[u8], v: f32| {
        let attributes = LayerAttributes {
            layer_name: Some(Text::from_slice_unchecked(name)),
            ..Default::default()
        };
        Layer::new(
            (16, 8),
            attributes,
            Encoding {
                compression: Compression::ZIP16,
                blocks: if tiled {
                    Blocks::Tiles(Vec2(16, 16))
                } else {
                    Blocks::ScanLines
                },
                line_order: LineOrder::Increasing,
            },
            SpecificChannels::rgb(move |_: Vec2<usize>| (v, v, v)),
        )
    };
    let image = exr::image::Image::empty(ImageAttributes::new(IntegerBounds::from_dimensions((
        16, 8,
    ))))
    .with_layer(part(names[0], 0.5))
    .with_layer(part(names[1], 2.0));
    let mut out = Vec::new();
    image
        .write()
        .to_buffered(std::io::Cursor::new(&mut out))
        .unwrap();
    out
}

/// Item 10: OpenEXR stores names as UTF-8: a part named in UTF-8 is chosen by that name and
/// shown as written (they were read as Latin-1); a tiled ZIP file is not said to be "16 lines".
#[test]
fn exr_part_names_are_utf8_and_tiles_are_not_lines() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("parts.exr");
    std::fs::write(
        &p,
        two_parts(["Himmel".as_bytes(), "Straße 日".as_bytes()], true),
    )
    .unwrap();
    let info = |extra: &[&str]| {
        let out = Command::new(BIN)
            .args(["info", p.to_str().unwrap()])
            .args(extra)
            .output()
            .unwrap();
        ok(&out);
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let text = info(&[]);
    assert!(
        text.contains("tiles 16x16") && !text.contains("16 lines"),
        "{text}"
    );
    let second = info(&["--part", "Straße 日"]);
    assert!(second.contains("1 \"Straße 日\" of 2"), "{second}");
    // The part chosen by its UTF-8 name is the second (its mean is 2, the first's 0.5).
    let json = |extra: &[&str]| -> serde_json::Value {
        let mut args = vec!["--json"];
        args.extend_from_slice(extra);
        serde_json::from_str(&info(&args)).unwrap()
    };
    assert_ne!(json(&[]), json(&["--part", "Straße 日"]));
    assert_eq!(json(&["--part", "1"]), json(&["--part", "Straße 日"]));
    let scan = dir.path().join("scan.exr");
    std::fs::write(&scan, two_parts([b"a", b"b"], false)).unwrap();
    let out = Command::new(BIN)
        .args(["info", scan.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("ZIP, 16 lines"));
}

/// Item 10: preview's exposure has the range of every other command's (-32..32 stops).
#[test]
fn preview_exposure_is_bounded_as_elsewhere() {
    let dir = tempfile::tempdir().unwrap();
    for ev in ["1e9", "-33", "33"] {
        let out = Command::new(BIN)
            .current_dir(dir.path())
            .args([
                "preview",
                SKY_EXR,
                "-o",
                "p.png",
                "--size",
                "8",
                "--exposure",
                ev,
            ])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(2), "{ev}");
        let err = crate::common::stderr(&out);
        assert!(err.contains("-32..=32"), "{err}");
    }
    assert!(!dir.path().join("p.png").exists());
    let out = Command::new(BIN)
        .current_dir(dir.path())
        .args([
            "preview",
            SKY_EXR,
            "-o",
            "p.png",
            "--size",
            "8",
            "--exposure",
            "-2",
        ])
        .output()
        .unwrap();
    ok(&out);
}
