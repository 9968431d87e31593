//! Tiny files whose headers claim huge sizes: refused from their size, or stopped where
//! their data ends.

use crate::harness::{be16, encoded, test_image};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{Decoded, Limits, ReadOptions, WriteOptions};
use glam::Vec4;
use std::path::Path;

/// Limits that let a claimed size through, so that only the file's own checks can stop it.
fn generous() -> Limits {
    Limits {
        max_pixels: 1 << 30,
        max_dimension: 1 << 16,
        max_memory: u64::MAX,
        ..Limits::default()
    }
}

fn read_with(path: &Path, bytes: &[u8], limits: Limits) -> cubeforge::Result<Image> {
    std::fs::write(path, bytes).unwrap();
    let opts = ReadOptions {
        limits,
        ..ReadOptions::default()
    };
    match cubeforge::internals::convert::read(path, &opts)?.0 {
        Decoded::Image(img) => Ok(img),
        Decoded::Cube(_) => panic!("{}: a cube map", path.display()),
    }
}

/// Where a JPEG's frame header keeps its height (its width follows).
fn jpeg_size_at(b: &[u8]) -> usize {
    let mut at = 2;
    while !(0xc0..=0xc2).contains(&b[at + 1]) {
        at += 2 + be16(b, at + 2);
    }
    at + 5
}

/// Item 2: a 1 KB JPEG whose header claims up to 16384x16384 pixels (within the pixel limit,
/// the memory budget lifted) is refused from its size, before the decoder runs over blocks it
/// has no data for; a blank JPEG, the least data a real one needs per pixel, still reads.
#[test]
fn a_tiny_jpeg_claiming_a_huge_size_is_refused_before_decoding() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("claims.jpg");
    let small = encoded("x.jpg", &test_image(16, 16), &WriteOptions::default());
    assert!(small.len() < 2048, "{} bytes", small.len());
    let at = jpeg_size_at(&small);
    for (w, h) in [
        (16384u16, 16384u16),
        (65500, 4096),
        (4096, 4096),
        (2048, 1024),
    ] {
        let mut b = small.clone();
        b[at..at + 2].copy_from_slice(&h.to_be_bytes());
        b[at + 2..at + 4].copy_from_slice(&w.to_be_bytes());
        let e = read_with(&path, &b, generous()).unwrap_err().to_string();
        assert!(
            e.contains("claims.jpg") && e.contains("too few"),
            "{w}x{h}: {e}"
        );
        assert!(e.contains(&format!("{w}x{h}")), "{e}");
    }
    // Blank: one DC code and an end-of-block per block, 16 times the floor or more.
    let blank = encoded(
        "x.jpg",
        &Image::filled(1024, 768, Vec4::splat(0.5)),
        &WriteOptions::default(),
    );
    println!("blank 1024x768 JPEG: {} bytes", blank.len());
    let img = read_with(&path, &blank, generous()).unwrap();
    assert_eq!((img.width, img.height), (1024, 768));
    // The same file cut to an eighth still reads (the rest grey), as it did.
    let img = read_with(&path, &blank[..blank.len() / 8], generous()).unwrap();
    assert_eq!((img.width, img.height), (1024, 768));
}

/// A grey PNG made here: `rows` (each starting with its filter byte) deflated into one IDAT.
fn png_file(w: u32, h: u32, bit_depth: u8, interlace: u8, rows: &[u8]) -> Vec<u8> {
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |kind: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let start = out.len();
        out.extend_from_slice(kind);
        out.extend_from_slice(data);
        let crc = libdeflater::crc32(&out[start..]);
        out.extend_from_slice(&crc.to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[bit_depth, 0, 0, 0, interlace]);
    chunk(b"IHDR", &ihdr);
    let mut z = libdeflater::Compressor::new(libdeflater::CompressionLvl::best());
    let mut idat = vec![0u8; z.zlib_compress_bound(rows.len())];
    let n = z.zlib_compress(rows, &mut idat).unwrap();
    chunk(b"IDAT", &idat[..n]);
    chunk(b"IEND", &[]);
    out
}

/// PNG's counterpart: a 200-byte PNG claiming 16384x16384 (1-bit grey, plain and interlaced)
/// holds a few rows, and the decoder stops where they end, having inflated no more than the
/// file holds (deflate expands at most about 1032 times). A blank 2048x2048 PNG of a few
/// thousand bytes, more pixels per byte than any JPEG, is genuine and reads.
#[test]
fn a_tiny_png_claiming_a_huge_size_stops_where_its_data_ends() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("claims.png");
    for interlace in [0, 1] {
        let rows = vec![0u8; 8 * (1 + 16384 / 8)];
        let b = png_file(16384, 16384, 1, interlace, &rows);
        assert!(b.len() < 256, "{} bytes", b.len());
        let e = read_with(&path, &b, generous()).unwrap_err().to_string();
        assert!(e.contains("claims.png"), "{e}");
        println!("{e}");
    }
    let rows: Vec<u8> = (0..2048)
        .flat_map(|_| std::iter::once(0).chain(std::iter::repeat_n(0xff, 2048 / 8)))
        .collect();
    let b = png_file(2048, 2048, 1, 0, &rows);
    assert!(b.len() < 4096, "{} bytes", b.len());
    let img = read_with(&path, &b, generous()).unwrap();
    assert_eq!((img.width, img.height), (2048, 2048));
    assert_eq!(img.get(2047, 2047), Vec4::ONE);
}

/// The same for the other formats whose header states a size: a TGA (run-length and flat)
/// claiming 8192x8192 and a Radiance HDR claiming 16384x16384 in a few dozen bytes stop
/// where their data ends.
#[test]
fn tiny_tga_and_hdr_files_claiming_a_huge_size_stop_where_their_data_ends() {
    let dir = tempfile::tempdir().unwrap();
    for image_type in [2u8, 10] {
        let path = dir.path().join(format!("claims{image_type}.tga"));
        let mut b = vec![0, 0, image_type, 0, 0, 0, 0, 0, 0, 0, 0, 0];
        // 8192x8192 (the image crate's buffer, 256 MiB, is allocated before reading).
        b.extend_from_slice(&8192u16.to_le_bytes());
        b.extend_from_slice(&8192u16.to_le_bytes());
        b.extend_from_slice(&[32, 8]);
        // One run of 128 texels, or 8 flat texels.
        b.extend_from_slice(&[0xff, 1, 2, 3, 4]);
        b.extend_from_slice(&[9; 28]);
        let e = read_with(&path, &b, generous()).unwrap_err().to_string();
        assert!(e.contains(&format!("claims{image_type}.tga")), "{e}");
    }
    let path = dir.path().join("claims.hdr");
    let mut b = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16384 +X 16384\n".to_vec();
    b.extend_from_slice(&[2, 2, 0x40, 0]);
    for _ in 0..4 {
        b.extend_from_slice(&[128 + 127, 7]);
    }
    let e = read_with(&path, &b, generous()).unwrap_err().to_string();
    assert!(e.contains("claims.hdr") && e.contains("scanline 1"), "{e}");
}
