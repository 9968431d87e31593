//! Control maps: every source and operation gives exact texel values, resizing uses the filter
//! it promises, `[pack]` moves parameters, bad recipes fail with the recipe's line and leave
//! nothing behind, and the outputs (PNG, EXR, KTX2 with mips, sidecar JSON) read back as written.

use crate::common;

use cubeforge::control::{self, lattice, Noise, Recipe, Size, Slot, Syntax};
use cubeforge::image::{luminance, srgb_to_linear};
use cubeforge::io::{self, unorm8, Decoded, Limits, ReadOptions};
use glam::Vec4;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const EPS: f32 = 1e-6;

fn parse_in(dir: &Path, text: &str, syntax: Syntax) -> cubeforge::Result<Recipe> {
    control::parse(text, syntax, Path::new("recipe"), dir, &Limits::default())
}

/// Bakes TOML recipe text at `w` x `h`, images relative to `dir`.
fn bake_in(dir: &Path, text: &str, w: usize, h: usize) -> control::Baked {
    let recipe = parse_in(dir, text, Syntax::Toml).unwrap_or_else(|e| panic!("{e}\n{text}"));
    recipe
        .bake(Some(Size::new(w, h).unwrap()), &Limits::default())
        .unwrap()
}

fn bake(text: &str, w: usize, h: usize) -> control::Baked {
    bake_in(Path::new("."), text, w, h)
}

/// One channel of a baked map (0 R, 1 G, 2 B, 3 A), rows top to bottom.
fn channel(b: &control::Baked, c: usize) -> Vec<f32> {
    b.image.pixels.iter().map(|p| p[c]).collect()
}

/// The reflectivity (R) of `[reflectivity]` given as `source` (a TOML table body).
fn refl(source: &str, w: usize, h: usize) -> Vec<f32> {
    channel(&bake(&format!("[reflectivity]\n{source}\n"), w, h), 0)
}

fn assert_close(got: &[f32], want: &[f32]) {
    assert_eq!(got.len(), want.len(), "length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= EPS,
            "texel {i}: got {g}, want {w}\n{got:?}"
        );
    }
}

fn cubeforge(args: &[&dyn AsRef<std::ffi::OsStr>], cwd: &Path) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubeforge"));
    cmd.current_dir(cwd);
    for a in args {
        cmd.arg(a);
    }
    cmd.output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The RGBA8 bytes of a PNG, decoded by the `image` crate (no colour conversion).
fn png8(path: &Path) -> (u32, u32, Vec<u8>) {
    let img = image::open(path).unwrap();
    assert_eq!(img.color(), image::ColorType::Rgba8, "{}", path.display());
    let img = img.to_rgba8();
    (img.width(), img.height(), img.into_raw())
}

fn write_png8(path: &Path, w: u32, h: u32, rgba: &[u8]) {
    image::save_buffer(path, rgba, w, h, image::ExtendedColorType::Rgba8).unwrap();
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

// ---------------------------------------------------------------------------------------------
// Sources

#[test]
fn constants_give_round_v_times_255_in_8_bit_png_and_exact_16_bit() {
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("c.toml");
    std::fs::write(
        &recipe,
        "size = \"3x2\"\nmax_lod_bias = 4\nreflectivity = 0.2\ntransmittance = 0.6\nblur = 0.25\nfresnel = 1\n",
    )
    .unwrap();
    let out = dir.path().join("c.png");
    let o = cubeforge(&[&"control", &recipe, &"-o", &out], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let (w, h, px) = png8(&out);
    assert_eq!((w, h), (3, 2));
    for t in px.chunks(4) {
        // 0.2 * 255 = 51, 0.6 * 255 = 153, 0.25 * 255 = 63.75, 1 * 255 = 255.
        assert_eq!(t, [51, 153, 64, 255]);
    }

    let out16 = dir.path().join("c16.png");
    let o = cubeforge(
        &[&"control", &recipe, &"-o", &out16, &"--png16"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&out16).unwrap();
    assert_eq!(img.color(), image::ColorType::Rgba16);
    for t in img.to_rgba16().into_raw().chunks(4) {
        // 0.2 * 65535 = 13107, 0.6 * 65535 = 39321, 0.25 * 65535 = 16383.75.
        assert_eq!(t, [13107, 39321, 16384, 65535]);
    }

    // The table form and a bare number are the same source.
    let a = bake("reflectivity = 0.2\n", 2, 2);
    let b = bake("[reflectivity]\nconstant = 0.2\n", 2, 2);
    assert_eq!(a.image, b.image);
    assert!(channel(&a, 0).iter().all(|&v| v == 0.2));
}

#[test]
fn parameters_not_in_the_recipe_are_zero() {
    let b = bake("reflectivity = 0.5\n", 2, 1);
    assert_eq!(channel(&b, 0), [0.5, 0.5]);
    for c in 1..4 {
        assert_eq!(channel(&b, c), [0.0, 0.0]);
    }
    assert_eq!(b.channels[1].source, "0 (not in the recipe)");
}

#[test]
fn linear_gradient_endpoints_and_steps() {
    // Texel centres of a 4-wide map are at u = 0.125, 0.375, 0.625, 0.875.
    assert_close(
        &refl(
            "linear_gradient = { from = [0.125, 0], to = [0.875, 0] }",
            4,
            1,
        ),
        &[0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0],
    );
    // The default runs left to right across the whole image.
    assert_close(
        &refl("linear_gradient = {}", 4, 1),
        &[0.125, 0.375, 0.625, 0.875],
    );
    // Top to bottom; beyond the ends it clamps.
    assert_close(
        &refl("linear_gradient = { from = [0, 0.3], to = [0, 0.7] }", 1, 4),
        &[0.0, 0.1875, 0.8125, 1.0],
    );
    // Right to left.
    assert_close(
        &refl(
            "linear_gradient = { from = [0.875, 0], to = [0.125, 0] }",
            4,
            1,
        ),
        &[1.0, 2.0 / 3.0, 1.0 / 3.0, 0.0],
    );
    // Diagonal: constant along lines perpendicular to from -> to.
    let d = refl("linear_gradient = { from = [0, 0], to = [1, 1] }", 4, 4);
    for y in 0..4 {
        for x in 0..4 {
            let want = (x + y + 1) as f32 / 8.0;
            assert!((d[y * 4 + x] - want).abs() < EPS);
        }
    }
    // In an 8-bit PNG the endpoints are exactly 0 and 255.
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("g.toml");
    std::fs::write(
        &recipe,
        "size = \"4x1\"\n[reflectivity]\nlinear_gradient = { from = [0.125, 0], to = [0.875, 0] }\n",
    )
    .unwrap();
    let out = dir.path().join("g.png");
    let o = cubeforge(&[&"control", &recipe, &"-o", &out], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let (_, _, px) = png8(&out);
    let r: Vec<u8> = px.chunks(4).map(|t| t[0]).collect();
    assert_eq!(r, [0, 85, 170, 255]);
}

#[test]
fn radial_gradient_is_distance_over_radius() {
    let v = refl(
        "radial_gradient = { center = [0.5, 0.5], radius = 0.5 }",
        4,
        4,
    );
    for y in 0..4 {
        for x in 0..4 {
            let (u, w) = ((x as f32 + 0.5) / 4.0, (y as f32 + 0.5) / 4.0);
            let want = (((u - 0.5).powi(2) + (w - 0.5).powi(2)).sqrt() / 0.5).min(1.0);
            assert!((v[y * 4 + x] - want).abs() < EPS, "({x}, {y})");
        }
    }
    // Inner texels: sqrt(2) * 0.125 / 0.5; corners are past the radius: 1.
    assert!((v[5] - 0.353_553_4).abs() < EPS);
    assert_eq!(v[0], 1.0);
    // Centred on a texel centre: exactly 0 there, 1 at the radius.
    let v = refl(
        "radial_gradient = { center = [0.125, 0.5], radius = 0.75 }",
        4,
        1,
    );
    assert_close(&v, &[0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0]);
}

#[test]
fn checker_cells() {
    assert_eq!(
        refl("checker = { cells = [2, 2] }", 4, 4),
        [0., 0., 1., 1., 0., 0., 1., 1., 1., 1., 0., 0., 1., 1., 0., 0.]
    );
    assert_eq!(
        refl("checker = { cells = [4, 1] }", 8, 2),
        [0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1., 1., 0., 0., 1., 1.]
    );
    // The default is 8 x 8: 64-texel cells on a 512 map, top-left 0.
    let v = refl("checker = {}", 512, 512);
    for (x, y, want) in [
        (0, 0, 0.0),
        (63, 63, 0.0),
        (64, 0, 1.0),
        (0, 64, 1.0),
        (64, 64, 0.0),
    ] {
        assert_eq!(v[y * 512 + x], want, "({x}, {y})");
    }
}

#[test]
fn stripes_count_width_offset_and_angle() {
    assert_eq!(
        refl("stripes = { count = 2, width = 0.5 }", 8, 1),
        [1., 1., 0., 0., 1., 1., 0., 0.]
    );
    assert_eq!(
        refl("stripes = { count = 2, width = 0.25 }", 8, 1),
        [1., 0., 0., 0., 1., 0., 0., 0.]
    );
    // Shifted by a quarter period.
    assert_eq!(
        refl("stripes = { count = 2, width = 0.5, offset = 0.25 }", 8, 1),
        [0., 1., 1., 0., 0., 1., 1., 0.]
    );
    // 90 degrees: the value changes top to bottom.
    assert_eq!(
        refl("stripes = { count = 2, width = 0.5, angle = 90 }", 2, 4),
        [1., 1., 0., 0., 1., 1., 0., 0.]
    );
    // A band: one period, 1 from 35% to 65% of the height.
    let band = refl(
        "stripes = { count = 1, width = 0.3, angle = 90, offset = 0.35 }",
        1,
        20,
    );
    let want: Vec<f32> = (0..20)
        .map(|y| {
            let v = (y as f32 + 0.5) / 20.0;
            if (0.35..0.65).contains(&v) {
                1.0
            } else {
                0.0
            }
        })
        .collect();
    assert_eq!(band, want);
    // Width 0 and 1.
    assert!(refl("stripes = { width = 0 }", 16, 4)
        .iter()
        .all(|&v| v == 0.0));
    assert!(refl("stripes = { width = 1 }", 16, 4)
        .iter()
        .all(|&v| v == 1.0));
}

#[test]
fn noise_is_deterministic_seeded_in_range_and_smooth() {
    let text = "noise = { cells = [8, 8], seed = 42, octaves = 4 }";
    let a = refl(text, 64, 64);
    let b = refl(text, 64, 64);
    assert_eq!(a, b, "the same recipe gives the same noise");
    let c = refl("noise = { cells = [8, 8], seed = 43, octaves = 4 }", 64, 64);
    assert_ne!(a, c, "another seed gives other noise");
    let (lo, hi) = a
        .iter()
        .fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
    assert!(lo >= 0.0 && hi <= 1.0, "range {lo}..{hi}");
    assert!(hi - lo > 0.3, "noise should vary: {lo}..{hi}");
    // Smooth: neighbours differ little compared to the range.
    let one = refl("noise = { cells = [4, 4], seed = 1 }", 128, 128);
    for y in 0..128 {
        for x in 1..128 {
            assert!((one[y * 128 + x] - one[y * 128 + x - 1]).abs() < 0.1);
        }
    }

    // Exact values: with one cell per texel, each texel centre lies halfway between four
    // lattice points, where the quintic weights are 1/2: the mean of those four, wrapping.
    let v = refl("noise = { cells = [4, 4], seed = 9 }", 4, 4);
    for y in 0..4u64 {
        for x in 0..4u64 {
            let l = |i: u64, j: u64| lattice(9, 0, i % 4, j % 4);
            let want = (l(x, y) + l(x + 1, y) + l(x, y + 1) + l(x + 1, y + 1)) / 4.0;
            assert!((v[(y * 4 + x) as usize] as f64 - want).abs() < 1e-6);
        }
    }
    // The lattice hash is fixed: these values never change between runs or versions.
    assert_eq!(lattice(0, 0, 0, 0), lattice(0, 0, 0, 0));
    assert_ne!(lattice(0, 0, 0, 0), lattice(1, 0, 0, 0));
    assert_ne!(lattice(0, 0, 1, 0), lattice(0, 0, 0, 1));

    // It tiles: the value just inside the left edge continues from the right edge.
    let n = Noise {
        cells: [4, 4],
        seed: 5,
        octaves: 3,
        persistence: 0.5,
    };
    for v in [0.1, 0.5, 0.9] {
        assert!((n.at(1e-9, v) - n.at(1.0 - 1e-9, v)).abs() < 1e-6);
        assert!((n.at(v, 1e-9) - n.at(v, 1.0 - 1e-9)).abs() < 1e-6);
    }
    // Persistence 0 keeps only the first octave.
    assert_eq!(
        refl(
            "noise = { cells = [3, 5], seed = 2, octaves = 5, persistence = 0 }",
            32,
            32
        ),
        refl("noise = { cells = [3, 5], seed = 2 }", 32, 32)
    );
}

// ---------------------------------------------------------------------------------------------
// Operations

#[test]
fn invert() {
    assert_eq!(
        refl("checker = { cells = [2, 1] }\ninvert = true", 4, 1),
        [1., 1., 0., 0.]
    );
    assert_close(&refl("constant = 0.25\ninvert = true", 1, 1), &[0.75]);
    assert_close(&refl("constant = 0.25\ninvert = false", 1, 1), &[0.25]);
}

#[test]
fn remap_levels_and_gamma() {
    // Gradient 0.125 .. 0.875 onto 0.2 .. 0.6.
    assert_close(
        &refl(
            "linear_gradient = {}\nremap = { in = [0.125, 0.875], out = [0.2, 0.6] }",
            4,
            1,
        ),
        &[0.2, 0.2 + 0.4 / 3.0, 0.2 + 0.8 / 3.0, 0.6],
    );
    // Below and above the input levels clamp.
    assert_close(
        &refl(
            "linear_gradient = {}\nremap = { in = [0.375, 0.625] }",
            4,
            1,
        ),
        &[0.0, 0.0, 1.0, 1.0],
    );
    // Gamma like the middle slider of Levels: t^(1/gamma).
    assert_close(
        &refl("constant = 0.25\nremap = { gamma = 2 }", 1, 1),
        &[0.5],
    );
    assert_close(
        &refl("constant = 0.25\nremap = { gamma = 0.5 }", 1, 1),
        &[0.0625],
    );
    // Reversed output levels invert; gamma applies before the output levels.
    assert_close(
        &refl(
            "constant = 0.25\nremap = { out = [1, 0.5], gamma = 2 }",
            1,
            1,
        ),
        &[0.75],
    );
    // Remap comes before invert, whatever the order in the file.
    assert_close(
        &refl(
            "constant = 0.25\ninvert = true\nremap = { gamma = 2 }",
            1,
            1,
        ),
        &[0.5],
    );
}

#[test]
fn multiply() {
    assert_close(
        &refl("checker = { cells = [2, 1] }\nmultiply = 0.5", 4, 1),
        &[0.0, 0.0, 0.5, 0.5],
    );
    assert_close(
        &refl("constant = 0.5\nmultiply = { linear_gradient = {} }", 4, 1),
        &[0.0625, 0.1875, 0.3125, 0.4375],
    );
}

#[test]
fn mix_with_another_source() {
    // amount 0 keeps the value, 1 takes `with`, exactly.
    assert_eq!(
        refl(
            "constant = 0.2\nmix = { with = 0.9, amount = { checker = { cells = [2, 1] } } }",
            4,
            1
        ),
        [0.2, 0.2, 0.9, 0.9]
    );
    assert_close(
        &refl("constant = 0.2\nmix = { with = 1, amount = 0.25 }", 1, 1),
        &[0.4],
    );
    // Operations nest: `with` and `amount` are sources with operations of their own.
    assert_close(
        &refl(
            "constant = 0\nmix = { with = { constant = 0.25, invert = true }, amount = { constant = 1, multiply = 0.5 } }",
            1,
            1,
        ),
        &[0.375],
    );
    // The order: remap, invert, multiply, mix.
    assert_close(
        &refl(
            "constant = 0.25\nmix = { with = 1, amount = 0.5 }\nmultiply = 0.5\ninvert = true\nremap = { gamma = 2 }",
            1,
            1,
        ),
        // 0.25 -> remap 0.5 -> invert 0.5 -> x0.5 0.25 -> mix with 1 by 0.5: 0.625
        &[0.625],
    );
}

// ---------------------------------------------------------------------------------------------
// Images

#[test]
fn image_channels_luminance_and_srgb_decode() {
    let dir = tempfile::tempdir().unwrap();
    let px = [200u8, 100, 50, 128, 10, 20, 240, 255];
    write_png8(&dir.path().join("m.png"), 2, 1, &px);
    let f = |b: u8| b as f32 / 255.0;
    let get = |ch: &str, srgb: bool| {
        let text = format!(
            "[reflectivity]\nimage = {{ path = \"m.png\", channel = \"{ch}\", srgb = {srgb} }}\n"
        );
        channel(&bake_in(dir.path(), &text, 2, 1), 0)
    };
    assert_close(&get("r", false), &[f(200), f(10)]);
    assert_close(&get("g", false), &[f(100), f(20)]);
    assert_close(&get("b", false), &[f(50), f(240)]);
    assert_close(&get("a", false), &[f(128), f(255)]);
    assert_close(&get("red", false), &[f(200), f(10)]);
    let lum = |a: [u8; 3], dec: bool| {
        let t = |b: u8| if dec { srgb_to_linear(f(b)) } else { f(b) };
        luminance(Vec4::new(t(a[0]), t(a[1]), t(a[2]), 0.0))
    };
    assert_close(
        &get("luminance", false),
        &[lum([200, 100, 50], false), lum([10, 20, 240], false)],
    );
    // srgb = true decodes colour; alpha is never decoded.
    assert_close(
        &get("r", true),
        &[srgb_to_linear(f(200)), srgb_to_linear(f(10))],
    );
    assert_close(&get("a", true), &[f(128), f(255)]);
    assert_close(
        &get("luminance", true),
        &[lum([200, 100, 50], true), lum([10, 20, 240], true)],
    );
    // Luminance is the default channel.
    let d = bake_in(
        dir.path(),
        "[reflectivity]\nimage = { path = \"m.png\" }\n",
        2,
        1,
    );
    assert_close(&channel(&d, 0), &get("luminance", false));

    // A grey 16-bit PNG: exact 16-bit values.
    let grey16: Vec<u16> = vec![0, 13107, 65535, 32768];
    let bytes: Vec<u8> = grey16.iter().flat_map(|v| v.to_ne_bytes()).collect();
    image::save_buffer(
        dir.path().join("g16.png"),
        &bytes,
        4,
        1,
        image::ExtendedColorType::L16,
    )
    .unwrap();
    let v = channel(
        &bake_in(
            dir.path(),
            "max_lod_bias = 1\n[blur]\nimage = { path = \"g16.png\", channel = \"r\" }\n",
            4,
            1,
        ),
        2,
    );
    assert_close(&v, &[0.0, 0.2, 1.0, 32768.0 / 65535.0]);

    // Float data above 1 clamps to 1; srgb does not apply to it.
    let img = cubeforge::image::Image {
        width: 2,
        height: 1,
        pixels: vec![
            Vec4::new(3.0, 0.25, 0.0, 1.0),
            Vec4::new(0.5, 0.0, 0.0, 1.0),
        ],
    };
    let exr = dir.path().join("f.exr");
    std::fs::write(
        &exr,
        io::encode_image(&exr, &img, &Default::default()).unwrap(),
    )
    .unwrap();
    let v = channel(
        &bake_in(
            dir.path(),
            "[fresnel]\nimage = { path = \"f.exr\", channel = \"r\", srgb = true }\n",
            2,
            1,
        ),
        3,
    );
    assert_close(&v, &[1.0, 0.5]);
}

#[test]
fn images_resize_with_area_filter_down_and_bilinear_up() {
    let dir = tempfile::tempdir().unwrap();
    // 4 x 1 grey: 0, 64, 128, 255.
    let row = [0u8, 64, 128, 255];
    let rgba: Vec<u8> = row.iter().flat_map(|&v| [v, v, v, 255]).collect();
    write_png8(&dir.path().join("row.png"), 4, 1, &rgba);
    let f = |b: u8| b as f32 / 255.0;
    let src = "[reflectivity]\nimage = { path = \"row.png\", channel = \"r\" }\n";
    // Shrinking 4 -> 2: each output texel is the mean of the two it covers.
    assert_close(
        &channel(&bake_in(dir.path(), src, 2, 1), 0),
        &[(f(0) + f(64)) / 2.0, (f(128) + f(255)) / 2.0],
    );
    // 4 -> 1: the mean of all.
    assert_close(
        &channel(&bake_in(dir.path(), src, 1, 1), 0),
        &[(f(0) + f(64) + f(128) + f(255)) / 4.0],
    );
    // 4 -> 3: area weights (each output texel covers 4/3 input texels).
    assert_close(
        &channel(&bake_in(dir.path(), src, 3, 1), 0),
        &[
            (f(0) + f(64) / 3.0) * 0.75,
            (f(64) * 2.0 / 3.0 + f(128) * 2.0 / 3.0) * 0.75,
            (f(128) / 3.0 + f(255)) * 0.75,
        ],
    );
    // Enlarging 4 -> 8: bilinear between texel centres, edges clamped.
    let (a, b, c, d) = (f(0), f(64), f(128), f(255));
    assert_close(
        &channel(&bake_in(dir.path(), src, 8, 1), 0),
        &[
            a,
            a * 0.75 + b * 0.25,
            a * 0.25 + b * 0.75,
            b * 0.75 + c * 0.25,
            b * 0.25 + c * 0.75,
            c * 0.75 + d * 0.25,
            c * 0.25 + d * 0.75,
            d,
        ],
    );
    // Each axis on its own: 4x1 -> 2x3 shrinks across and stretches down (one row: copies).
    let v = channel(&bake_in(dir.path(), src, 2, 3), 0);
    let want = [(a + b) / 2.0, (c + d) / 2.0];
    assert_close(&v, &[want, want, want].concat());

    // A 2 x 2 image -> 1 x 1 is the mean; vertical shrinking works like horizontal.
    let sq = [10u8, 20, 30, 40];
    let rgba: Vec<u8> = sq.iter().flat_map(|&v| [v, v, v, 255]).collect();
    write_png8(&dir.path().join("sq.png"), 2, 2, &rgba);
    let v = channel(
        &bake_in(
            dir.path(),
            "[reflectivity]\nimage = { path = \"sq.png\", channel = \"g\" }\n",
            1,
            1,
        ),
        0,
    );
    assert_close(&v, &[(f(10) + f(20) + f(30) + f(40)) / 4.0]);
    let v = channel(
        &bake_in(
            dir.path(),
            "[reflectivity]\nimage = { path = \"sq.png\", channel = \"g\" }\n",
            2,
            1,
        ),
        0,
    );
    assert_close(&v, &[(f(10) + f(30)) / 2.0, (f(20) + f(40)) / 2.0]);

    // The library function on a plane directly.
    assert_close(
        &control::resize(&[0.0, 1.0], 2, 1, 4, 1),
        &[0.0, 0.25, 0.75, 1.0],
    );
    assert_close(
        &control::resize(&[0.0, 1.0], 1, 2, 1, 4),
        &[0.0, 0.25, 0.75, 1.0],
    );
}

#[test]
fn size_comes_from_the_option_the_recipe_or_the_first_image() {
    let dir = tempfile::tempdir().unwrap();
    write_png8(&dir.path().join("m.png"), 3, 2, &[255u8; 24]);
    let r = parse_in(
        dir.path(),
        "[fresnel]\nimage = { path = \"m.png\" }\n",
        Syntax::Toml,
    )
    .unwrap();
    assert_eq!(r.output_size(None).unwrap(), Size::new(3, 2).unwrap());
    let r = parse_in(
        dir.path(),
        "size = \"7x5\"\n[fresnel]\nimage = { path = \"m.png\" }\n",
        Syntax::Toml,
    )
    .unwrap();
    assert_eq!(r.output_size(None).unwrap(), Size::new(7, 5).unwrap());
    let given = Some(Size::new(4, 4).unwrap());
    assert_eq!(r.output_size(given).unwrap(), Size::new(4, 4).unwrap());
    let r = parse_in(dir.path(), "size = 16\n", Syntax::Toml).unwrap();
    assert_eq!(r.output_size(None).unwrap(), Size::new(16, 16).unwrap());
    let r = parse_in(dir.path(), "reflectivity = 1\n", Syntax::Toml).unwrap();
    let e = r.output_size(None).unwrap_err().to_string();
    assert!(e.contains("no size"), "{e}");
    assert!("0x4".parse::<Size>().is_err());
    assert!("4by4".parse::<Size>().is_err());
    assert_eq!("12X3".parse::<Size>().unwrap(), Size::new(12, 3).unwrap());
}

// ---------------------------------------------------------------------------------------------
// Packing

#[test]
fn pack_reassigns_channels() {
    let b = bake(
        "max_lod_bias = 3\nreflectivity = 0.2\ntransmittance = 0.4\nblur = 0.6\n\n[pack]\nr = \"blur\"\ng = \"one\"\nb = \"zero\"\na = \"reflectivity\"\n",
        2,
        2,
    );
    for p in &b.image.pixels {
        assert_eq!(*p, Vec4::new(0.6, 1.0, 0.0, 0.2));
    }
    let holds: Vec<Slot> = b.channels.iter().map(|c| c.holds).collect();
    assert_eq!(
        holds,
        [Slot::Blur, Slot::One, Slot::Zero, Slot::Reflectivity]
    );
    // transmittance is set but packed nowhere: a warning says so.
    assert_eq!(b.warnings.len(), 1, "{:?}", b.warnings);
    assert!(b.warnings[0].contains("transmittance"));
    // Channels not named keep their default.
    let b = bake(
        "reflectivity = 0.2\nfresnel = 0.8\n[pack]\nr = \"fresnel\"\n",
        1,
        1,
    );
    assert_eq!(b.image.pixels[0], Vec4::new(0.8, 0.0, 0.0, 0.8));
    assert!(b.warnings[0].contains("reflectivity"));
}

// ---------------------------------------------------------------------------------------------
// Errors: the recipe's line, a non-zero exit, nothing written.

/// Runs `control` on a recipe file holding `text`; returns stderr after checking the exit
/// status and that the folder holds nothing but the recipe (and `keep`).
fn fails(name: &str, text: &str, keep: &[(&str, &[u8])]) -> String {
    let dir = tempfile::tempdir().unwrap();
    for (n, bytes) in keep {
        std::fs::write(dir.path().join(n), bytes).unwrap();
    }
    let recipe = dir.path().join(name);
    std::fs::write(&recipe, text).unwrap();
    let before = files_in(dir.path());
    for out in ["out.png", "out.ktx2", "out.exr"] {
        let o = cubeforge(&[&"control", &name, &"-o", &out], dir.path());
        assert!(!o.status.success(), "{name} should fail:\n{text}");
        assert_eq!(o.status.code(), Some(1));
        assert_eq!(files_in(dir.path()), before, "nothing may be written");
        let e = stderr(&o);
        assert!(e.starts_with("cubeforge: error: "), "{e}");
        assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
        assert!(!e.contains("panicked"), "{e}");
    }
    let o = cubeforge(&[&"control", &name, &"-o", &"out.png"], dir.path());
    stderr(&o)
}

#[test]
fn a_missing_image_names_its_line() {
    let e = fails(
        "r.toml",
        "size = 8\n\n[reflectivity]\nconstant = 1\n\n[blur]\nimage = { path = \"paint/mask.png\", channel = \"r\" }\n",
        &[],
    );
    assert!(e.contains("r.toml: line 7:"), "{e}");
    assert!(
        e.contains("paint/mask.png") && e.contains("not found"),
        "{e}"
    );
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"reflectivity\": {\n    \"image\": {\n      \"channel\": \"r\",\n      \"path\": \"nope.png\"\n    }\n  }\n}\n",
        &[],
    );
    assert!(
        e.contains("r.json: line 6:") && e.contains("nope.png"),
        "{e}"
    );
    // A file that is there but is no image: its decode error, still with the line.
    let e = fails(
        "r.toml",
        "size = 8\n[fresnel]\nimage = { path = \"bad.png\" }\n",
        &[("bad.png", b"not a png")],
    );
    assert!(e.contains("line 3:") && e.contains("bad.png"), "{e}");
}

#[test]
fn an_unknown_channel_names_its_line() {
    let png = {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.png");
        write_png8(&p, 1, 1, &[1, 2, 3, 4]);
        std::fs::read(p).unwrap()
    };
    let e = fails(
        "r.toml",
        "size = 8\n[reflectivity]\nimage = { path = \"m.png\", channel = \"x\" }\n",
        &[("m.png", &png)],
    );
    assert!(
        e.contains("line 3:") && e.contains("unknown variant `x`"),
        "{e}"
    );
    // A channel of the packing that does not exist.
    let e = fails(
        "r.toml",
        "size = 8\n\n[pack]\nr = \"blur\"\nq = \"fresnel\"\n",
        &[],
    );
    assert!(
        e.contains("line 5:") && e.contains("unknown field `q`"),
        "{e}"
    );
    // A parameter that does not exist, as a channel's content.
    let e = fails("r.toml", "size = 8\n[pack]\ng = \"roughness\"\n", &[]);
    assert!(e.contains("line 3:") && e.contains("roughness"), "{e}");
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"pack\": {\n    \"x\": \"blur\"\n  }\n}\n",
        &[],
    );
    assert!(e.contains("line 4:") && e.contains("`x`"), "{e}");
}

#[test]
fn an_unknown_parameter_names_its_line() {
    let e = fails(
        "r.toml",
        "size = 8\nreflectivity = 1\nroughness = 0.5\n",
        &[],
    );
    assert!(
        e.contains("line 3:") && e.contains("unknown field `roughness`"),
        "{e}"
    );
    // ... or an unknown key in a source or operation.
    let e = fails(
        "r.toml",
        "size = 8\n[blur]\nchecker = { cells = [2, 2] }\nremap = { in = [0, 1], levels = 3 }\n",
        &[],
    );
    assert!(
        e.contains("line 4:") && e.contains("unknown field `levels`"),
        "{e}"
    );
    let e = fails(
        "r.toml",
        "size = 8\n[blur]\n\n[blur.checker]\ncells = [2, 2]\ncolour = 1\n",
        &[],
    );
    assert!(e.contains("line 6:") && e.contains("colour"), "{e}");
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"reflectivity\": {\n    \"noise\": { \"seed\": 3 },\n    \"blend\": 1\n  }\n}\n",
        &[],
    );
    assert!(e.contains("line 5:") && e.contains("`blend`"), "{e}");
}

#[test]
fn a_value_outside_0_1_names_its_line() {
    let e = fails("r.toml", "size = 8\nreflectivity = 0.5\nblur = 1.5\n", &[]);
    assert!(
        e.contains("line 3:") && e.contains("1.5 is outside [0, 1]"),
        "{e}"
    );
    let e = fails(
        "r.toml",
        "size = 8\n\n[fresnel]\nlinear_gradient = { from = [0, 0], to = [1, -0.5] }\n",
        &[],
    );
    assert!(
        e.contains("line 4:") && e.contains("-0.5 is outside [0, 1]"),
        "{e}"
    );
    let e = fails(
        "r.toml",
        "size = 8\n[reflectivity]\nconstant = 0.5\nremap = { in = [0, 1],\n  out = [0, 2] }\n",
        &[],
    );
    assert!(e.contains("line 5:") && e.contains("2 is outside"), "{e}");
    let e = fails(
        "r.toml",
        "size = 8\n[reflectivity]\nconstant = 0\n[reflectivity.mix]\nwith = 1\namount = 7\n",
        &[],
    );
    assert!(e.contains("line 6:") && e.contains("7 is outside"), "{e}");
    let e = fails(
        "r.json",
        "{\n  \"size\": 8,\n  \"transmittance\": {\n    \"constant\":\n      -1\n  }\n}\n",
        &[],
    );
    assert!(
        e.contains("r.json: line 5:") && e.contains("-1 is outside"),
        "{e}"
    );
    // Other bounded numbers say what they need.
    let e = fails(
        "r.toml",
        "size = 8\nfresnel = { noise = { octaves = 0 } }\n",
        &[],
    );
    assert!(e.contains("line 2:") && e.contains("octaves"), "{e}");
    let e = fails("r.toml", "size = 8\nmax_lod_bias = -1\n", &[]);
    assert!(e.contains("line 2:") && e.contains("max_lod_bias"), "{e}");
}

#[test]
fn other_recipe_errors() {
    // TOML syntax.
    let e = fails("r.toml", "size = 8\nreflectivity = [0.5\n", &[]);
    assert!(e.contains("line 2:"), "{e}");
    // JSON syntax.
    let e = fails("r.json", "{\n  \"size\": 8,\n  \"blur\" 1\n}\n", &[]);
    assert!(e.contains("line 3:"), "{e}");
    // Two kinds in one source, or none.
    let e = fails(
        "r.toml",
        "size = 8\n[blur]\nchecker = {}\nnoise = {}\n",
        &[],
    );
    assert!(e.contains("exactly one"), "{e}");
    let e = fails("r.toml", "size = 8\n[blur]\ninvert = true\n", &[]);
    assert!(e.contains("needs one of"), "{e}");
    // Blur without the LOD bias it is a fraction of.
    let e = fails("r.toml", "size = 8\nblur = 0.5\n", &[]);
    assert!(e.contains("max_lod_bias"), "{e}");
    // No size anywhere.
    let e = fails("r.toml", "reflectivity = 0.5\n", &[]);
    assert!(e.contains("no size"), "{e}");
    // A JSON array is not a recipe (serde would read a struct from it by position).
    let e = fails("r.json", "[8, 2]\n", &[]);
    assert!(e.contains("line 1:") && e.contains("one object"), "{e}");
    // Not a recipe extension.
    let e = fails("r.yaml", "size: 8\n", &[]);
    assert!(e.contains(".toml or .json"), "{e}");
}

#[test]
fn bad_options_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("r.toml");
    std::fs::write(&recipe, "size = 8\nreflectivity = 1\n").unwrap();
    for args in [
        vec!["-o", "out.jpg"],
        vec!["-o", "out.dds"],
        vec!["-o", "out.png", "--size", "0x4"],
        vec!["-o", "out.png", "--size", "big"],
        vec!["-o", "out.ktx2", "--gpu-format", "rgba8-srgb"],
        vec!["-o", "out.exr", "--png16"],
        vec!["-o", "out.ktx2", "--levels", "9"],
        vec!["-o", "r.toml.png", "--size", "60000x60000"],
        vec!["-o", "r.toml"],
    ] {
        let mut full: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"control", &"r.toml"];
        for a in &args {
            full.push(a);
        }
        let o = cubeforge(&full, dir.path());
        assert!(!o.status.success(), "{args:?} should fail");
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
        assert_eq!(files_in(dir.path()), ["r.toml"], "{args:?}");
    }
}

// ---------------------------------------------------------------------------------------------
// Outputs

/// Little-endian u32 / u64 at a byte offset.
fn u32_at(b: &[u8], o: usize) -> u32 {
    u32::from_le_bytes(b[o..o + 4].try_into().unwrap())
}
fn u64_at(b: &[u8], o: usize) -> u64 {
    u64::from_le_bytes(b[o..o + 8].try_into().unwrap())
}

#[test]
fn ktx2_output_is_a_2d_unorm_texture_with_its_mip_chain() {
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("k.toml");
    std::fs::write(
        &recipe,
        "size = \"8x4\"\nmax_lod_bias = 2\nreflectivity = 0.2\nblur = { checker = { cells = [2, 1] } }\nfresnel = 1\n",
    )
    .unwrap();
    let out = dir.path().join("k.ktx2");
    let o = cubeforge(&[&"control", &recipe, &"-o", &out], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let b = std::fs::read(&out).unwrap();
    assert_eq!(b[..12], io::ktx2::IDENTIFIER);
    assert_eq!(u32_at(&b, 12), 37, "VK_FORMAT_R8G8B8A8_UNORM");
    assert_eq!(u32_at(&b, 16), 1, "typeSize");
    assert_eq!((u32_at(&b, 20), u32_at(&b, 24)), (8, 4), "pixel size");
    assert_eq!(u32_at(&b, 28), 0, "pixelDepth");
    assert_eq!(u32_at(&b, 32), 0, "layerCount");
    assert_eq!(u32_at(&b, 36), 1, "faceCount");
    assert_eq!(u32_at(&b, 40), 4, "levels 8x4, 4x2, 2x1, 1x1");
    assert_eq!(u32_at(&b, 44), 0, "no supercompression");
    // The DFD says linear transfer (not sRGB).
    let dfd = u32_at(&b, 48) as usize;
    assert_eq!(
        (u32_at(&b, dfd + 12) >> 16) & 0xFF,
        1,
        "KHR_DF_TRANSFER_LINEAR"
    );
    let sizes = [(8, 4), (4, 2), (2, 1), (1, 1)];
    let mut levels = Vec::new();
    for (l, &(w, h)) in sizes.iter().enumerate() {
        let e = 80 + 24 * l;
        let (off, len) = (u64_at(&b, e) as usize, u64_at(&b, e + 8) as usize);
        assert_eq!(len, w * h * 4, "level {l} length");
        assert_eq!(u64_at(&b, e + 16) as usize, len);
        assert_eq!(off % 4, 0);
        assert!(off + len <= b.len());
        levels.push(&b[off..off + len]);
    }
    // Level 0: R = 51, B = the checker (0 left half, 255 right), A = 255.
    for y in 0..4 {
        for x in 0..8 {
            let t = &levels[0][(y * 8 + x) * 4..][..4];
            assert_eq!(t, [51, 0, if x < 4 { 0 } else { 255 }, 255], "({x}, {y})");
        }
    }
    // Box mips: 4x2 keeps the halves; 1x1 averages them to 0.5 -> 128.
    assert_eq!(&levels[1][..4], [51, 0, 0, 255]);
    assert_eq!(&levels[1][12..16], [51, 0, 255, 255]);
    assert_eq!(levels[3], [51, 0, 128, 255]);

    // --levels and float formats.
    let out2 = dir.path().join("k2.ktx2");
    let o = cubeforge(
        &[
            &"control",
            &recipe,
            &"-o",
            &out2,
            &"--levels",
            &"2",
            &"--gpu-format",
            &"rgba16f",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let b = std::fs::read(&out2).unwrap();
    assert_eq!(u32_at(&b, 12), 97, "VK_FORMAT_R16G16B16A16_SFLOAT");
    assert_eq!(u32_at(&b, 40), 2);
    assert_eq!(u64_at(&b, 80 + 8), 8 * 4 * 8);
}

#[test]
fn exr_output_holds_the_values() {
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("e.toml");
    std::fs::write(
        &recipe,
        "size = \"4x2\"\nreflectivity = { linear_gradient = {} }\nfresnel = 0.5\n",
    )
    .unwrap();
    let out = dir.path().join("e.exr");
    let o = cubeforge(&[&"control", &recipe, &"-o", &out], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let img = match io::read(&out, &ReadOptions::default()).unwrap().0 {
        Decoded::Image(i) => i,
        _ => panic!("image expected"),
    };
    assert_eq!((img.width, img.height), (4, 2));
    let r: Vec<f32> = img.pixels[..4].iter().map(|p| p.x).collect();
    assert_eq!(r, [0.125, 0.375, 0.625, 0.875]); // exact in half float
    assert!(img.pixels.iter().all(|p| p.w == 0.5 && p.y == 0.0));
}

#[test]
fn sidecar_json_holds_the_lod_bias_and_the_packing() {
    let dir = tempfile::tempdir().unwrap();
    let recipe = dir.path().join("s.toml");
    std::fs::write(
        &recipe,
        "size = \"4x2\"\nmax_lod_bias = 5.5\nreflectivity = 0.5\nblur = { checker = {} }\n[pack]\na = \"one\"\n",
    )
    .unwrap();
    let out = dir.path().join("mask.png");
    let o = cubeforge(&[&"control", &recipe, &"-o", &out], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    // What went where, one line per channel, and the sidecar named.
    for want in [
        "R = reflectivity",
        "G = transmittance",
        "B = blur",
        "A = one",
        "mask.png.json",
    ] {
        assert!(stdout.contains(want), "{want} in:\n{stdout}");
    }
    assert_eq!(
        files_in(dir.path()),
        ["mask.png", "mask.png.json", "s.toml"]
    );
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("mask.png.json")).unwrap()).unwrap();
    assert_eq!(j["max_lod_bias"], 5.5);
    assert_eq!(j["image"], "mask.png");
    assert_eq!(
        (j["width"].as_u64(), j["height"].as_u64()),
        (Some(4), Some(2))
    );
    assert_eq!(j["encoding"], "linear");
    assert_eq!(j["channels"]["r"], "reflectivity");
    assert_eq!(j["channels"]["g"], "transmittance");
    assert_eq!(j["channels"]["b"], "blur");
    assert_eq!(j["channels"]["a"], "one");
    assert_eq!(j["sources"]["b"], "checker 8x8 cells");
    assert_eq!(j["sources"]["r"], "0.5");
}

#[test]
fn outputs_are_byte_identical_across_runs() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let recipe = root.join("fixtures/control/chrome_and_paint.toml");
    for name in ["a.png", "a.ktx2", "a.exr"] {
        let mut runs = Vec::new();
        for i in 0..2 {
            let out = dir.path().join(format!("{i}{name}"));
            let o = cubeforge(
                &[&"control", &recipe, &"-o", &out, &"--size", &"128x96"],
                dir.path(),
            );
            assert!(o.status.success(), "{}", stderr(&o));
            let side = std::fs::read_to_string(dir.path().join(format!("{i}{name}.json"))).unwrap();
            runs.push((
                std::fs::read(&out).unwrap(),
                side.replace(&format!("{i}{name}"), ""),
            ));
        }
        assert!(runs[0] == runs[1], "{name} differs between runs");
    }
}

#[test]
fn json_and_toml_recipes_are_the_same() {
    let toml = "size = \"16x8\"\nmax_lod_bias = 2\n[reflectivity]\nnoise = { cells = [4, 2], seed = 3 }\nremap = { in = [0.2, 0.8], gamma = 1.5 }\n[blur]\nstripes = { count = 3, angle = 45 }\n[pack]\na = \"one\"\n";
    let json = r#"{"size": "16x8", "max_lod_bias": 2,
        "reflectivity": {"noise": {"cells": [4, 2], "seed": 3}, "remap": {"in": [0.2, 0.8], "gamma": 1.5}},
        "blur": {"stripes": {"count": 3, "angle": 45}},
        "pack": {"a": "one"}}"#;
    let a = parse_in(Path::new("."), toml, Syntax::Toml).unwrap();
    let b = parse_in(Path::new("."), json, Syntax::Json).unwrap();
    let l = Limits::default();
    assert_eq!(
        a.bake(None, &l).unwrap().image,
        b.bake(None, &l).unwrap().image
    );
}

#[test]
fn the_example_recipes_bake_from_the_repository_root() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let examples: Vec<PathBuf> = std::fs::read_dir(root.join("fixtures/control"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| Syntax::from_path(p).is_some())
        .collect();
    assert!(examples.len() >= 3, "{examples:?}");
    for recipe in &examples {
        let rel = recipe.strip_prefix(root).unwrap();
        let out = dir
            .path()
            .join(rel.file_stem().unwrap())
            .with_extension("png");
        let o = cubeforge(&[&"control", &rel, &"-o", &out], root);
        assert!(o.status.success(), "{}: {}", rel.display(), stderr(&o));
        let (w, h, _) = png8(&out);
        assert!(w > 0 && h > 0);
    }
    // The frosted band of the glass: blurred and less transmissive between 35% and 65%.
    let out = dir.path().join("frosted_glass.png");
    let (w, h, px) = png8(&out);
    let at = |x: u32, y: u32| &px[((y * w + x) * 4) as usize..][..4];
    let (r, clear, frosted) = (unorm8(0.08), unorm8(0.9), unorm8(0.7));
    assert_eq!(at(10, h / 10), [r, clear, 0, 255]);
    assert_eq!(at(10, 9 * h / 10), [r, clear, 0, 255]);
    let mid = at(10, h / 2);
    assert_eq!(mid[..2], [r, frosted]);
    assert!(mid[2] >= 191, "frosted blur {}", mid[2]);
    // The wet ground takes its size from ../sky.png.
    let (w, h, _) = png8(&dir.path().join("wet_ground.png"));
    assert_eq!((w, h), (512, 256));
}

/// ktx-parse (an independent reader, in $CUBEFORGE_TOOLS or target/tools) reads our 2D KTX2
/// with an odd, non-square mip chain, and writes it back byte for byte. Skipped when absent
/// (a failure under CI).
#[test]
fn ktx_parse_reads_our_2d_ktx2() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let Some(tools) = common::ktx_parse() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let recipe = root.join("fixtures/control/frosted_glass.toml");
    for (format, vk, bpt) in [
        ("rgba8", 37, 4u64),
        ("rgba16f", 97, 8),
        ("rgba32f", 109, 16),
    ] {
        let out = dir.path().join(format!("{format}.ktx2"));
        let o = cubeforge(
            &[
                &"control",
                &recipe,
                &"-o",
                &out,
                &"--size",
                &"24x10",
                &"--gpu-format",
                &format,
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let v = common::ktx_check(&tools, &out, format);
        assert_eq!(v["vkFormat"], vk, "{v}");
        assert_eq!(
            (v["pixelWidth"].as_u64(), v["pixelHeight"].as_u64()),
            (Some(24), Some(10))
        );
        assert_eq!(v["faceCount"], 1, "{v}");
        assert_eq!(v["levelCount"], 5, "{v}");
        // 24x10, 12x5, 6x2, 3x1, 1x1.
        let sizes: Vec<u64> = [240u64, 60, 12, 3, 1].iter().map(|n| n * bpt).collect();
        assert_eq!(v["levels"], serde_json::json!(sizes), "{v}");
        assert_eq!(v["dfd"]["transferFunction"], 1, "linear, not sRGB: {v}");
        assert_eq!(v["rewriteIdentical"], true, "{v}");
    }
}

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
    let Decoded::Image(want) = io::read(&png, &data).unwrap().0 else {
        panic!("the PNG read as a cube map")
    };
    for format in ["rgba8", "rgba16f", "rgba32f"] {
        let map = dir.path().join(format!("map-{format}.ktx2"));
        let o = cubeforge(
            &[&"control", &recipe, &"-o", &map, &"--gpu-format", &format],
            dir.path(),
        );
        assert!(o.status.success(), "{format}: {}", stderr(&o));
        let (decoded, meta) = io::read(&map, &ReadOptions::default()).unwrap();
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
    use cubeforge::image::Image;
    use cubeforge::io::GpuFormat;
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
        let Decoded::Image(got) = io::read(&path, &ReadOptions::default()).unwrap().0 else {
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
        let Decoded::Image(got) = io::read(&path, &ReadOptions::default()).unwrap().0 else {
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
