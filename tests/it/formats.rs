//! Every single-image format round-trips through the library within its precision, sRGB is
//! decoded and encoded exactly, and an independent reader (OpenImageIO) reads our EXR and HDR.

use crate::common;

use cubeforge::internals::image::{linear_to_srgb, srgb_to_linear, Image};
use cubeforge::internals::io::{Decoded, ReadOptions, WriteOptions};
use glam::Vec4;
use std::process::Command;

/// A gradient covering 0..1 in every channel, with a little above 1 in red for HDR formats.
fn ramp(hdr: bool) -> Image {
    Image::from_fn(64, 32, |x, y| {
        let u = x as f32 / 63.0;
        let v = y as f32 / 31.0;
        Vec4::new(
            if hdr { u * 8.0 } else { u },
            v,
            (u + v) * 0.5,
            1.0 - 0.5 * v,
        )
    })
}

fn round_trip(name: &str, img: &Image, opts: &WriteOptions, ropts: &ReadOptions) -> Image {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    let bytes = cubeforge::internals::output::encode_image(&path, img, opts).unwrap();
    std::fs::write(&path, bytes).unwrap();
    match cubeforge::internals::convert::read(&path, ropts).unwrap().0 {
        Decoded::Image(i) => i,
        Decoded::Cube(_) => panic!("single image expected"),
    }
}

/// Largest error of the colour channels, measured after sRGB encoding (what 8 bits quantise).
fn max_srgb_err(a: &Image, b: &Image) -> f32 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| {
            (0..3)
                .map(|c| (linear_to_srgb(p[c]) - linear_to_srgb(q[c])).abs())
                .fold(0.0, f32::max)
        })
        .fold(0.0, f32::max)
}

#[test]
fn srgb_transfer_is_the_standard_one() {
    assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-6);
    assert!((linear_to_srgb(0.214_041_14) - 0.5).abs() < 1e-6);
    assert_eq!(srgb_to_linear(0.0), 0.0);
    assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
    for i in 0..=255 {
        let v = i as f32 / 255.0;
        assert!((linear_to_srgb(srgb_to_linear(v)) - v).abs() < 1e-5);
    }
}

#[test]
fn eight_bit_formats_round_trip_within_half_a_step() {
    let img = ramp(false);
    let r = ReadOptions::default();
    for name in ["a.png", "a.tga"] {
        let back = round_trip(name, &img, &WriteOptions::default(), &r);
        assert!(max_srgb_err(&img, &back) <= 0.5 / 255.0 + 1e-6, "{name}");
        let alpha = img
            .pixels
            .iter()
            .zip(&back.pixels)
            .map(|(p, q)| (p.w - q.w).abs())
            .fold(0.0, f32::max);
        assert!(alpha <= 0.5 / 255.0 + 1e-6, "{name} alpha {alpha}");
    }
    // JPEG is lossy and has no alpha: a looser bound, alpha comes back as 1.
    let back = round_trip("a.jpg", &img, &WriteOptions::default(), &r);
    let e = max_srgb_err(&img, &back);
    assert!(e < 12.0 / 255.0, "JPEG error {}", e * 255.0);
    assert!(back.pixels.iter().all(|p| p.w == 1.0));
}

#[test]
fn sixteen_bit_png_is_srgb_too_and_finer() {
    let img = ramp(false);
    let w = WriteOptions {
        png16: true,
        ..WriteOptions::default()
    };
    let back = round_trip("a.png", &img, &w, &ReadOptions::default());
    assert!(max_srgb_err(&img, &back) <= 0.5 / 65535.0 + 1e-6);
}

#[test]
fn linear_flag_stores_data_as_is() {
    let img = ramp(false);
    let w = WriteOptions {
        linear: true,
        ..WriteOptions::default()
    };
    let r = ReadOptions {
        linear: true,
        ..ReadOptions::default()
    };
    let back = round_trip("a.png", &img, &w, &r);
    for (p, q) in img.pixels.iter().zip(&back.pixels) {
        assert!((*p - *q).abs().max_element() <= 0.5 / 255.0 + 1e-6);
    }
    // Read without the flag, the same file is decoded as sRGB colour: different values.
    let srgb = round_trip("b.png", &img, &w, &ReadOptions::default());
    assert!((srgb.get(32, 16).x - img.get(32, 16).x).abs() > 0.1);
}

#[test]
fn float_formats_keep_hdr_values() {
    let img = ramp(true);
    let r = ReadOptions::default();
    let exr = round_trip("a.exr", &img, &WriteOptions::default(), &r);
    for (p, q) in img.pixels.iter().zip(&exr.pixels) {
        // Half float: 11 significant bits.
        assert!((*p - *q).abs().max_element() <= p.abs().max_element() / 1024.0 + 1e-7);
    }
    let hdr = round_trip("a.hdr", &img, &WriteOptions::default(), &r);
    for (p, q) in img.pixels.iter().zip(&hdr.pixels) {
        // RGBE: 8-bit mantissas sharing the largest channel's exponent; alpha is not stored.
        let m = p.truncate().max_element();
        assert!((p.truncate() - q.truncate()).abs().max_element() <= m / 128.0 + 1e-7);
        assert_eq!(q.w, 1.0);
    }
    assert!(exr.get(63, 0).x > 7.9, "HDR values above 1 survive");
}

/// OpenImageIO reads our EXR and HDR files with the right size, channels and values.
#[test]
fn openimageio_reads_our_float_files() {
    if !common::oiiotool() {
        return;
    }
    let img = ramp(true);
    let dir = tempfile::tempdir().unwrap();
    for name in ["a.exr", "a.hdr"] {
        let path = dir.path().join(name);
        std::fs::write(
            &path,
            cubeforge::internals::output::encode_image(&path, &img, &WriteOptions::default())
                .unwrap(),
        )
        .unwrap();
        let info = Command::new("oiiotool")
            .args(["--info", "-v"])
            .arg(&path)
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&info.stdout);
        assert!(info.status.success(), "{name}: {text}");
        let words: Vec<&str> = text.split_whitespace().collect();
        assert!(
            words.windows(3).any(|w| w == ["64", "x", "32,"]),
            "{name}: {text}"
        );
        // The brightest red is 8.0 (column 63).
        let stats = Command::new("oiiotool")
            .arg("--stats")
            .arg(&path)
            .output()
            .unwrap();
        let s = String::from_utf8_lossy(&stats.stdout);
        let max_line = s
            .lines()
            .find(|l| l.trim_start().starts_with("Stats Max"))
            .unwrap_or_else(|| panic!("{name}: no stats in {s}"));
        let first: f32 = max_line
            .split(':')
            .nth(1)
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{name}: cannot parse {max_line}"));
        assert!((first - 8.0).abs() < 0.07, "{name}: max red {first}");
    }
}

/// Our ZIP blocks (compressed by us, the file laid out by the exr crate) decode to exactly the
/// half-float values written, in OpenImageIO and in cubeforge: blocks that shrink and blocks
/// stored as they are (noise), a partial last block, with and without alpha.
#[test]
fn exr_zip_blocks_read_back_exactly() {
    for (w, h) in [(45, 37), (3, 5)] {
        exr_zip_round_trip(w, h, false);
    }
}

/// The same files, read by OpenImageIO.
#[test]
fn openimageio_reads_our_zip_blocks_exactly() {
    if !common::oiiotool() {
        return;
    }
    for (w, h) in [(45, 37), (3, 5)] {
        exr_zip_round_trip(w, h, true);
    }
}

/// PIZ files OpenEXR itself wrote (through oiiotool), half and float, RGB and RGBA, smooth
/// (the 14-bit wavelet) and noisy (the 16-bit one, long Huffman codes), partial last blocks:
/// read exactly as their uncompressed copies.
#[test]
fn openexr_piz_files_read_exactly() {
    if !common::oiiotool() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let read =
        |p: &std::path::Path| match cubeforge::internals::convert::read(p, &ReadOptions::default())
            .unwrap()
            .0
        {
            Decoded::Image(img) => img,
            _ => panic!("not an image"),
        };
    for (w, h) in [(256, 128), (37, 19), (1, 33)] {
        for (kind, noise) in [("smooth", false), ("noisy", true)] {
            for (ty, ch) in [("half", 3), ("float", 3), ("float", 4), ("half", 4)] {
                let what = format!("{w}x{h} {kind} {ty} {ch} channels");
                let (piz, plain) = (dir.path().join("p.exr"), dir.path().join("n.exr"));
                let size = format!("{w}x{h}");
                let ramp = if ch == 3 {
                    "fill:left=0,0.001,0:right=100,50,2500"
                } else {
                    "fill:left=0,0.001,0,1:right=100,50,2500,0.5"
                };
                let mut args = vec!["--pattern", ramp, &size];
                let channels = ch.to_string();
                args.push(&channels);
                if noise {
                    args.extend([
                        "--pattern",
                        "noise:type=gaussian:mean=0:stddev=3",
                        &size,
                        &channels,
                        "--add",
                    ]);
                }
                let status = Command::new("oiiotool")
                    .args(&args)
                    .args(["-d", ty, "--compression", "piz", "-o"])
                    .arg(&piz)
                    .status()
                    .unwrap();
                assert!(status.success(), "{what}: oiiotool");
                let status = Command::new("oiiotool")
                    .arg(&piz)
                    .args(["--compression", "none", "-o"])
                    .arg(&plain)
                    .status()
                    .unwrap();
                assert!(status.success(), "{what}: oiiotool");
                let (a, b) = (read(&piz), read(&plain));
                assert_eq!((a.width, a.height), (w, h), "{what}");
                assert!(a == b, "{what}: the PIZ file reads otherwise than its copy");
            }
        }
    }
}

fn exr_zip_round_trip(w: usize, h: usize, oiiotool: bool) {
    let noise = |x: usize, y: usize, c: usize| {
        let mut k = (x as u32).wrapping_mul(0x9E37_79B9)
            ^ (y as u32 * 4 + c as u32).wrapping_mul(0x85EB_CA6B);
        k ^= k >> 15;
        k = k.wrapping_mul(0x2C1B_3C6D);
        k ^= k >> 12;
        (k & 0xffff) as f32 / 4096.0
    };
    for alpha in [false, true] {
        let img = Image::from_fn(w, h, |x, y| {
            if y < 16 && w > 8 {
                // Smooth: compresses.
                Vec4::new(x as f32 * 0.1, y as f32 * 0.01, 0.5, 1.0)
            } else {
                // Noise: a block that does not shrink (3 x 5 here) is stored raw.
                Vec4::new(noise(x, y, 0), noise(x, y, 1), noise(x, y, 2), 1.0)
            }
        });
        let img = if alpha {
            Image::from_fn(w, h, |x, y| {
                img.get(x, y).truncate().extend((x % 7) as f32 / 6.0)
            })
        } else {
            img
        };
        let half = |v: f32| half::f16::from_f32(v).to_f32();
        let want = Image::from_fn(w, h, |x, y| {
            let p = img.get(x, y);
            Vec4::new(half(p.x), half(p.y), half(p.z), half(p.w))
        });
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("z.exr");
        std::fs::write(
            &path,
            cubeforge::internals::output::encode_image(&path, &img, &WriteOptions::default())
                .unwrap(),
        )
        .unwrap();
        let (back, _) =
            cubeforge::internals::convert::read(&path, &ReadOptions::default()).unwrap();
        let Decoded::Image(back) = back else {
            panic!("not an image")
        };
        assert_eq!(
            back, want,
            "alpha {alpha}: cubeforge reads back other values"
        );

        if !oiiotool {
            continue;
        }
        let dump = Command::new("oiiotool")
            .arg("--dumpdata")
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            dump.status.success(),
            "{}",
            String::from_utf8_lossy(&dump.stderr)
        );
        let text = String::from_utf8_lossy(&dump.stdout);
        let mut seen = 0;
        for line in text.lines() {
            let Some(rest) = line.trim_start().strip_prefix("Pixel (") else {
                continue;
            };
            let (xy, values) = rest.split_once("):").unwrap();
            let mut xy = xy.split(',').map(|v| v.trim().parse::<usize>().unwrap());
            let (x, y) = (xy.next().unwrap(), xy.next().unwrap());
            let v: Vec<f32> = values
                .split_whitespace()
                .map(|v| v.parse().unwrap())
                .collect();
            let p = want.get(x, y);
            let expect: Vec<f32> = if alpha {
                vec![p.x, p.y, p.z, p.w]
            } else {
                vec![p.x, p.y, p.z]
            };
            assert_eq!(v.len(), expect.len(), "alpha {alpha}: {line}");
            for (a, b) in v.iter().zip(&expect) {
                assert!(
                    (a - b).abs() <= b.abs() * 1e-5,
                    "alpha {alpha} at ({x}, {y}): {v:?} vs {expect:?}"
                );
            }
            seen += 1;
        }
        assert_eq!(
            seen,
            w * h,
            "alpha {alpha}: OpenImageIO printed {seen} pixels"
        );
    }
}
