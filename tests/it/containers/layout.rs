//! The bytes we write, field by field against the specifications (KTX2, DDS with its DX10
//! header), and the legacy DDS headers other tools write.

use super::*;

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
                data.extend(format.encode_image(&level[f]).unwrap());
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
