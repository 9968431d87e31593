//! KTX 1 files read back: byte orders, key/value data, refusals.

use super::*;
use glam::Vec4;

fn cube(n: usize, levels: usize) -> CubeMap {
    CubeMap::from_fn(n, |d| Vec4::new(d.x.abs() * 3.0, d.y * 0.5 + 0.5, d.z, 1.0))
        .with_box_mips(Some(levels))
}

#[test]
fn header_and_image_sizes_follow_the_spec() {
    let c = cube(8, 4);
    let kv = [KeyValue::text("hello", "world")];
    let b = encode(&c, Ktx1Format::Rgba16f, &kv).unwrap();
    let w = |i: usize| u32::from_le_bytes(b[12 + 4 * i..16 + 4 * i].try_into().unwrap());
    assert_eq!(&b[..12], &IDENTIFIER);
    assert_eq!(w(0), 0x0403_0201);
    assert_eq!(
        (w(1), w(2), w(3), w(4), w(5)),
        (0x140B, 2, 0x1908, 0x881A, 0x1908)
    );
    assert_eq!((w(6), w(7), w(8), w(9), w(10), w(11)), (8, 8, 0, 0, 6, 4));
    let kvd = w(12) as usize;
    assert_eq!(kvd % 4, 0);
    // First level's imageSize: one 8x8 RGBA16F face.
    let at = 64 + kvd;
    assert_eq!(
        u32::from_le_bytes(b[at..at + 4].try_into().unwrap()),
        8 * 8 * 8
    );
    let expect_len = 64
        + kvd
        + (0..4)
            .map(|l| 4 + 6 * (8usize >> l).pow(2) * 8)
            .sum::<usize>();
    assert_eq!(b.len(), expect_len);
}

#[test]
fn round_trip_keeps_texels_and_key_values() {
    let c = cube(4, 3);
    let kv = [
        KeyValue::text("a", "1"),
        KeyValue {
            key: "bin".into(),
            value: vec![1, 2, 3],
        },
    ];
    for f in [
        Ktx1Format::Rgba32f,
        Ktx1Format::Rgba16f,
        Ktx1Format::Rgb16f,
        Ktx1Format::Rgba8,
    ] {
        let b = encode(&c, f, &kv).unwrap();
        let k = read(&b, Path::new("t.ktx"), &Limits::default()).unwrap();
        assert_eq!(k.format, f);
        assert_eq!(k.key_values[0].key, WRITER_KEY);
        assert_eq!(&k.key_values[1..], &kv);
        let Decoded::Cube(d) = k.texture else {
            panic!("a cube")
        };
        assert_eq!(d.levels.len(), 3);
        for (la, lb) in c.levels.iter().zip(&d.levels) {
            for (fa, fb) in la.iter().zip(lb) {
                for (p, q) in fa.pixels.iter().zip(&fb.pixels) {
                    // 8-bit UNORM holds [0, 1] to half a step; halves hold 11 bits.
                    let (p, tol) = if f == Ktx1Format::Rgba8 {
                        (p.clamp(Vec4::ZERO, Vec4::ONE), 0.51 / 255.0)
                    } else {
                        (*p, 1e-3 * p.abs().max_element().max(1.0))
                    };
                    let d = (p.truncate() - q.truncate()).abs().max_element();
                    assert!(d <= tol, "{f:?} {p} {q}");
                }
            }
        }
    }
}

#[test]
fn rgb16f_rows_are_padded_to_four_bytes() {
    // A 1x1 face of 6 bytes takes 8; a 3x3 one 3 rows of 20.
    let c = cube(3, 2);
    let b = encode(&c, Ktx1Format::Rgb16f, &[]).unwrap();
    let k = read(&b, Path::new("t.ktx"), &Limits::default()).unwrap();
    assert_eq!(k.levels, 2);
    let kvd = u32::from_le_bytes(b[60..64].try_into().unwrap()) as usize;
    assert_eq!(
        u32::from_le_bytes(b[64 + kvd..68 + kvd].try_into().unwrap()),
        60
    );
    assert_eq!(b.len(), 64 + kvd + 4 + 6 * 60 + 4 + 6 * 8);
}

#[test]
fn big_endian_files_are_read() {
    let c = cube(2, 2);
    let le = encode(&c, Ktx1Format::Rgba16f, &[KeyValue::text("k", "v")]).unwrap();
    // Swap every UInt32 of the header, key/value sizes and imageSizes, and every half.
    let mut be = le.clone();
    let swap4 = |b: &mut Vec<u8>, at: usize| b[at..at + 4].reverse();
    for i in 0..13 {
        swap4(&mut be, 12 + 4 * i);
    }
    let kvd = u32::from_le_bytes(le[60..64].try_into().unwrap()) as usize;
    let mut at = 64;
    while at < 64 + kvd {
        let n = u32::from_le_bytes(le[at..at + 4].try_into().unwrap()) as usize;
        swap4(&mut be, at);
        at = (at + 4 + n).div_ceil(4) * 4;
    }
    for l in 0..2 {
        let n = 2usize >> l;
        swap4(&mut be, at);
        for h in 0..6 * n * n * 4 {
            be[at + 4 + 2 * h..at + 6 + 2 * h].reverse();
        }
        at += 4 + 6 * n * n * 8;
    }
    let a = read(&le, Path::new("le.ktx"), &Limits::default()).unwrap();
    let b = read(&be, Path::new("be.ktx"), &Limits::default()).unwrap();
    let (Decoded::Cube(a), Decoded::Cube(b)) = (a.texture, b.texture) else {
        panic!("cubes")
    };
    assert_eq!(a, b);
}

/// Both refusals of a format name every format read (the compressed one left out R11F).
#[test]
fn refusals_name_every_format_read() {
    let mut b = encode(&cube(2, 1), Ktx1Format::Rgba16f, &[]).unwrap();
    for (at, v) in [(16, 0u32), (16, 0x1234)] {
        b[at..at + 4].copy_from_slice(&v.to_le_bytes());
        let e = read(&b, Path::new("t.ktx"), &Limits::default()).unwrap_err();
        assert!(e.to_string().contains(READS), "{e}");
    }
}

#[test]
fn sh_text_round_trips() {
    let mut r = [[0.0f64; 3]; 9];
    for (i, c) in r.iter_mut().enumerate() {
        *c = [i as f64 * 0.1, -(i as f64) * 0.2, 1.0 / (i + 1) as f64];
    }
    let sh = crate::filter::sh_engines::filament_sh(&r);
    let kv = sh_key_value(&sh);
    assert_eq!(kv.key, "sh");
    assert_eq!(kv.as_text().unwrap().lines().count(), 9);
    let back = parse_sh(&kv.value).unwrap();
    for i in 0..9 {
        for c in 0..3 {
            assert!((back[i][c] - sh[i][c]).abs() <= 1e-6 * sh[i][c].abs().max(1e-3));
        }
    }
    assert!(parse_sh(b"1 2 3").is_none());
}
