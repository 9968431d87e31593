//! Seeded mutations of the engine containers: KTX 1 (Filament's) and Babylon's `.env`, made
//! here by cubeforge's own encoders (../shared/fixtures/real holds neither; `HOSTILE_EXTRA`
//! files named .ktx or .env join in).

use crate::harness::{formats, formats_with, test_cube};
use crate::images::{png_fields, png_fix_crcs};
use crate::mutator::Field;
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::filter::sh;
use cubeforge::internals::filter::sh_engines::SphericalPolynomial;
use cubeforge::internals::io::babylon_env;
use cubeforge::internals::io::ktx1::{self, Ktx1Format};
use glam::{Vec3, Vec4};

/// A UInt32 of a KTX 1 file in its byte order (0 past the end).
fn word(b: &[u8], at: usize, big: bool) -> usize {
    let w: [u8; 4] = b
        .get(at..at + 4)
        .and_then(|s| s.try_into().ok())
        .unwrap_or_default();
    (if big {
        u32::from_be_bytes(w)
    } else {
        u32::from_le_bytes(w)
    }) as usize
}

/// Whether a KTX 1 file is big-endian (its endianness field, 0x04030201, stored 04 03 02 01).
fn is_big(b: &[u8]) -> bool {
    b.get(12..16) == Some(&[4, 3, 2, 1])
}

/// Where each key/value entry's size and each level's imageSize sit, and each level's faces'
/// bytes (start, stride): the file's own layout, walked as far as it holds together.
fn ktx1_layout(b: &[u8]) -> (Vec<usize>, Vec<usize>, Vec<(usize, usize)>) {
    let big = is_big(b);
    let (faces, levels, kvd) = (word(b, 52, big), word(b, 56, big).max(1), word(b, 60, big));
    let (mut kv, mut sizes, mut spans) = (Vec::new(), Vec::new(), Vec::new());
    let kvd_end = (64 + kvd).min(b.len());
    let mut at = 64;
    while at + 4 <= kvd_end {
        kv.push(at);
        at = (at + 4 + word(b, at, big)).div_ceil(4) * 4;
    }
    let mut at = kvd_end;
    for _ in 0..levels.min(32) {
        if at + 4 > b.len() {
            break;
        }
        sizes.push(at);
        let stride = word(b, at, big).div_ceil(4) * 4;
        spans.push((at + 4, stride));
        at = at + 4 + faces.min(6) * stride;
    }
    (kv, sizes, spans)
}

/// KTX 1: the thirteen header words (endianness, glType, glTypeSize, glFormat,
/// glInternalFormat, glBaseInternalFormat, pixelWidth, pixelHeight, pixelDepth,
/// numberOfArrayElements, numberOfFaces, numberOfMipmapLevels, bytesOfKeyValueData), every
/// key/value entry's size and every level's imageSize, in the file's byte order.
fn ktx1_fields(b: &[u8]) -> Vec<Field> {
    let big = is_big(b);
    let f = |at| Field {
        at,
        len: 4,
        be: big,
    };
    let (kv, sizes, _) = ktx1_layout(b);
    let mut fields: Vec<Field> = (0..13).map(|i| f(12 + 4 * i)).collect();
    fields.extend(kv.into_iter().chain(sizes).map(f));
    fields
}

/// A little-endian KTX 1 file in big-endian order: every UInt32 of the header, the key/value
/// sizes and the imageSizes swapped, and every texel component of glTypeSize bytes.
fn big_endian(le: &[u8]) -> Vec<u8> {
    let (kv, sizes, spans) = ktx1_layout(le);
    let type_size = word(le, 20, false).max(1);
    let faces = word(le, 52, false);
    let mut be = le.to_vec();
    for at in (0..13).map(|i| 12 + 4 * i).chain(kv).chain(sizes) {
        be[at..at + 4].reverse();
    }
    for (start, stride) in spans {
        for c in be[start..start + faces * stride].chunks_exact_mut(type_size) {
            c.reverse();
        }
    }
    be
}

/// A 2D texture from a cube map's file: numberOfFaces 1, each level's first face only.
fn two_d(cube: &[u8]) -> Vec<u8> {
    let (_, sizes, spans) = ktx1_layout(cube);
    let mut b = cube[..sizes[0]].to_vec();
    b[52..56].copy_from_slice(&1u32.to_le_bytes());
    for (size_at, (start, stride)) in sizes.into_iter().zip(spans) {
        b.extend_from_slice(&cube[size_at..start + stride]);
    }
    b
}

#[test]
fn ktx1_mutations() {
    let cube = test_cube(8);
    let sh_kv = ktx1::sh_key_value(&cubeforge::internals::filter::sh_engines::filament_sh(
        &sh::project(&cube),
    ));
    let mut sources = Vec::new();
    let mut add = |what: &str, b: Vec<u8>| {
        let fields = ktx1_fields(&b);
        sources.push((format!("KTX1 {what}"), b, fields));
    };
    let rgba16f = ktx1::encode(&cube, Ktx1Format::Rgba16f, &[sh_kv]).unwrap();
    add("cube RGBA16F big-endian", big_endian(&rgba16f));
    add("cube RGBA16F", rgba16f);
    // Rows of 6, 3 and 1 texels of 6 bytes: padded to 4 bytes.
    add(
        "cube RGB16F",
        ktx1::encode(&test_cube(6), Ktx1Format::Rgb16f, &[]).unwrap(),
    );
    add(
        "cube R11F_G11F_B10F",
        ktx1::encode(&cube, Ktx1Format::Rg11b10, &[]).unwrap(),
    );
    let rgba8 = ktx1::encode(&cube, Ktx1Format::Rgba8Srgb, &[]).unwrap();
    add("2D RGBA8", two_d(&rgba8));
    let rgba32f = ktx1::encode(&cube, Ktx1Format::Rgba32f, &[]).unwrap();
    add("2D RGBA32F big-endian", big_endian(&two_d(&rgba32f)));
    formats(sources, "ktx", 0x3c6e_f372_fe94_f82b, 250, ktx1_fields);
}

const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// Where each PNG of a `.env` starts.
fn pngs(b: &[u8]) -> Vec<usize> {
    b.windows(8)
        .enumerate()
        .filter(|(_, w)| *w == PNG_SIGNATURE)
        .map(|(i, _)| i)
        .collect()
}

/// The end of a `.env`'s manifest (its NUL), or the file's end.
fn manifest_end(b: &[u8]) -> usize {
    b.iter()
        .skip(8)
        .position(|&c| c == 0)
        .map_or(b.len(), |i| 8 + i)
}

/// `.env`: the magic, the manifest's NUL, and each PNG's header fields and chunk lengths (the
/// manifest's numbers are aimed at by [`manifest_numbers`]).
fn env_fields(b: &[u8]) -> Vec<Field> {
    let mut f = vec![Field::le(0, 4), Field::le(4, 4), Field::le(0, 8)];
    f.push(Field::le(manifest_end(b), 1));
    let starts = pngs(b);
    for (i, &start) in starts.iter().enumerate() {
        let end = starts.get(i + 1).copied().unwrap_or(b.len());
        f.extend(png_fields(&b[start..end]).into_iter().map(|mut x| {
            x.at += start;
            x
        }));
    }
    f
}

/// Where each number of a `.env`'s JSON manifest starts: version, width, irradiance
/// coefficients, every image's length and position, lodGenerationScale.
fn manifest_numbers(b: &[u8]) -> Vec<usize> {
    let end = manifest_end(b);
    (9..end)
        .filter(|&i| b[i].is_ascii_digit() && !(b[i - 1].is_ascii_digit() || b[i - 1] == b'.'))
        .collect()
}

/// Rewrites the CRCs of every PNG in a `.env`, so a mutation reaches the decoder.
fn env_fix_crcs(b: &mut [u8]) {
    for start in pngs(b) {
        png_fix_crcs(&mut b[start..]);
    }
}

#[test]
fn env_mutations() {
    let mut sources = Vec::new();
    // Values up to 12 (RGBD's divisor varies), with and without irradiance.
    let bright = |n: usize| {
        CubeMap::from_fn(n, |d: Vec3| {
            Vec4::new(d.x.abs() * 12.0, d.y * 0.5 + 0.5, d.z.abs() * 0.1, 1.0)
        })
        .with_box_mips(None)
    };
    for (n, irradiance) in [(8, true), (4, false), (1, true)] {
        let cube = bright(n);
        let p = SphericalPolynomial::from_radiance_sh(&sh::project(&cube)).coefficients();
        let b = babylon_env::encode(&cube, irradiance.then_some(&p), 0.8).unwrap();
        let what = if irradiance { "" } else { ", no irradiance" };
        sources.push((format!(".env {n}x{n}{what}"), b.clone(), env_fields(&b)));
    }
    formats_with(
        sources,
        "env",
        0xa54f_f53a_5f1d_36f1,
        250,
        env_fields,
        &|m, b| m.fixed_by(env_fix_crcs).numbers_at(manifest_numbers(b)),
    );
}
