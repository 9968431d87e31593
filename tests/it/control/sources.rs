//! The sources a recipe can start from (constants, gradients, checkers, stripes, noise), each
//! against the values its definition gives.

use super::*;
use cubeforge::internals::control::{lattice, Noise};

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
