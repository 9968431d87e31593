//! Control maps read back as inputs: a KTX2 control map in the library, `info` and `preview`,
//! and 2D KTX2 and DDS textures of every format read as their level 0.

use super::*;
use cubeforge::internals::io::{self, Decoded, ReadOptions};
use glam::Vec4;

/// Item 10: a control map written as KTX2 reads back everywhere. The library returns its
/// level 0 as an image, the values the PNG of the same recipe holds; `info` describes it and
/// `preview --control` renders with it; a command that needs an environment says in one line
/// that this is none.
#[test]
fn a_ktx2_control_map_reads_back_in_info_and_preview() {
    let dir = tempfile::tempdir().unwrap();
    let sky = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/sky.exr");
    let recipe = dir.path().join("r.toml");
    std::fs::write(
        &recipe,
        "size = \"24x10\"\nmax_lod_bias = 3\nreflectivity = 0.8\n\
         blur = { linear_gradient = { from = [0, 0], to = [1, 0] } }\n\
         fresnel = { checker = { cells = [4, 2] } }\n",
    )
    .unwrap();
    let png = dir.path().join("map.png");
    let o = cubeforge(&[&"control", &recipe, &"-o", &png], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let data = ReadOptions {
        linear: true,
        ..ReadOptions::default()
    };
    let Decoded::Image(want) = cubeforge::internals::convert::read(&png, &data).unwrap().0 else {
        panic!("the PNG read as a cube map")
    };
    for format in ["rgba8", "rgba16f", "rgba32f"] {
        let map = dir.path().join(format!("map-{format}.ktx2"));
        let o = cubeforge(
            &[&"control", &recipe, &"-o", &map, &"--gpu-format", &format],
            dir.path(),
        );
        assert!(o.status.success(), "{format}: {}", stderr(&o));
        let (decoded, meta) =
            cubeforge::internals::convert::read(&map, &ReadOptions::default()).unwrap();
        assert_eq!(meta.file_format, io::FileFormat::Ktx2);
        let Decoded::Image(got) = decoded else {
            panic!("{format}: read as a cube map")
        };
        assert_eq!((got.width, got.height), (24, 10), "{format}");
        // The PNG holds 8 bits: the float formats differ from it by the rounding alone.
        for (i, (g, w)) in got.pixels.iter().zip(&want.pixels).enumerate() {
            let d = (*g - *w).abs().max_element();
            assert!(d <= 0.5 / 255.0 + 1e-3, "{format}: texel {i}: {g} vs {w}");
        }

        let o = cubeforge(&[&"info", &map], dir.path());
        assert!(o.status.success(), "info {format}: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.contains("KTX2") && out.contains("24 x 10"), "{out}");
        // Its mip chain is counted, though only level 0 is read.
        assert_eq!(meta.stored_levels, 5, "{format}");
        assert!(out.contains("mip levels:   5"), "{out}");

        let ball = dir.path().join(format!("ball-{format}.png"));
        let o = cubeforge(
            &[
                &"preview",
                &sky,
                &"-o",
                &ball,
                &"--size",
                &"32",
                &"--control",
                &map,
            ],
            dir.path(),
        );
        assert!(o.status.success(), "preview {format}: {}", stderr(&o));
        assert!(ball.is_file());
    }
    // A 24x10 map is no environment: the layout detection says so, in one line.
    let o = cubeforge(
        &[&"convert", &"map-rgba8.ktx2", &"-o", &"cube.ktx2"],
        dir.path(),
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(e.contains("map-rgba8.ktx2"), "{e}");
}

/// 2D KTX2 textures of every texel format and odd sizes, and 2D DDS textures (DX10 and legacy
/// headers, with mips), read as their level 0 image; `info` describes a DDS one.
#[test]
fn two_d_ktx2_and_dds_read_as_their_level_0() {
    use cubeforge::internals::image::Image;
    use cubeforge::internals::io::GpuFormat;
    let dir = tempfile::tempdir().unwrap();
    let level0 = Image::from_fn(5, 3, |x, y| {
        Vec4::new(x as f32 / 4.0, y as f32 / 2.0, 0.25, 1.0 - x as f32 / 8.0)
    });
    let levels = [level0.clone(), level0.downsample_2x(), Image::new(1, 1)];
    for format in [
        GpuFormat::Rgba8,
        GpuFormat::Rgba8Srgb,
        GpuFormat::Rgba16f,
        GpuFormat::Rgba32f,
    ] {
        let path = dir.path().join("t.ktx2");
        std::fs::write(&path, io::ktx2::encode_2d(&levels, format)).unwrap();
        let Decoded::Image(got) =
            cubeforge::internals::convert::read(&path, &ReadOptions::default())
                .unwrap()
                .0
        else {
            panic!("{format:?}: read as a cube map")
        };
        assert_eq!((got.width, got.height), (5, 3));
        for (g, w) in got.pixels.iter().zip(&level0.pixels) {
            assert!(
                (*g - *w).abs().max_element() <= 3e-3,
                "{format:?}: {g} vs {w}"
            );
        }
    }

    use ddsfile::{AlphaMode, D3D10ResourceDimension, D3DFormat, Dds, DxgiFormat};
    let texels: Vec<u8> = (0..6 * 3 * 4).map(|i| (i * 11 % 256) as u8).collect();
    let dx10 = Dds::new_dxgi(ddsfile::NewDxgiParams {
        height: 3,
        width: 6,
        depth: None,
        format: DxgiFormat::R8G8B8A8_UNorm,
        mipmap_levels: Some(3),
        array_layers: None,
        caps2: None,
        is_cubemap: false,
        resource_dimension: D3D10ResourceDimension::Texture2D,
        alpha_mode: AlphaMode::Unknown,
    })
    .unwrap();
    let legacy = Dds::new_d3d(ddsfile::NewD3dParams {
        height: 3,
        width: 6,
        depth: None,
        format: D3DFormat::A8B8G8R8,
        mipmap_levels: Some(3),
        caps2: None,
    })
    .unwrap();
    for (what, mut dds) in [("DX10", dx10), ("legacy", legacy)] {
        dds.data[..texels.len()].copy_from_slice(&texels);
        let path = dir.path().join(format!("{what}.dds"));
        let mut bytes = Vec::new();
        dds.write(&mut bytes).unwrap();
        std::fs::write(&path, bytes).unwrap();
        let Decoded::Image(got) =
            cubeforge::internals::convert::read(&path, &ReadOptions::default())
                .unwrap()
                .0
        else {
            panic!("{what}: read as a cube map")
        };
        assert_eq!((got.width, got.height), (6, 3), "{what}");
        for (g, t) in got.pixels.iter().zip(texels.chunks_exact(4)) {
            let w = Vec4::from_array(std::array::from_fn(|c| t[c] as f32 / 255.0));
            assert!((*g - w).abs().max_element() < 1e-6, "{what}: {g} vs {w}");
        }
        let o = cubeforge(&[&"info", &path], dir.path());
        assert!(o.status.success(), "info {what}: {}", stderr(&o));
        assert!(String::from_utf8_lossy(&o.stdout).contains("6 x 3"));
    }
}
