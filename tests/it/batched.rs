//! The batched lookups (vectorised coordinate maths, prefetched texel reads) give exactly the
//! values of the one-at-a-time lookups they speed up, so no output depends on the path taken.

use cubeforge::internals::cube::{Dirs, Environment, Interp, BATCH};
use cubeforge::internals::image::Image;
use cubeforge::internals::layout::{ImageEnv, Projection};
use glam::{Vec3, Vec4};

/// A deterministic, busy image: every texel differs from its neighbours.
fn busy(w: usize, h: usize) -> Image {
    Image::from_fn(w, h, |x, y| {
        let k = (x * 7919 + y * 104_729) % 1013;
        Vec4::new(
            k as f32 / 97.0,
            (x % 13) as f32,
            (y % 17) as f32 * 0.25,
            1.0,
        )
    })
}

/// Directions spread over the sphere (a Fibonacci lattice) plus the axes and the seams.
fn directions() -> Vec<Vec3> {
    let n = 2000;
    let mut v: Vec<Vec3> = (0..n)
        .map(|i| {
            let y = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = (1.0 - y * y).sqrt();
            let a = i as f32 * 2.399_963;
            Vec3::new(r * a.cos(), y, r * a.sin())
        })
        .collect();
    for d in [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
        Vec3::new(-1e-7, 0.3, -1.0).normalize(),
        Vec3::new(1e-7, -0.3, -1.0).normalize(),
        Vec3::new(0.0, 0.0, -1.0),
    ] {
        v.push(d);
    }
    v
}

#[test]
fn bilinear_many_matches_bilinear() {
    let img = busy(37, 19);
    for wrap in [true, false] {
        let mut xs = Vec::new();
        let mut ys = Vec::new();
        for j in 0..=40 {
            for i in 0..=80 {
                xs.push(i as f32 / 80.0 * img.width as f32);
                ys.push(j as f32 / 40.0 * img.height as f32);
            }
        }
        let mut out = vec![Vec4::ZERO; xs.len()];
        img.bilinear_many(&xs, &ys, wrap, &mut out);
        for k in 0..xs.len() {
            let want = img.bilinear(xs[k], ys[k], wrap);
            assert_eq!(out[k], want, "wrap {wrap} at ({}, {})", xs[k], ys[k]);
        }
    }
}

#[test]
fn sample_many_matches_sample() {
    let dirs = directions();
    for (projection, w, h) in [
        (Projection::Equirect, 64, 32),
        (Projection::Sphere, 48, 48),
        (Projection::Angular, 48, 48),
    ] {
        let img = busy(w, h);
        let env = ImageEnv::new(projection, &img, None);
        assert_batches_match(&env, &dirs, &format!("{projection:?}"));
    }
}

/// `sample_many` gives `sample`'s values at every level, both interpolations.
fn assert_batches_match(env: &dyn Environment, dirs: &[Vec3], what: &str) {
    for level in 0..env.levels() {
        for interp in [Interp::Bilinear, Interp::Bicubic] {
            for chunk in dirs.chunks(BATCH) {
                let mut batch = Dirs::default();
                for d in chunk {
                    batch.push(*d);
                }
                let mut out = vec![Vec4::ZERO; chunk.len()];
                env.sample_many(&batch, level, interp, &mut out);
                for (d, got) in chunk.iter().zip(&out) {
                    let want = env.sample(*d, level, interp);
                    assert_eq!(*got, want, "{what} level {level} {interp:?} along {d}");
                }
            }
        }
    }
}

#[test]
fn batch_transform_and_normalize_match_glam() {
    let m = cubeforge::internals::resample::Orientation {
        yaw: 33.0,
        pitch: -12.0,
        roll: 7.5,
        mirror: true,
    }
    .lookup_matrix();
    let dirs: Vec<Vec3> = directions().iter().map(|d| *d * 3.7).collect();
    for chunk in dirs.chunks(BATCH) {
        let mut batch = Dirs::default();
        for d in chunk {
            batch.push(*d);
        }
        batch.transform(&m);
        batch.normalize();
        for (i, d) in chunk.iter().enumerate() {
            assert_eq!(batch.get(i), (m * *d).normalize());
        }
    }
}

#[test]
fn cube_sample_many_matches_sample() {
    let n = 24;
    let cube = cubeforge::internals::cube::CubeMap {
        levels: vec![std::array::from_fn(|f| {
            let img = busy(n, n);
            Image::from_fn(n, n, |x, y| img.get(x, y) + Vec4::splat(f as f32))
        })],
    }
    .with_box_mips(None);
    let sampler = cubeforge::internals::cube::CubeSampler::new(&cube);
    let mut dirs = directions();
    // Face edges and corners, where the face choice ties.
    for d in [
        Vec3::new(1.0, 1.0, 0.3),
        Vec3::new(-1.0, 0.2, -1.0),
        Vec3::ONE,
        Vec3::NEG_ONE,
    ] {
        dirs.push(d.normalize());
    }
    assert_batches_match(&sampler, &dirs, "cube");
}

#[test]
fn sampler_with_box_mips_matches_the_copying_route() {
    let n = 20;
    let faces: cubeforge::internals::cube::Faces = std::array::from_fn(|f| {
        let img = busy(n, n);
        Image::from_fn(n, n, |x, y| img.get(x, y) * (f + 1) as f32)
    });
    let cube = cubeforge::internals::cube::CubeMap {
        levels: vec![faces.clone()],
    };
    for count in [Some(1), Some(3), None] {
        let direct = cubeforge::internals::cube::CubeSampler::with_box_mips(&faces, count);
        let copied =
            cubeforge::internals::cube::CubeSampler::new(&cube.clone().with_box_mips(count));
        assert_eq!(direct.levels(), copied.levels());
        for level in 0..direct.levels() {
            for d in directions() {
                assert_eq!(
                    direct.sample(d, level, Interp::Bilinear),
                    copied.sample(d, level, Interp::Bilinear)
                );
            }
        }
    }
}

#[test]
fn trilinear_many_matches_sample_split() {
    let n = 16;
    let cube = cubeforge::internals::cube::CubeMap {
        levels: vec![std::array::from_fn(|f| {
            let img = busy(n, n);
            Image::from_fn(n, n, |x, y| img.get(x, y) - Vec4::splat(f as f32))
        })],
    };
    let sampler = cubeforge::internals::cube::CubeSampler::with_box_mips(&cube.levels[0], None);
    let dirs = directions();
    let top = sampler.levels();
    for chunk in dirs.chunks(BATCH) {
        let mut batch = Dirs::default();
        let mut levels = Vec::new();
        let mut fracs = Vec::new();
        for (i, d) in chunk.iter().enumerate() {
            batch.push(*d * 2.5);
            levels.push(i % top);
            fracs.push([0.0, 0.25, 0.9][i % 3]);
        }
        let mut out = vec![Vec4::ZERO; chunk.len()];
        sampler.trilinear_many(&batch, &levels, &fracs, &mut out);
        for (i, d) in chunk.iter().enumerate() {
            assert_eq!(
                out[i],
                sampler.sample_split(*d * 2.5, levels[i], fracs[i]),
                "along {d}"
            );
        }
    }
}
