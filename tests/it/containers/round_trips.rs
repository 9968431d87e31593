//! Round trips: every level of every format through memory and through files, odd sizes,
//! and the faces in their order.

use super::*;

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
                    cubeforge::internals::image::ColorSpace::Srgb
                } else {
                    cubeforge::internals::image::ColorSpace::Linear
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
            let bytes =
                cubeforge::internals::output::encode_cube(&path, cube, GpuFormat::Rgba32f).unwrap();
            std::fs::write(&path, bytes).unwrap();
            let (decoded, meta) =
                cubeforge::internals::convert::read(&path, &ReadOptions::default()).unwrap();
            assert_eq!(meta.replaced_values, 0);
            assert_same(cube, &cube_of(decoded), GpuFormat::Rgba32f);
        }
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
