//! KTX2 and DDS cube-map containers: round trips of every level in every format, hostile and
//! truncated files (errors naming the file, never a panic), and checks by independent readers
//! (ktx-parse for KTX2, Pillow and nvddsinfo for DDS): skipped with a line on stderr when one is
//! not installed, failed when CI is set.

use crate::common;

use cubeforge::cube::CubeMap;
use cubeforge::image::{linear_to_srgb, Image};
use cubeforge::io::{self, dds, ktx2, Decoded, FileFormat, GpuFormat, Limits, ReadOptions};
use glam::Vec4;
use std::path::Path;
use std::process::Command;

const FORMATS: [GpuFormat; 4] = [
    GpuFormat::Rgba16f,
    GpuFormat::Rgba32f,
    GpuFormat::Rgba8Srgb,
    GpuFormat::Rgba8,
];

/// An 8x8 cube with its full chain (8, 4, 2, 1), different on every face and texel. Float
/// formats get values above 1 as well.
fn test_cube(format: GpuFormat) -> CubeMap {
    let scale = match format {
        GpuFormat::Rgba16f | GpuFormat::Rgba32f => 6.0,
        _ => 1.0,
    };
    CubeMap::from_fn(8, move |d| {
        Vec4::new(
            scale * (0.5 + 0.5 * d.x),
            scale * (0.5 + 0.5 * d.y),
            scale * (0.5 + 0.5 * d.z),
            0.2 + 0.7 * (d.x * d.y).abs(),
        )
    })
    .with_box_mips(None)
}

/// Checks every texel of every face of every level, within what `format` can hold.
fn assert_same(original: &CubeMap, decoded: &CubeMap, format: GpuFormat) {
    assert_eq!(decoded.levels.len(), original.levels.len(), "level count");
    for (l, (a, b)) in original.levels.iter().zip(&decoded.levels).enumerate() {
        for f in 0..6 {
            assert_eq!(
                (b[f].width, b[f].height),
                (a[f].width, a[f].height),
                "level {l} face {f} size"
            );
            for (i, (pa, pb)) in a[f].pixels.iter().zip(&b[f].pixels).enumerate() {
                for c in 0..4 {
                    let (x, y) = (pa[c], pb[c]);
                    let ok = match format {
                        GpuFormat::Rgba32f => x == y,
                        GpuFormat::Rgba16f => half::f16::from_f32(x).to_f32() == y,
                        GpuFormat::Rgba8 => (x - y).abs() <= 0.5 / 255.0 + 1e-6,
                        GpuFormat::Rgba8Srgb if c < 3 => {
                            (linear_to_srgb(x) - linear_to_srgb(y)).abs() <= 0.5 / 255.0 + 1e-5
                        }
                        GpuFormat::Rgba8Srgb => (x - y).abs() <= 0.5 / 255.0 + 1e-6,
                        _ => {
                            unreachable!("the plain formats (tests/it/gpu_formats.rs has the rest)")
                        }
                    };
                    assert!(
                        ok,
                        "{}: level {l} face {f} texel {i} channel {c}: wrote {x}, read {y}",
                        format.name()
                    );
                }
            }
        }
    }
}

fn cube_of(decoded: Decoded) -> CubeMap {
    match decoded {
        Decoded::Cube(c) => c,
        Decoded::Image(_) => panic!("a container decoded to a single image"),
    }
}

type DecodeFn = fn(&[u8], &Path, &Limits) -> cubeforge::Result<(Decoded, io::Meta)>;

fn encode(kind: FileFormat, cube: &CubeMap, format: GpuFormat) -> Vec<u8> {
    match kind {
        FileFormat::Ktx2 => ktx2::encode(cube, format),
        FileFormat::Dds => dds::encode(cube, format).expect("DDS encode"),
        _ => unreachable!(),
    }
}

fn decoder(kind: FileFormat) -> DecodeFn {
    match kind {
        FileFormat::Ktx2 => ktx2::decode,
        _ => dds::decode,
    }
}

#[test]
fn round_trip_every_level_every_format() {
    for kind in [FileFormat::Ktx2, FileFormat::Dds] {
        for format in FORMATS {
            let cube = test_cube(format);
            assert_eq!(cube.levels.len(), 4);
            let bytes = encode(kind, &cube, format);
            let path = Path::new("round.trip");
            let (decoded, meta) = decoder(kind)(&bytes, path, &Limits::default())
                .unwrap_or_else(|e| panic!("{} {}: {e}", kind.name(), format.name()));
            assert_same(&cube, &cube_of(decoded), format);
            assert_eq!(meta.file_format, kind);
            assert_eq!(meta.pixel_format, format.name());
            assert_eq!(
                meta.color_space,
                if format == GpuFormat::Rgba8Srgb {
                    cubeforge::image::ColorSpace::Srgb
                } else {
                    cubeforge::image::ColorSpace::Linear
                }
            );
            assert_eq!(
                meta.hdr,
                matches!(format, GpuFormat::Rgba16f | GpuFormat::Rgba32f)
            );
            // The same input always gives the same bytes.
            assert_eq!(
                bytes,
                encode(kind, &cube, format),
                "output is not reproducible"
            );
        }
    }
}

#[test]
fn round_trip_through_files_and_odd_sizes() {
    let dir = tempfile::tempdir().unwrap();
    // 6 -> 3 -> 1 is a full chain of a size that is not a power of two; one level alone too.
    let odd = CubeMap::from_fn(6, |d| d.abs().extend(1.0)).with_box_mips(None);
    let single = CubeMap::from_fn(5, |d| d.abs().extend(0.5));
    for (name, cube) in [("odd", &odd), ("single", &single)] {
        for ext in ["ktx2", "dds"] {
            let path = dir.path().join(format!("{name}.{ext}"));
            let bytes = io::encode_cube(&path, cube, GpuFormat::Rgba32f).unwrap();
            io::write_all_atomic(&[(path.clone(), bytes)]).unwrap();
            let (decoded, meta) = io::read(&path, &ReadOptions::default()).unwrap();
            assert_eq!(meta.replaced_values, 0);
            assert_same(cube, &cube_of(decoded), GpuFormat::Rgba32f);
        }
    }
}

fn le32(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes(b[o..o + 4].try_into().unwrap())
}
fn le64(b: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(b[o..o + 8].try_into().unwrap())
}

#[test]
fn ktx2_layout_follows_the_spec() {
    for format in FORMATS {
        let cube = test_cube(format);
        let b = ktx2::encode(&cube, format);
        assert_eq!(&b[..12], &ktx2::IDENTIFIER);
        let field = |i: usize| le32(&b, 12 + 4 * i);
        let bpt = format.block_bytes() as u64;
        assert_eq!(field(1) as u64, bpt / 4, "typeSize");
        assert_eq!((field(2), field(3), field(4)), (8, 8, 0), "pixel size");
        assert_eq!((field(5), field(6), field(7), field(8)), (0, 6, 4, 0));
        let (dfd_off, dfd_len, kvd_off, kvd_len) = (field(9), field(10), field(11), field(12));
        assert_eq!(dfd_off, 80 + 4 * 24, "the DFD follows the level index");
        assert_eq!(le32(&b, dfd_off as usize), dfd_len, "dfdTotalSize");
        assert_eq!(
            kvd_off,
            dfd_off + dfd_len,
            "the key/value data follows the DFD"
        );
        assert_eq!(kvd_len % 4, 0);
        let kv = &b[kvd_off as usize..(kvd_off + kvd_len) as usize];
        let kv_len = le32(kv, 0) as usize;
        let writer = format!("KTXwriter\0cubeforge {}\0", env!("CARGO_PKG_VERSION"));
        assert_eq!(&kv[4..4 + kv_len], writer.as_bytes());
        assert_eq!(
            (le64(&b, 64), le64(&b, 72)),
            (0, 0),
            "no supercompression data"
        );
        let align = if bpt.is_multiple_of(4) { bpt } else { bpt * 4 };
        let mut next_end = b.len() as u64;
        for l in 0..4 {
            let e = 80 + 24 * l;
            let (off, len, ulen) = (le64(&b, e), le64(&b, e + 8), le64(&b, e + 16));
            let n = 8u64 >> l;
            assert_eq!(len, 6 * n * n * bpt, "level {l} length");
            assert_eq!(ulen, len);
            assert_eq!(
                off % align,
                0,
                "level {l} offset {off} not aligned to {align}"
            );
            // Level 0 is last in the file, each smaller level before the larger one.
            assert_eq!(
                off + len,
                next_end,
                "level {l} is not right before level {}",
                l + 1
            );
            next_end = off;
        }
        assert!(next_end >= (kvd_off + kvd_len) as u64);
        assert!(
            next_end - ((kvd_off + kvd_len) as u64) < align,
            "mip padding too long"
        );
    }
}

#[test]
fn dds_header_is_a_dx10_cube_map() {
    for format in FORMATS {
        let b = dds::encode(&test_cube(format), format).unwrap();
        assert_eq!(&b[..4], b"DDS ");
        assert_eq!(le32(&b, 4), 124);
        assert_eq!((le32(&b, 12), le32(&b, 16)), (8, 8));
        assert_eq!(le32(&b, 28), 4, "mipMapCount");
        assert_eq!(le32(&b, 80), 0x4, "pixel format flags: DDPF_FOURCC only");
        assert_eq!(&b[84..88], b"DX10");
        assert_eq!(le32(&b, 108) & 0x1008, 0x1008, "DDSCAPS_TEXTURE | COMPLEX");
        assert_eq!(le32(&b, 112), 0xFE00, "DDSCAPS2_CUBEMAP and all six faces");
        let dxgi = match format {
            GpuFormat::Rgba16f => 10,
            GpuFormat::Rgba32f => 2,
            GpuFormat::Rgba8Srgb => 29,
            GpuFormat::Rgba8 => 28,
            _ => unreachable!("the plain formats"),
        };
        assert_eq!(le32(&b, 128), dxgi, "DXGI format");
        assert_eq!(le32(&b, 132), 3, "TEXTURE2D");
        assert_eq!(le32(&b, 136), 0x4, "RESOURCE_MISC_TEXTURECUBE");
        assert_eq!(le32(&b, 140), 1, "one cube");
        let texels: u64 = (0..4).map(|l| (8u64 >> l).pow(2)).sum::<u64>() * 6;
        assert_eq!(b.len() as u64, 148 + texels * format.block_bytes() as u64);
    }
}

/// Legacy (pre-DX10) headers written by ddsfile: float FourCCs and the RGBA8 bit masks.
#[test]
fn dds_legacy_headers_are_read() {
    use ddsfile::{Caps2, D3DFormat, Dds, FourCC, NewD3dParams, PixelFormatFlags};
    let cube = CubeMap::from_fn(4, |d| (d.abs() * 0.9).extend(0.6)).with_box_mips(None);
    for (d3d, format, bgra) in [
        (D3DFormat::A16B16G16R16F, GpuFormat::Rgba16f, false),
        (D3DFormat::A32B32G32R32F, GpuFormat::Rgba32f, false),
        (D3DFormat::A8B8G8R8, GpuFormat::Rgba8, false),
        (D3DFormat::A8R8G8B8, GpuFormat::Rgba8, true),
    ] {
        let mut dds = Dds::new_d3d(NewD3dParams {
            height: 4,
            width: 4,
            depth: None,
            format: d3d,
            mipmap_levels: Some(cube.levels.len() as u32),
            caps2: Some(Caps2::CUBEMAP | Caps2::CUBEMAP_ALLFACES),
        })
        .unwrap();
        let mut data = Vec::new();
        for f in 0..6 {
            for level in &cube.levels {
                let start = data.len();
                data.extend(format.encode_image(&level[f]));
                if bgra {
                    for t in data[start..].chunks_exact_mut(4) {
                        t.swap(0, 2);
                    }
                }
            }
        }
        // ddsfile sizes its buffer for one layer; a cube holds six.
        dds.data = data;
        if matches!(format, GpuFormat::Rgba16f | GpuFormat::Rgba32f) {
            // ddsfile describes the float formats by bit count alone; legacy files name them
            // by FourCC (113, 116), as D3DX and DirectXTex write them.
            let spf = &mut dds.header.spf;
            spf.flags = PixelFormatFlags::FOURCC;
            spf.fourcc = Some(FourCC(if format == GpuFormat::Rgba16f {
                113
            } else {
                116
            }));
            spf.rgb_bit_count = None;
        }
        let mut bytes = Vec::new();
        dds.write(&mut bytes).unwrap();
        let (decoded, meta) = dds::decode(&bytes, Path::new("legacy.dds"), &Limits::default())
            .unwrap_or_else(|e| panic!("{d3d:?}: {e}"));
        assert_eq!(meta.pixel_format, format.name(), "{d3d:?}");
        assert_same(&cube, &cube_of(decoded), format);
    }
}

/// Every way a file can be cut or corrupted gives an error that names the file.
fn assert_rejected(kind: FileFormat, bytes: &[u8], what: &str, expect: &str) {
    let path = Path::new("/some/dir/broken-file.bin");
    // No memory budget: the file's own checks, the same on every machine.
    let limits = Limits {
        max_memory: u64::MAX,
        ..Limits::default()
    };
    let result = decoder(kind)(bytes, path, &limits);
    match result {
        Ok(_) => panic!("{} {what}: accepted", kind.name()),
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.starts_with("/some/dir/broken-file.bin: "),
                "{} {what}: message does not name the file: {msg}",
                kind.name()
            );
            assert!(
                msg.contains(expect),
                "{} {what}: expected {expect:?} in: {msg}",
                kind.name()
            );
            assert!(!msg.contains('\n'), "message is not one line: {msg}");
        }
    }
}

/// `bytes` decode as a 2D image of `size`.
fn assert_image(kind: FileFormat, bytes: &[u8], what: &str, size: (usize, usize)) {
    let path = Path::new("/some/dir/texture.bin");
    match decoder(kind)(bytes, path, &Limits::default()) {
        Ok((Decoded::Image(img), _)) => assert_eq!((img.width, img.height), size, "{what}"),
        Ok((Decoded::Cube(_), _)) => panic!("{} {what}: read as a cube map", kind.name()),
        Err(e) => panic!("{} {what}: {e}", kind.name()),
    }
}

#[test]
fn truncated_files_are_rejected() {
    for kind in [FileFormat::Ktx2, FileFormat::Dds] {
        for format in [GpuFormat::Rgba16f, GpuFormat::Rgba8] {
            let bytes = encode(kind, &test_cube(format), format);
            let n = bytes.len();
            for cut in [
                0,
                3,
                4,
                11,
                12,
                40,
                79,
                80,
                100,
                127,
                128,
                147,
                148,
                200,
                n / 2,
                n - 1,
            ] {
                assert_rejected(kind, &bytes[..cut], &format!("cut at {cut}"), "");
            }
            // Cuts inside the texels say so.
            assert_rejected(kind, &bytes[..n - 1], "cut at n-1", "truncated");
        }
    }
}

#[test]
fn non_cube_files_are_rejected() {
    // KTX2: a cube map's header saying faceCount 1 (its level index then does not fit), a
    // cube-map array, a 3D texture, BasisLZ supercompression. (A real 2D texture reads: see
    // tests/it/control.rs.)
    let k = ktx2::encode(&test_cube(GpuFormat::Rgba8), GpuFormat::Rgba8);
    let patch = |offset: usize, v: u32| {
        let mut b = k.clone();
        b[offset..offset + 4].copy_from_slice(&v.to_le_bytes());
        b
    };
    assert_rejected(
        FileFormat::Ktx2,
        &patch(36, 1),
        "2D",
        "invalid level index: level 0 claims",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(32, 2),
        "array",
        "texture arrays are not supported",
    );
    assert_rejected(FileFormat::Ktx2, &patch(28, 8), "3D", "pixelDepth");
    assert_rejected(FileFormat::Ktx2, &patch(44, 1), "BasisLZ", "supercompress");
    // Zstandard is read, but plain levels are no zstd frames.
    assert_rejected(FileFormat::Ktx2, &patch(44, 2), "zstd", "Zstandard data");
    assert_rejected(
        FileFormat::Ktx2,
        &patch(12, 131),
        "BC1",
        "unsupported vkFormat 131 (cubeforge reads RGBA16F, RGBA32F, RGBA8 sRGB/UNORM, BC6H",
    );
    assert_rejected(FileFormat::Ktx2, &patch(16, 4), "typeSize", "typeSize");
    assert_rejected(FileFormat::Ktx2, &patch(24, 4), "not square", "square");

    // DDS: a plain 2D texture from ddsfile and a DX10 header without TEXTURECUBE read as
    // images; a cube array, a partial legacy cube and an unsupported DXGI format do not.
    use ddsfile::{
        AlphaMode, Caps2, D3D10ResourceDimension, D3DFormat, Dds, DxgiFormat, NewD3dParams,
        NewDxgiParams,
    };
    let plain = Dds::new_dxgi(NewDxgiParams {
        height: 8,
        width: 8,
        depth: None,
        format: DxgiFormat::R8G8B8A8_UNorm,
        mipmap_levels: Some(1),
        array_layers: None,
        caps2: None,
        is_cubemap: false,
        resource_dimension: D3D10ResourceDimension::Texture2D,
        alpha_mode: AlphaMode::Unknown,
    })
    .unwrap();
    let mut b = Vec::new();
    plain.write(&mut b).unwrap();
    assert_image(FileFormat::Dds, &b, "2D DX10", (8, 8));
    let legacy_2d = Dds::new_d3d(NewD3dParams {
        height: 8,
        width: 8,
        depth: None,
        format: D3DFormat::A8B8G8R8,
        mipmap_levels: None,
        caps2: None,
    })
    .unwrap();
    let mut b = Vec::new();
    legacy_2d.write(&mut b).unwrap();
    assert_image(FileFormat::Dds, &b, "2D legacy", (8, 8));
    let partial = Dds::new_d3d(NewD3dParams {
        height: 8,
        width: 8,
        depth: None,
        format: D3DFormat::A8B8G8R8,
        mipmap_levels: None,
        caps2: Some(Caps2::CUBEMAP | Caps2::CUBEMAP_POSITIVEX),
    })
    .unwrap();
    let mut b = Vec::new();
    partial.write(&mut b).unwrap();
    assert_rejected(FileFormat::Dds, &b, "partial cube", "not a cube map");

    let d = dds::encode(&test_cube(GpuFormat::Rgba8), GpuFormat::Rgba8).unwrap();
    let patch = |offset: usize, v: u32| {
        let mut b = d.clone();
        b[offset..offset + 4].copy_from_slice(&v.to_le_bytes());
        b
    };
    assert_image(FileFormat::Dds, &patch(136, 0), "no misc flag", (8, 8));
    assert_rejected(
        FileFormat::Dds,
        &patch(140, 2),
        "array",
        "texture arrays are not supported",
    );
    assert_rejected(
        FileFormat::Dds,
        &patch(128, 71),
        "BC1",
        "unsupported DXGI format 71",
    );
    assert_rejected(FileFormat::Dds, &patch(12, 4), "not square", "square");
}

#[test]
fn absurd_sizes_are_rejected_before_allocating() {
    let k = ktx2::encode(&test_cube(GpuFormat::Rgba32f), GpuFormat::Rgba32f);
    let d = dds::encode(&test_cube(GpuFormat::Rgba32f), GpuFormat::Rgba32f).unwrap();
    let patch = |src: &[u8], offset: usize, v: &[u8]| {
        let mut b = src.to_vec();
        b[offset..offset + v.len()].copy_from_slice(v);
        b
    };
    let huge = 0x7FFF_FFFFu32.to_le_bytes();
    let big = 8000u32.to_le_bytes();
    let mut both = patch(&k, 20, &huge);
    both[24..28].copy_from_slice(&huge);
    assert_rejected(FileFormat::Ktx2, &both, "2^31 square", "over the limit");
    let mut both = patch(&k, 20, &big);
    both[24..28].copy_from_slice(&big);
    // Within the limit per side, but the level sizes then disagree with the index.
    assert_rejected(FileFormat::Ktx2, &both, "8000 square", "level 0");
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 20, &[0; 4]),
        "zero width",
        "empty",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 40, &1000u32.to_le_bytes()),
        "levels",
        "levelCount",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 40, &u32::MAX.to_le_bytes()),
        "levels",
        "levelCount",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 80, &u64::MAX.to_le_bytes()),
        "level offset",
        "truncated",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 88, &u64::MAX.to_le_bytes()),
        "level length",
        "level 0",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 48, &u32::MAX.to_le_bytes()),
        "dfd offset",
        "descriptor",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 56, &u32::MAX.to_le_bytes()),
        "kvd offset",
        "key/value",
    );
    assert_rejected(
        FileFormat::Ktx2,
        &patch(&k, 64, &u64::MAX.to_le_bytes()),
        "sgd offset",
        "supercompression",
    );

    let mut both = patch(&d, 12, &huge);
    both[16..20].copy_from_slice(&huge);
    assert_rejected(FileFormat::Dds, &both, "2^31 square", "over the limit");
    let mut both = patch(&d, 12, &big);
    both[16..20].copy_from_slice(&big);
    assert_rejected(FileFormat::Dds, &both, "8000 square", "truncated");
    assert_rejected(
        FileFormat::Dds,
        &patch(&d, 28, &u32::MAX.to_le_bytes()),
        "mips",
        "mip levels",
    );

    // A tighter limit is honoured too.
    let small = Limits {
        max_pixels: 16,
        max_dimension: 4,
        ..Limits::default()
    };
    for (kind, bytes) in [(FileFormat::Ktx2, &k), (FileFormat::Dds, &d)] {
        let e = decoder(kind)(bytes, Path::new("big.file"), &small).unwrap_err();
        assert!(e.to_string().contains("over the limit"), "{e}");
    }
}

/// Garbage, and every single-byte corruption of a header: errors or a cube map, never a panic.
#[test]
fn garbage_and_corruption_never_panic() {
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    for kind in [FileFormat::Ktx2, FileFormat::Dds] {
        let magic: &[u8] = if kind == FileFormat::Ktx2 {
            &ktx2::IDENTIFIER
        } else {
            b"DDS "
        };
        for len in [1usize, 16, 100, 200, 1000, 5000] {
            let noise: Vec<u8> = (0..len).map(|_| next() as u8).collect();
            assert_rejected(kind, &noise, &format!("{len} random bytes"), "");
            let mut with_magic = magic.to_vec();
            with_magic.extend_from_slice(&noise);
            assert_rejected(
                kind,
                &with_magic,
                &format!("magic + {len} random bytes"),
                "",
            );
        }
        for format in [GpuFormat::Rgba16f, GpuFormat::Rgba8Srgb] {
            let good = encode(kind, &test_cube(format), format);
            let header_len = if kind == FileFormat::Ktx2 {
                80 + 4 * 24 + 92 + 32
            } else {
                148
            };
            for pos in 0..header_len {
                for v in [0x00, 0x01, 0x7F, 0x80, 0xFF, next() as u8] {
                    let mut b = good.clone();
                    b[pos] = v;
                    let _ = decoder(kind)(&b, Path::new("x"), &Limits::default());
                }
            }
        }
    }
}

#[test]
fn read_names_the_file_on_errors() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = ktx2::encode(&test_cube(GpuFormat::Rgba8), GpuFormat::Rgba8);
    let path = dir.path().join("cut.ktx2");
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = io::read(&path, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    assert!(e.contains("truncated"), "{e}");

    let bytes = dds::encode(&test_cube(GpuFormat::Rgba8), GpuFormat::Rgba8).unwrap();
    let path = dir.path().join("cut.dds");
    std::fs::write(&path, &bytes[..200]).unwrap();
    let e = io::read(&path, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    assert!(e.contains("truncated"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Independent readers (tests/common): each test is skipped, with a line on stderr, when its
// reader is not installed, and fails when CI is set.

#[test]
fn ktx_parse_reads_our_ktx2() {
    let Some(tools) = common::ktx_parse() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    for format in FORMATS {
        let cube = test_cube(format);
        let path = dir.path().join("cube.ktx2");
        std::fs::write(&path, ktx2::encode(&cube, format)).unwrap();
        let v = common::ktx_check(&tools, &path, format.name());
        let bpt = format.block_bytes() as u64;
        let (vk, transfer) = match format {
            GpuFormat::Rgba16f => (97, 1),
            GpuFormat::Rgba32f => (109, 1),
            GpuFormat::Rgba8Srgb => (43, 2),
            GpuFormat::Rgba8 => (37, 1),
            _ => unreachable!("the plain formats"),
        };
        assert_eq!(v["vkFormat"], vk, "{v}");
        assert_eq!(v["typeSize"], bpt / 4, "{v}");
        assert_eq!(v["pixelWidth"], 8, "{v}");
        assert_eq!(v["pixelHeight"], 8, "{v}");
        assert_eq!(v["pixelDepth"], 0, "{v}");
        assert_eq!(v["layerCount"], 0, "{v}");
        assert_eq!(v["faceCount"], 6, "{v}");
        assert_eq!(v["levelCount"], 4, "{v}");
        assert_eq!(v["supercompressionScheme"], 0, "{v}");
        let sizes: Vec<u64> = (0..4).map(|l| 6 * (8u64 >> l).pow(2) * bpt).collect();
        assert_eq!(v["levels"], serde_json::json!(sizes), "{v}");
        assert_eq!(v["uncompressedLevels"], serde_json::json!(sizes), "{v}");
        let dfd = &v["dfd"];
        assert_eq!(dfd["colorModel"], 1, "RGBSDA: {v}");
        assert_eq!(dfd["colorPrimaries"], 1, "BT709: {v}");
        assert_eq!(dfd["transferFunction"], transfer, "{v}");
        assert_eq!(dfd["bytesPlane0"], bpt, "{v}");
        let samples = dfd["samples"].as_array().unwrap();
        assert_eq!(samples.len(), 4, "{v}");
        let bits = bpt * 2;
        for (i, (s, channel)) in samples.iter().zip([0u64, 1, 2, 15]).enumerate() {
            assert_eq!(s["bitOffset"], i as u64 * bits, "{v}");
            assert_eq!(s["bitLength"], bits - 1, "{v}");
            assert_eq!(s["channelType"].as_u64().unwrap() & 0xF, channel, "{v}");
        }
        assert_eq!(
            v["writer"],
            format!("cubeforge {}", env!("CARGO_PKG_VERSION")),
            "{v}"
        );
        assert_eq!(
            v["rewriteIdentical"], true,
            "ktx-parse lays the file out differently: {v}"
        );
    }
}

#[test]
fn pillow_reads_our_rgba8_dds() {
    if !common::pillow() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for format in [GpuFormat::Rgba8Srgb, GpuFormat::Rgba8] {
        let cube = test_cube(format);
        let path = dir.path().join("cube.dds");
        std::fs::write(&path, dds::encode(&cube, format).unwrap()).unwrap();
        // Pillow reads the first surface: face +X, level 0.
        let script = "import sys, json\nfrom PIL import Image\nim = Image.open(sys.argv[1])\n\
                      im.load()\nprint(json.dumps({'format': im.format, 'size': im.size, \
                      'mode': im.mode, 'pixels': list(im.tobytes())}))";
        let out = Command::new("python3")
            .args(["-c", script])
            .arg(&path)
            .output()
            .expect("run python3");
        assert!(
            out.status.success(),
            "Pillow failed on {}: {}",
            format.name(),
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["format"], "DDS", "{v}");
        assert_eq!(v["size"], serde_json::json!([8, 8]), "{v}");
        assert_eq!(v["mode"], "RGBA", "{v}");
        let expected = format.encode_image(&cube.levels[0][0]);
        let got: Vec<u8> = v["pixels"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as u8)
            .collect();
        assert_eq!(got, expected, "{}: Pillow sees other texels", format.name());
    }
}

/// The decoded +X face must look like what `from_fn` put there (guards against face mix-ups
/// that a symmetric round trip would not see).
#[test]
fn faces_keep_their_order() {
    let cube = CubeMap::from_fn(4, |d| (d * 0.5 + glam::Vec3::splat(0.5)).extend(1.0));
    for kind in [FileFormat::Ktx2, FileFormat::Dds] {
        let bytes = encode(kind, &cube, GpuFormat::Rgba32f);
        let back = cube_of(
            decoder(kind)(&bytes, Path::new("f"), &Limits::default())
                .unwrap()
                .0,
        );
        let mean = |img: &Image| img.pixels.iter().copied().sum::<Vec4>() / img.pixels.len() as f32;
        // +X, -X, +Y, -Y, +Z, -Z: the dominant axis of each face's mean colour.
        let faces = &back.levels[0];
        assert!(mean(&faces[0]).x > 0.8 && mean(&faces[1]).x < 0.2);
        assert!(mean(&faces[2]).y > 0.8 && mean(&faces[3]).y < 0.2);
        assert!(mean(&faces[4]).z > 0.8 && mean(&faces[5]).z < 0.2);
    }
}

/// NVIDIA's DDS parser (nvddsinfo, from NVIDIA Texture Tools) reads our headers, float formats
/// included. It prints the header only: the texels are checked by the Pillow test above.
#[test]
fn nvddsinfo_reads_our_dds_headers() {
    if !common::nvddsinfo() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    for format in FORMATS {
        let path = dir.path().join("cube.dds");
        std::fs::write(&path, dds::encode(&test_cube(format), format).unwrap()).unwrap();
        let out = Command::new("nvddsinfo").arg(&path).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "nvddsinfo rejected {}: {text}",
            format.name()
        );
        let dxgi = match format {
            GpuFormat::Rgba16f => "10 (R16G16B16A16_FLOAT)",
            GpuFormat::Rgba32f => "2 (R32G32B32A32_FLOAT)",
            GpuFormat::Rgba8Srgb => "29 (R8G8B8A8_UNORM_SRGB)",
            GpuFormat::Rgba8 => "28 (R8G8B8A8_UNORM)",
            _ => unreachable!("the plain formats"),
        };
        for expected in [
            "Width: 8",
            "Height: 8",
            "Mipmap count: 4",
            "DDSCAPS2_CUBEMAP_ALL_FACES",
            "DDSD_MIPMAPCOUNT",
            &format!("DXGI Format: {dxgi}"),
            "Resource dimension: 3 (TEXTURE2D)",
            "Misc flag: 4",
            "Array size: 1",
        ] {
            assert!(
                text.contains(expected),
                "{}: nvddsinfo does not say {expected:?}:\n{text}",
                format.name()
            );
        }
    }
}
