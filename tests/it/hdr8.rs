//! RGBM (range 6, 7, 8 and 16) and RGBD in 8-bit PNGs and RGBA8 KTX2/DDS: written by
//! `--hdr-encoding`, their bytes decoded here by the published formulas, and read back by
//! `--decode` (a KTX2 by its metadata, a PNG by its text chunk, alone).

use crate::common::{self, read_image, run, stderr};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, Decoded, ReadOptions};
use glam::Vec4;
use std::path::Path;

/// A panorama with radiance from 0.001 to 200: the demo sky scaled, a sun added.
fn source(dir: &Path) -> std::path::PathBuf {
    let mut img = read_image(Path::new("fixtures/sky.exr"));
    let w = img.width;
    for (i, p) in img.pixels.iter_mut().enumerate() {
        let (x, y) = (i % w, i / w);
        *p = (p.truncate() * 1.5).extend(1.0);
        if (x as i32 - 40).abs() < 3 && (y as i32 - 20).abs() < 3 {
            *p = Vec4::new(200.0, 180.0, 150.0, 1.0);
        }
    }
    let path = dir.join("src.exr");
    let bytes = cubeforge::internals::output::encode_image(
        &path,
        &img,
        &io::WriteOptions {
            exr_float: io::ExrFloat::F32,
            ..Default::default()
        },
    )
    .unwrap();
    std::fs::write(&path, bytes).unwrap();
    path
}

/// The formulas as published: three.js's RGBMToLinear (rgb * a * range) and Babylon's
/// fromRGBD (pow(rgb, 2.2) / a), over bytes read by the `image` crate.
fn published(path: &Path, encoding: &str) -> Image {
    let png = image::open(path).unwrap().to_rgba8();
    let (w, h) = png.dimensions();
    let mut out = Image::new(w as usize, h as usize);
    for (o, p) in out.pixels.iter_mut().zip(png.pixels()) {
        let [r, g, b, a] = p.0.map(|v| v as f32 / 255.0);
        *o = match encoding.strip_prefix("rgbm") {
            Some(range) => Vec4::new(r, g, b, 0.0) * a * range.parse::<f32>().unwrap(),
            None => Vec4::new(r.powf(2.2), g.powf(2.2), b.powf(2.2), 0.0) / a.max(1.0 / 255.0),
        }
        .truncate()
        .extend(1.0);
    }
    out
}

fn read_as(path: &Path, decode: Option<io::HdrEncoding>) -> Decoded {
    let opts = ReadOptions {
        hdr_encoding: decode,
        ..Default::default()
    };
    cubeforge::internals::convert::read(path, &opts).unwrap().0
}

/// Largest error relative to max(value, floor), over texels within the encoding's range.
fn rel_error(got: &Image, want: &Image, range: f32, floor: f32) -> f32 {
    let mut worst = 0.0f32;
    for (g, w) in got.pixels.iter().zip(&want.pixels) {
        let top = w.truncate().max_element();
        if top > range {
            continue;
        }
        let e = (g - w).truncate().abs().max_element() / top.max(floor);
        worst = worst.max(e);
    }
    worst
}

#[test]
fn pngs_decode_by_the_published_formulas_and_read_back() {
    let dir = tempfile::tempdir().unwrap();
    let src = source(dir.path());
    let float = dir.path().join("ref.exr");
    let r = run([
        "convert",
        src.to_str().unwrap(),
        "-o",
        float.to_str().unwrap(),
        "--to",
        "equirect",
        "--size",
        "64",
    ]);
    assert!(r.status.success(), "{}", stderr(&r));
    let reference = read_image(&float);
    let mut errors = Vec::new();
    for (encoding, range, bound) in [
        ("rgbm6", 6.0, 0.03),
        ("rgbm7", 7.0, 0.03),
        ("rgbm8", 8.0, 0.03),
        ("rgbm16", 16.0, 0.03),
        ("rgbd", 255.0, 0.03),
    ] {
        let png = dir.path().join(format!("{encoding}.png"));
        let r = run([
            "convert",
            src.to_str().unwrap(),
            "-o",
            png.to_str().unwrap(),
            "--to",
            "equirect",
            "--size",
            "64",
            "--hdr-encoding",
            encoding,
        ]);
        assert!(r.status.success(), "{}", stderr(&r));
        if range < 200.0 {
            // The sun is beyond RGBM's range: counted, with the way to keep it.
            assert!(
                stderr(&r).contains(&format!("beyond {range}")),
                "{}",
                stderr(&r)
            );
            // The loader line: three.js's RGBMLoader assumes 7 unless told the range.
            let said = String::from_utf8_lossy(&r.stdout).to_string();
            let line = format!("new RGBMLoader().setMaxRange({range})");
            assert!(said.contains(&line), "{encoding}: {said}");
        }
        let by_formula = published(&png, encoding);
        let e = io::HdrEncoding::ALL
            .into_iter()
            .find(|e| e.name() == encoding)
            .unwrap();
        let Decoded::Image(ours) = read_as(&png, Some(e)) else {
            panic!("an image")
        };
        // cubeforge's decode is the published one.
        let same = rel_error(&ours, &by_formula, f32::MAX, 1e-3);
        assert!(same < 1e-5, "{encoding}: decode differs by {same}");
        // The PNG names its encoding in a tEXt chunk: read back with no --decode, and Pillow
        // (an independent reader, checking the chunk's CRC) finds the same text.
        let Decoded::Image(marked) = read_as(&png, None) else {
            panic!("an image")
        };
        assert!(
            marked.pixels == ours.pixels,
            "{encoding}: the marker was not read"
        );
        if common::pillow_png() {
            let o = std::process::Command::new("python3")
                .args([
                    "-c",
                    "import sys; from PIL import Image; im = Image.open(sys.argv[1]); im.load(); \
                     print(im.info['cubeforge.hdrEncoding'])",
                    png.to_str().unwrap(),
                ])
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), encoding);
        }
        // And the bytes hold the radiance: within the 8-bit grid of the largest channel
        // (relative to values of at least 1/16; darker ones hold less precision).
        let err = rel_error(&ours, &reference, range, 1.0 / 16.0);
        eprintln!(
            "{encoding}: largest error {:.2}% within its range",
            100.0 * err
        );
        assert!(err < bound, "{encoding}: {err}");
        errors.push((encoding, err));
    }
    let rgbm = errors
        .iter()
        .filter(|(e, _)| e.starts_with("rgbm"))
        .map(|(_, v)| *v)
        .fold(0.0f32, f32::max);
    let rgbd = errors
        .iter()
        .find(|(e, _)| *e == "rgbd")
        .map_or(0.0, |(_, v)| *v);
    let text = format!(
        "{:.2}% (RGBM) and {:.2}% (RGBD)",
        100.0 * rgbm,
        100.0 * rgbd
    );
    crate::figures::check("docs/formats.md", "rgbm rgbd", &text);
    // The sun comes back from RGBD (up to 255), not from RGBM (clamped to 6 or 8).
    let Decoded::Image(d) = read_as(&dir.path().join("rgbd.png"), Some(io::HdrEncoding::Rgbd))
    else {
        panic!("an image")
    };
    let top = d.pixels.iter().map(|p| p.x).fold(0.0, f32::max);
    assert!(top > 150.0, "RGBD keeps the sun: {top}");
}

#[test]
fn rgba8_containers_carry_their_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let src = source(dir.path());
    for (name, encoding) in [
        ("m.ktx2", "rgbm6"),
        ("d.ktx2", "rgbd"),
        ("plain.ktx2", "rgbm16"),
        ("m.dds", "rgbm8"),
    ] {
        let out = dir.path().join(name);
        let mut args = vec![
            "convert",
            src.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--size",
            "32",
            "--hdr-encoding",
            encoding,
            "--gpu-format",
            "rgba8",
        ];
        let keys = name != "plain.ktx2" && name.ends_with(".ktx2");
        if keys {
            args.push("--cubeforge-keys");
        }
        let r = run(&args);
        assert!(r.status.success(), "{name}: {}", stderr(&r));
        let e = io::HdrEncoding::ALL
            .into_iter()
            .find(|e| e.name() == encoding)
            .unwrap();
        // A KTX2 with cubeforge's keys says what it holds; one without, like a DDS, needs
        // --decode, and the command says so.
        let decode = (!keys).then_some(e);
        if name == "plain.ktx2" {
            let said = String::from_utf8_lossy(&r.stdout).to_string();
            assert!(said.contains("--decode rgbm16"), "{said}");
        }
        let Decoded::Cube(cube) = read_as(&out, decode) else {
            panic!("a cube")
        };
        let top = cube.levels[0]
            .iter()
            .flat_map(|f| f.pixels.iter())
            .map(|p| p.truncate().max_element())
            .fold(0.0, f32::max);
        assert!(
            top > 1.5 && top <= e.largest() + 1e-3,
            "{name}: brightest {top}"
        );
        assert!(cube.levels.len() > 1, "{name}: its mips");
        let info = run(["info", out.to_str().unwrap()]);
        let text = String::from_utf8_lossy(&info.stdout).to_string();
        if decode.is_none() {
            assert!(
                text.contains(&format!("as {}", encoding.to_uppercase())),
                "{text}"
            );
        }
    }
}

#[test]
fn files_that_cannot_hold_an_encoding_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let src = source(dir.path());
    for (out, extra) in [
        ("a.exr", None),
        ("b.ktx2", None),
        ("c.png", Some("--png16")),
    ] {
        let path = dir.path().join(out);
        let mut args = vec![
            "convert",
            src.to_str().unwrap(),
            "-o",
            path.to_str().unwrap(),
        ];
        args.extend(["--size", "16", "--hdr-encoding", "rgbm6"]);
        args.extend(extra);
        let r = run(&args);
        assert!(!r.status.success(), "{out}");
        assert!(
            stderr(&r).contains("--hdr-encoding rgbm6"),
            "{}",
            stderr(&r)
        );
        assert!(!path.exists(), "{out}: no partial output");
    }
    // Decoding a float file is refused in one line.
    let r = run(["info", src.to_str().unwrap(), "--decode", "rgbd"]);
    assert!(!r.status.success());
    assert!(stderr(&r).contains("--decode rgbd"), "{}", stderr(&r));
}

/// The refusal comes from `validate`, before any input is read: the jobs say it of outputs
/// that cannot hold an encoding even when the input does not exist.
#[test]
fn the_jobs_refuse_an_encoding_in_validate() {
    use cubeforge::internals::io::HdrEncoding;
    use cubeforge::internals::jobs::{ConvertJob, IrradianceJob, Job, PrefilterJob};
    use cubeforge::internals::output::Destination;
    let dir = tempfile::tempdir().unwrap();
    let missing = vec![dir.path().join("nowhere.exr")];
    let out = |name: &str| Destination::Path(dir.path().join(name));
    let e = Some(HdrEncoding::Rgbm6);
    let enc = cubeforge::Encoding {
        hdr_encoding: e,
        ..Default::default()
    };
    let jobs: Vec<Box<dyn Job>> = vec![
        Box::new(ConvertJob {
            encoding: enc,
            ..ConvertJob::new(missing.clone(), out("a.exr"))
        }),
        Box::new(PrefilterJob {
            encoding: enc,
            ..PrefilterJob::new(missing.clone(), out("b.ktx2"))
        }),
        Box::new(IrradianceJob {
            encoding: enc,
            ..IrradianceJob::new(missing.clone(), out("c.hdr"))
        }),
    ];
    for job in jobs {
        let err = job.validate().expect_err("refused").to_string();
        assert!(err.contains("rgbm6 stores four 8-bit channels"), "{err}");
    }
    // And what holds one passes.
    let ok = ConvertJob {
        encoding: enc,
        ..ConvertJob::new(missing, out("d.png"))
    };
    assert!(ok.validate().is_ok());
}

/// A prefiltered chain in RGBD (up to 255) does not warn of texels clipping at 1: the
/// encoding's own range is what clamps (issue 48, item 10); plain RGBA8 still warns.
#[test]
fn prefilter_warns_of_clipping_by_the_encodings_range() {
    let dir = tempfile::tempdir().unwrap();
    let src = source(dir.path());
    let prefilter = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "prefilter",
            src.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--filter",
            "box",
            "--size",
            "16",
            "--gpu-format",
            "rgba8",
        ];
        args.extend_from_slice(extra);
        let r = run(&args);
        assert!(r.status.success(), "{name}: {}", stderr(&r));
        stderr(&r)
    };
    let rgbd = prefilter("d.ktx2", &["--hdr-encoding", "rgbd"]);
    assert!(!rgbd.contains("clip"), "{rgbd}");
    let plain = prefilter("p.ktx2", &[]);
    assert!(plain.contains("clip"), "{plain}");
}
