//! No output holds NaN or Inf, whatever the input's magnitudes: values beyond a format's
//! largest finite value are written as that value, with a warning that counts them, and the
//! maths stays finite on inputs near the f32 maximum (they are clamped to 1e28 on reading).

use crate::common;

use common::{run, stderr};
use cubeforge::internals::cube::CubeMap;
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, Decoded, GpuFormat, ReadOptions};
use glam::Vec4;
use std::path::Path;

/// A 16 px cube map of radiance 1 with a 3 x 3 "sun" of 1e6 (above any half float) and one
/// texel at 3e38 (near the f32 maximum), written as RGBA32F KTX2.
fn extreme_input(dir: &Path) -> std::path::PathBuf {
    let faces = std::array::from_fn(|f| {
        Image::from_fn(16, 16, |x, y| {
            if f == 4 && x == 8 && y == 8 {
                Vec4::new(3e38, 3e38, 3e38, 1.0)
            } else if f == 4 && (7..10).contains(&x) && (7..10).contains(&y) {
                Vec4::new(1e6, 1e6, 1e6, 1.0)
            } else {
                Vec4::ONE
            }
        })
    });
    let cube = CubeMap {
        levels: vec![faces],
    };
    let path = dir.join("extreme.ktx2");
    std::fs::write(
        &path,
        cubeforge::internals::output::encode_cube(&path, &cube, GpuFormat::Rgba32f).unwrap(),
    )
    .unwrap();
    path
}

/// Every value of every image in the file, as stored (no clean-up on reading).
fn stored_values_finite(path: &Path) -> bool {
    let (decoded, _) = cubeforge::internals::convert::read_raw(path, &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let images: Vec<Image> = match decoded {
        Decoded::Image(img) => vec![img],
        Decoded::Cube(c) => c.levels.into_iter().flatten().collect(),
    };
    images
        .iter()
        .all(|img| img.pixels.iter().all(|p| p.is_finite()))
}

#[test]
fn extreme_inputs_give_finite_outputs_with_a_counted_warning() {
    let dir = tempfile::tempdir().unwrap();
    let input = extreme_input(dir.path());
    let input = input.to_str().unwrap();
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    // (arguments, output file, whether a half-float output must warn)
    let jobs: Vec<(Vec<String>, String, bool)> = vec![
        (
            vec![
                "convert".into(),
                input.into(),
                "-o".into(),
                out("a.exr"),
                "--to".into(),
                "equirect".into(),
                "--size".into(),
                "32".into(),
            ],
            out("a.exr"),
            true,
        ),
        (
            vec![
                "convert".into(),
                input.into(),
                "-o".into(),
                out("b.ktx2"),
                "--gpu-format".into(),
                "rgba32f".into(),
            ],
            out("b.ktx2"),
            false,
        ),
        (
            vec!["convert".into(), input.into(), "-o".into(), out("c.ktx2")],
            out("c.ktx2"),
            true,
        ),
        (
            vec!["convert".into(), input.into(), "-o".into(), out("d.dds")],
            out("d.dds"),
            true,
        ),
        (
            vec![
                "convert".into(),
                input.into(),
                "-o".into(),
                out("e.hdr"),
                "--to".into(),
                "equirect".into(),
                "--size".into(),
                "32".into(),
            ],
            out("e.hdr"),
            false,
        ),
        (
            vec![
                "prefilter".into(),
                input.into(),
                "-o".into(),
                out("g.ktx2"),
                "--filter".into(),
                "gaussian".into(),
                "--gpu-format".into(),
                "rgba32f".into(),
            ],
            out("g.ktx2"),
            false,
        ),
        (
            vec![
                "prefilter".into(),
                input.into(),
                "-o".into(),
                out("h.ktx2"),
                "--filter".into(),
                "cosine".into(),
                "--gpu-format".into(),
                "rgba32f".into(),
            ],
            out("h.ktx2"),
            false,
        ),
        (
            vec![
                "prefilter".into(),
                input.into(),
                "-o".into(),
                out("i.ktx2"),
                "--filter".into(),
                "ggx".into(),
                "--samples".into(),
                "64".into(),
            ],
            out("i.ktx2"),
            true,
        ),
        (
            vec![
                "irradiance".into(),
                input.into(),
                "-o".into(),
                out("j.exr"),
                "--size".into(),
                "8".into(),
            ],
            out("j.exr"),
            true,
        ),
        (
            vec![
                "preview".into(),
                input.into(),
                "-o".into(),
                out("k.exr"),
                "--size".into(),
                "32".into(),
            ],
            out("k.exr"),
            true,
        ),
    ];
    for (args, path, warns) in jobs {
        let result = run(&args);
        let err = stderr(&result);
        assert!(result.status.success(), "{args:?}: {err}");
        assert!(
            stored_values_finite(Path::new(&path)),
            "{args:?} wrote NaN or Inf"
        );
        if warns {
            assert!(
                err.contains("values beyond 65504"),
                "{args:?}: no clamp warning in {err:?}"
            );
        }
    }
}

#[test]
fn inputs_near_the_f32_maximum_are_clamped_and_counted_on_reading() {
    let dir = tempfile::tempdir().unwrap();
    let input = extreme_input(dir.path());
    let (_, meta) = cubeforge::internals::convert::read(&input, &ReadOptions::default()).unwrap();
    // The 3e38 texel's three colour channels.
    assert_eq!(meta.replaced_values, 3);
}

#[test]
fn half_float_encoders_never_write_infinity() {
    let img = Image::from_fn(4, 4, |x, _| {
        Vec4::new(1e9, f32::INFINITY, f32::NAN, 1.0) * (x as f32 + 1.0)
    });
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("x.exr");
    let bytes =
        cubeforge::internals::output::encode_image(&path, &img, &Default::default()).unwrap();
    std::fs::write(&path, bytes).unwrap();
    assert!(stored_values_finite(&path));
    assert_eq!(io::count_out_of_range([&img], io::HALF_MAX), 48);
}
