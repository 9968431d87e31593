//! Every single-image format round-trips through the library within its precision, sRGB is
//! decoded and encoded exactly, and an independent reader (OpenImageIO) reads our EXR and HDR.

use cubeforge::image::{linear_to_srgb, srgb_to_linear, Image};
use cubeforge::io::{self, Decoded, ReadOptions, WriteOptions};
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
    let bytes = io::encode_image(&path, img, opts).unwrap();
    std::fs::write(&path, bytes).unwrap();
    match io::read(&path, ropts).unwrap().0 {
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

fn oiiotool() -> bool {
    Command::new("oiiotool").arg("--version").output().is_ok()
}

/// OpenImageIO reads our EXR and HDR files with the right size, channels and values.
#[test]
fn openimageio_reads_our_float_files() {
    if !oiiotool() {
        eprintln!("skipped: oiiotool not installed (apt-get install openimageio-tools)");
        return;
    }
    let img = ramp(true);
    let dir = tempfile::tempdir().unwrap();
    for name in ["a.exr", "a.hdr"] {
        let path = dir.path().join(name);
        std::fs::write(
            &path,
            io::encode_image(&path, &img, &WriteOptions::default()).unwrap(),
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
