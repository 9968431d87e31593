//! Seeded mutations of image files: PNG, JPEG, TGA, HDR, EXR, KTX2 and DDS.

use crate::harness::{be16, encoded, formats, real_files, test_cube, test_image};
use crate::mutator::Field;
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, GpuFormat, WriteOptions};

/// PNG: IHDR's fields and every chunk's length.
pub fn png_fields(b: &[u8]) -> Vec<Field> {
    let mut f = vec![Field::be(24, 1), Field::be(25, 1), Field::be(28, 1)];
    let mut at = 8;
    while at + 8 <= b.len() {
        f.push(Field::be(at, 4));
        let len = u32::from_be_bytes(b[at..at + 4].try_into().unwrap()) as usize;
        if &b[at + 4..at + 8] == b"IHDR" {
            f.extend([Field::be(at + 8, 4), Field::be(at + 12, 4)]);
        }
        at += 12 + len;
    }
    f
}

/// Rewrites every PNG chunk's CRC that lies inside the file, so a mutation reaches the
/// decoder behind the checksum.
pub fn png_fix_crcs(b: &mut [u8]) {
    let mut at = 8;
    while at + 8 <= b.len() {
        let len = u32::from_be_bytes(b[at..at + 4].try_into().unwrap()) as usize;
        let Some(end) = (at + 8).checked_add(len).filter(|&e| e + 4 <= b.len()) else {
            return;
        };
        let crc = libdeflater::crc32(&b[at + 4..end]);
        b[end..end + 4].copy_from_slice(&crc.to_be_bytes());
        at = end + 4;
    }
}

/// JPEG: every segment's length, the frame's sizes, component counts and sampling factors,
/// the restart interval and the scans' spectral selection and approximation.
pub fn jpeg_fields(b: &[u8]) -> Vec<Field> {
    let mut f = Vec::new();
    let mut at = 2;
    while at + 4 <= b.len() && b[at] == 0xff {
        let marker = b[at + 1];
        let len = be16(b, at + 2);
        f.push(Field::be(at + 2, 2));
        let body = at + 4;
        match marker {
            0xc0..=0xc2 => {
                f.extend([
                    Field::be(body, 1),
                    Field::be(body + 1, 2),
                    Field::be(body + 3, 2),
                    Field::be(body + 5, 1),
                ]);
                for c in 0..b[body + 5] as usize {
                    f.extend([
                        Field::be(body + 6 + 3 * c + 1, 1),
                        Field::be(body + 6 + 3 * c + 2, 1),
                    ]);
                }
            }
            0xdd => f.push(Field::be(body, 2)),
            0xda => {
                let n = b[body] as usize;
                f.push(Field::be(body, 1));
                for c in 0..n {
                    f.push(Field::be(body + 1 + 2 * c + 1, 1));
                }
                f.extend([
                    Field::be(body + 1 + 2 * n, 1),
                    Field::be(body + 2 + 2 * n, 1),
                    Field::be(body + 3 + 2 * n, 1),
                ]);
                break;
            }
            _ => {}
        }
        at += 2 + len;
    }
    f
}

/// TGA: every field of the 18-byte header.
pub fn tga_fields() -> Vec<Field> {
    let mut f: Vec<Field> = [0, 1, 2, 7, 16, 17].map(|at| Field::le(at, 1)).to_vec();
    f.extend([3, 5, 8, 10, 12, 14].map(|at| Field::le(at, 2)));
    f
}

/// Radiance HDR: the first scanline's header (its numbers in text are changed as text).
pub fn hdr_fields(b: &[u8]) -> Vec<Field> {
    let Some(line) = b.windows(4).position(|w| w == b"\n-Y ") else {
        return Vec::new();
    };
    let start = line + 1 + b[line + 1..].iter().position(|&c| c == b'\n').unwrap() + 1;
    vec![
        Field::be(start, 2),
        Field::be(start + 2, 2),
        Field::be(start, 4),
    ]
}

/// KTX2: the header's words, the index's, the level index, the first descriptor words and the
/// first key/value length.
pub fn ktx2_fields(b: &[u8]) -> Vec<Field> {
    let mut f: Vec<Field> = (0..13).map(|i| Field::le(12 + 4 * i, 4)).collect();
    f.extend([Field::le(64, 8), Field::le(72, 8)]);
    let levels = u32::from_le_bytes(b[40..44].try_into().unwrap()).max(1) as usize;
    for l in 0..levels {
        f.extend((0..3).map(|i| Field::le(80 + 24 * l + 8 * i, 8)));
    }
    let dfd = u32::from_le_bytes(b[48..52].try_into().unwrap()) as usize;
    f.extend((0..8).map(|i| Field::le(dfd + 4 * i, 4)));
    let kvd = u32::from_le_bytes(b[56..60].try_into().unwrap()) as usize;
    f.push(Field::le(kvd, 4));
    f
}

/// DDS: every word of the header and of the DX10 header.
pub fn dds_fields() -> Vec<Field> {
    (1..37).map(|i| Field::le(4 * i, 4)).collect()
}

#[test]
fn png_mutations() {
    let img = test_image(40, 24);
    let mut sources = Vec::new();
    for (what, opts) in [
        ("PNG 8-bit", WriteOptions::default()),
        (
            "PNG 16-bit",
            WriteOptions {
                png16: true,
                ..WriteOptions::default()
            },
        ),
    ] {
        let b = encoded("x.png", &img, &opts);
        sources.push((what.to_string(), b.clone(), png_fields(&b)));
    }
    // Grey and palette files, as other programs write them.
    let grey = image::GrayImage::from_fn(33, 17, |x, y| image::Luma([(x * 7 + y * 3) as u8]));
    let mut b = Vec::new();
    grey.write_to(&mut std::io::Cursor::new(&mut b), image::ImageFormat::Png)
        .unwrap();
    sources.push(("PNG grey".to_string(), b.clone(), png_fields(&b)));
    for path in real_files("png", "png").into_iter().take(1) {
        let b = std::fs::read(&path).unwrap();
        sources.push((path.display().to_string(), b.clone(), png_fields(&b)));
    }
    formats(sources, "png", 0x243f_6a88_85a3_08d3, 200, png_fields);
}

#[test]
fn jpeg_mutations() {
    let img = test_image(40, 24);
    let b = encoded("x.jpg", &img, &WriteOptions::default());
    let mut sources = vec![("JPEG".to_string(), b.clone(), jpeg_fields(&b))];
    let grey = image::GrayImage::from_fn(21, 13, |x, y| image::Luma([(x * 9 + y * 5) as u8]));
    let mut b = Vec::new();
    grey.write_to(&mut std::io::Cursor::new(&mut b), image::ImageFormat::Jpeg)
        .unwrap();
    sources.push(("JPEG grey".to_string(), b.clone(), jpeg_fields(&b)));
    for path in real_files("faces/forest_ldr", "jpg").into_iter().take(2) {
        let b = std::fs::read(&path).unwrap();
        sources.push((path.display().to_string(), b.clone(), jpeg_fields(&b)));
    }
    formats(sources, "jpg", 0x1319_8a2e_0370_7344, 200, jpeg_fields);
}

#[test]
fn tga_mutations() {
    let img = test_image(40, 24);
    let b = encoded("x.tga", &img, &WriteOptions::default());
    let mut sources = vec![("TGA (run-length)".to_string(), b, tga_fields())];
    // Flat: cubeforge's encoder compresses; the image crate can leave it.
    let rgba = image::RgbaImage::from_fn(19, 11, |x, y| {
        image::Rgba([x as u8 * 13, y as u8 * 23, 7, 200])
    });
    let mut b = Vec::new();
    image::codecs::tga::TgaEncoder::new(&mut b)
        .disable_rle()
        .encode(rgba.as_raw(), 19, 11, image::ExtendedColorType::Rgba8)
        .unwrap();
    sources.push(("TGA (flat)".to_string(), b, tga_fields()));
    formats(sources, "tga", 0xa409_3822_299f_31d0, 200, |_| tga_fields());
}

#[test]
fn hdr_mutations() {
    let mut sources = Vec::new();
    // Run-length scanlines (widths 8 to 32767), and flat texels (narrower).
    for (w, h) in [(40, 24), (5, 7)] {
        let b = encoded("x.hdr", &test_image(w, h), &WriteOptions::default());
        sources.push((format!("HDR {w}x{h}"), b.clone(), hdr_fields(&b)));
    }
    for path in real_files("hdr", "hdr").into_iter().take(1) {
        let b = std::fs::read(&path).unwrap();
        sources.push((path.display().to_string(), b.clone(), hdr_fields(&b)));
    }
    formats(sources, "hdr", 0x082e_fa98_ec4e_6c89, 200, hdr_fields);
}

#[test]
fn exr_mutations() {
    // The thorough EXR campaign is tests/it/hostile_exr.rs; this one keeps it in the same loop.
    let b = encoded("x.exr", &test_image(40, 24), &WriteOptions::default());
    formats(
        vec![("EXR".to_string(), b, Vec::new())],
        "exr",
        0x4528_21e6_38d0_1377,
        150,
        |_| Vec::new(),
    );
}

#[test]
fn ktx2_mutations() {
    let mut sources = Vec::new();
    for format in [GpuFormat::Rgba16f, GpuFormat::Rgba8Srgb] {
        let b = io::ktx2::encode(&test_cube(8), format);
        sources.push((
            format!("KTX2 cube {}", format.name()),
            b.clone(),
            ktx2_fields(&b),
        ));
    }
    let levels: Vec<Image> = std::iter::successors(Some(test_image(16, 8)), |i| {
        (i.width > 1 || i.height > 1).then(|| i.downsample_2x())
    })
    .collect();
    let b = io::ktx2::encode_2d(&levels, GpuFormat::Rgba8);
    sources.push(("KTX2 2D".to_string(), b.clone(), ktx2_fields(&b)));
    formats(sources, "ktx2", 0xbe54_66cf_34e9_0c6c, 200, ktx2_fields);
}

#[test]
fn dds_mutations() {
    let mut sources = Vec::new();
    for format in [GpuFormat::Rgba32f, GpuFormat::Rgba8] {
        let b = io::dds::encode(&test_cube(8), format).unwrap();
        sources.push((format!("DDS cube {}", format.name()), b, dds_fields()));
    }
    formats(sources, "dds", 0xc0ac_29b7_c97c_50dd, 200, |_| dds_fields());
}
