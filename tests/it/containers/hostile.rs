//! Hostile files: cut, corrupted, not cube maps or of absurd sizes. Each gives an error that
//! names the file, before allocating, and never a panic.

use super::*;

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
    let e = cubeforge::internals::convert::read(&path, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    assert!(e.contains("truncated"), "{e}");

    let bytes = dds::encode(&test_cube(GpuFormat::Rgba8), GpuFormat::Rgba8).unwrap();
    let path = dir.path().join("cut.dds");
    std::fs::write(&path, &bytes[..200]).unwrap();
    let e = cubeforge::internals::convert::read(&path, &ReadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&path.display().to_string()), "{e}");
    assert!(e.contains("truncated"), "{e}");
}
