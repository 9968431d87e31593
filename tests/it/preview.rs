//! `cubeforge preview`: every model against the source texts' formulas evaluated here,
//! independently, in double precision, for 1-sample renders of analytic environments; total
//! internal reflection, the Fresnel clamp, per-vertex converging to per-fragment, both
//! parallax modes, LOD bias, control maps, orientation, determinism and the command line.

use crate::common;

use cubeforge::cube::{CubeMap, CubeSampler};
use cubeforge::image::Image;
use cubeforge::io::{self, ReadOptions, WriteOptions};
use cubeforge::layout::sphere as sphere_map;
use cubeforge::preview::camera::sample_offsets;
use cubeforge::preview::material::{self, Material, Model};
use cubeforge::preview::{
    self, Background, Control, Options, Parallax, ParallaxMode, Shading, Surface,
};
use cubeforge::resample::FnEnv;
use cubeforge::synthetic;
use glam::{DVec3, Vec3, Vec4};
use std::path::Path;

// ---------------------------------------------------------------------------------------
// The geometry and the texts' formulas, written out again here (f64).

/// Camera of the issue: at (0, 0, D) looking at the origin, up +Y, image right -X (the
/// cube map's face images read correctly from inside), vertical fov; ray through the centre
/// of pixel (x, y) of an n x n image. Returns (eye, direction).
fn pixel_ray(x: usize, y: usize, n: usize, fov_deg: f64, d: f64) -> (DVec3, DVec3) {
    let th = (fov_deg.to_radians() / 2.0).tan();
    let sx = (2.0 * (x as f64 + 0.5) / n as f64 - 1.0) * th;
    let sy = (1.0 - 2.0 * (y as f64 + 0.5) / n as f64) * th;
    let eye = DVec3::new(0.0, 0.0, d);
    (eye, DVec3::new(-sx, sy, -1.0))
}

/// Nearest hit of a ray with the unit sphere.
fn hit_sphere(eye: DVec3, dir: DVec3) -> Option<DVec3> {
    let a = dir.dot(dir);
    let b = eye.dot(dir);
    let c = eye.dot(eye) - 1.0;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return None;
    }
    let t = (-b - disc.sqrt()) / a;
    (t > 0.0).then(|| eye + dir * t)
}

fn reflect(i: DVec3, n: DVec3) -> DVec3 {
    i - 2.0 * n * n.dot(i)
}

/// The texts' reference refract (section 7.3.2).
fn refract(i: DVec3, n: DVec3, eta: f64) -> DVec3 {
    let cos_i = (-i).dot(n);
    let cos_t2 = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    let t = eta * i + (eta * cos_i - cos_t2.abs().sqrt()) * n;
    if cos_t2 > 0.0 {
        t
    } else {
        DVec3::ZERO
    }
}

fn fresnel_unclamped(i: DVec3, n: DVec3, bias: f64, scale: f64, power: f64) -> f64 {
    bias + scale * (1.0 + i.dot(n)).max(0.0).powf(power)
}

/// texCUBE of the analytic environment; the zero vector transmits nothing.
fn env(v: DVec3) -> DVec3 {
    if v == DVec3::ZERO {
        return DVec3::ZERO;
    }
    synthetic::smooth(v.normalize().as_vec3())
        .truncate()
        .as_dvec3()
}

fn lerp(a: DVec3, b: DVec3, t: f64) -> DVec3 {
    a + (b - a) * t
}

/// The expected colour of pixel (x, y) per the texts' programs, or None off the sphere.
fn expected(m: &Material, x: usize, y: usize, n: usize) -> Option<DVec3> {
    let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
    let p = hit_sphere(eye, dir)?;
    let nrm = p.normalize();
    let i = p - eye;
    let decal = m.decal_color.as_dvec3();
    let eta = m.eta_ratio.as_dvec3();
    Some(match m.model {
        Model::Reflect => lerp(decal, env(reflect(i, nrm)), m.reflectivity as f64),
        Model::Refract => lerp(
            decal,
            env(refract(i.normalize(), nrm, eta.x)),
            m.transmittance as f64,
        ),
        Model::Dispersion => {
            let iu = i.normalize();
            let refl = env(reflect(i, nrm));
            let refr = DVec3::new(
                env(refract(iu, nrm, eta.x)).x,
                env(refract(iu, nrm, eta.y)).y,
                env(refract(iu, nrm, eta.z)).z,
            );
            let f = fresnel_unclamped(
                iu,
                nrm,
                m.fresnel_bias as f64,
                m.fresnel_scale as f64,
                m.fresnel_power as f64,
            )
            .clamp(0.0, 1.0);
            lerp(refr, refl, f)
        }
        Model::Pbr => unreachable!("pbr is checked in preview_pbr.rs"),
    })
}

fn smooth_env() -> FnEnv<fn(Vec3) -> Vec4> {
    FnEnv(synthetic::smooth as fn(Vec3) -> Vec4)
}

fn opts(n: usize) -> Options {
    Options {
        size: n,
        samples: 1,
        ..Options::default()
    }
}

fn render(m: &Material, o: &Options) -> Image {
    preview::render(&smooth_env(), m, &Surface::default(), o).unwrap()
}

fn rgb(p: Vec4) -> DVec3 {
    p.truncate().as_dvec3()
}

/// Largest difference between a render and the formulas over the sphere's pixels (and the
/// number of pixels compared); background pixels must show the environment along the ray.
fn max_error_vs_formula(m: &Material, img: &Image) -> (f64, usize) {
    let n = img.width;
    let (mut worst, mut count) = (0.0f64, 0);
    for y in 0..n {
        for x in 0..n {
            let got = rgb(img.get(x, y));
            match expected(m, x, y, n) {
                Some(want) => {
                    worst = worst.max((got - want).abs().max_element());
                    count += 1;
                }
                None => {
                    let (_, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                    let want = env(dir);
                    assert!(
                        (got - want).abs().max_element() < 1e-4,
                        "background at ({x}, {y}): {got} != {want}"
                    );
                }
            }
        }
    }
    (worst, count)
}

// ---------------------------------------------------------------------------------------
// The models, per pixel.

#[test]
fn reflection_matches_c7e1v_c7e2f_per_pixel() {
    for m in [
        material::preset("chrome").unwrap(),
        Material {
            reflectivity: 0.7,
            decal_color: Vec3::new(0.9, 0.2, 0.1),
            ..material::preset("mirror-decal").unwrap()
        },
    ] {
        let img = render(&m, &opts(96));
        let (err, count) = max_error_vs_formula(&m, &img);
        println!("{}: max error {err:.2e} over {count} sphere pixels", m.name);
        assert!(count > 4000, "the sphere covers most of the image");
        assert!(err < 2e-5, "{}: max error {err}", m.name);
    }
}

#[test]
fn refraction_matches_c7e3v_c7e4f_per_pixel() {
    for name in ["glass", "water", "diamond", "plastic"] {
        let m = material::preset(name).unwrap();
        let img = render(&m, &opts(96));
        let (err, _) = max_error_vs_formula(&m, &img);
        println!("{name}: max error {err:.2e}");
        assert!(err < 2e-5, "{name}: max error {err}");
    }
    // The texts' refract obeys Snell's law: sin(theta_t) = eta sin(theta_i), T in the plane.
    let n = DVec3::new(0.3, 0.8, 0.52).normalize();
    let i = DVec3::new(0.1, -0.9, -0.3).normalize();
    let eta = 1.0 / 1.5;
    let t = material::refract(i.as_vec3(), n.as_vec3(), eta as f32).as_dvec3();
    let sin_i = i.cross(n).length();
    let sin_t = t.normalize().cross(n).length();
    assert!((sin_t - eta * sin_i).abs() < 1e-6);
    assert!(
        t.dot(i.cross(n)).abs() < 1e-6,
        "T lies in the plane of I and N"
    );
    assert!(t.dot(n) < 0.0, "T goes into the surface");
}

#[test]
fn dispersion_matches_c7e5v_c7e6f_per_pixel() {
    let m = material::preset("crystal").unwrap();
    let img = render(&m, &opts(96));
    let (err, _) = max_error_vs_formula(&m, &img);
    println!("crystal: max error {err:.2e}");
    assert!(err < 2e-5, "max error {err}");
    // The rainbow: the channels are refracted differently, so a grey environment's edges
    // would fringe; here the refracted colour differs from one refracted with green's ratio.
    let (eye, dir) = pixel_ray(30, 48, 96, 30.0, 4.0);
    let p = hit_sphere(eye, dir).unwrap();
    let iu = (p - eye).normalize();
    let tr = refract(iu, p, m.eta_ratio.x as f64);
    let tb = refract(iu, p, m.eta_ratio.z as f64);
    assert!(tr.normalize().angle_between(tb.normalize()) > 0.01);
}

#[test]
fn total_internal_reflection_transmits_nothing() {
    // From a dense medium into a light one (eta_ratio 1.5): beyond the critical angle
    // (sin theta_i > 1 / 1.5) the texts' refract returns the zero vector.
    assert_eq!(
        material::refract(Vec3::new(0.9, 0.0, -0.436).normalize(), Vec3::Z, 1.5),
        Vec3::ZERO
    );
    let m = Material {
        name: "bubble".into(),
        model: Model::Refract,
        eta_ratio: Vec3::splat(1.5),
        transmittance: 1.0,
        ..Material::default()
    };
    let n = 96;
    let img = render(&m, &opts(n));
    let (err, _) = max_error_vs_formula(&m, &img);
    assert!(err < 2e-5, "max error {err}");
    let (mut tir, mut through) = (0, 0);
    for y in 0..n {
        for x in 0..n {
            let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
            let Some(p) = hit_sphere(eye, dir) else {
                continue;
            };
            let cos_i = -(p - eye).normalize().dot(p);
            let sin_i = (1.0 - cos_i * cos_i).sqrt();
            let got = rgb(img.get(x, y));
            if sin_i > 1.0 / 1.5 + 1e-3 {
                assert_eq!(got, DVec3::ZERO, "TIR at ({x}, {y}) must be black");
                tir += 1;
            } else if sin_i < 1.0 / 1.5 - 1e-3 {
                assert!(got.max_element() > 0.05, "light passes at ({x}, {y})");
                through += 1;
            }
        }
    }
    println!("{tir} pixels in total internal reflection, {through} transmitting");
    assert!(tir > 500 && through > 500);
}

#[test]
fn fresnel_factor_is_clamped_to_0_1() {
    // Bias + scale (1 + I.N)^power runs past 1 towards the rim and below 0 at the centre.
    let over = Material {
        fresnel_bias: 0.5,
        fresnel_scale: 3.0,
        fresnel_power: 1.0,
        ..material::preset("crystal").unwrap()
    };
    let under = Material {
        fresnel_bias: -0.5,
        fresnel_scale: 1.0,
        fresnel_power: 1.0,
        ..over.clone()
    };
    assert_eq!(material::fresnel(Vec3::NEG_Z, Vec3::Z, -0.5, 1.0, 1.0), 0.0);
    assert_eq!(
        material::fresnel(Vec3::new(0.0, -0.6, -0.8), Vec3::Y, 0.5, 3.0, 1.0),
        1.0
    );
    let n = 96;
    for m in [&over, &under] {
        let img = render(m, &opts(n));
        let (err, _) = max_error_vs_formula(m, &img);
        assert!(err < 2e-5, "max error {err}");
        // Where the unclamped factor leaves [0, 1], the colour is exactly the reflected
        // (factor 1) or the refracted colour (factor 0), not an extrapolation.
        let mut clamped = 0;
        for y in (0..n).step_by(3) {
            for x in (0..n).step_by(3) {
                let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                let Some(p) = hit_sphere(eye, dir) else {
                    continue;
                };
                let i = p - eye;
                let iu = i.normalize();
                let f = fresnel_unclamped(
                    iu,
                    p,
                    m.fresnel_bias as f64,
                    m.fresnel_scale as f64,
                    m.fresnel_power as f64,
                );
                let refl = env(reflect(i, p));
                let eta = m.eta_ratio.as_dvec3();
                let refr = DVec3::new(
                    env(refract(iu, p, eta.x)).x,
                    env(refract(iu, p, eta.y)).y,
                    env(refract(iu, p, eta.z)).z,
                );
                let got = rgb(img.get(x, y));
                if f > 1.05 {
                    assert!((got - refl).abs().max_element() < 2e-5);
                    assert!((got - lerp(refr, refl, f)).abs().max_element() > 1e-3);
                    clamped += 1;
                } else if f < -0.05 {
                    assert!((got - refr).abs().max_element() < 2e-5);
                    assert!((got - lerp(refr, refl, f)).abs().max_element() > 1e-3);
                    clamped += 1;
                }
            }
        }
        assert!(clamped > 20, "{clamped} clamped pixels");
    }
}

// ---------------------------------------------------------------------------------------
// Per-vertex shading (section 7.2.5).

/// Mean absolute difference of two renders over the pixels both show the sphere on
/// (alpha 1 with a transparent background), split into the inner disc and the rim.
fn vertex_vs_fragment(a: &Image, b: &Image) -> (f64, f64) {
    let n = a.width;
    let (mut inner, mut ni, mut rim, mut nr) = (0.0, 0, 0.0, 0);
    for y in 0..n {
        for x in 0..n {
            let (pa, pb) = (a.get(x, y), b.get(x, y));
            if pa.w < 1.0 || pb.w < 1.0 {
                continue;
            }
            let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
            let Some(p) = hit_sphere(eye, dir) else {
                continue;
            };
            let facing = -(p - eye).normalize().dot(p);
            let d = (rgb(pa) - rgb(pb)).abs().element_sum() / 3.0;
            if facing > 0.5 {
                inner += d;
                ni += 1;
            } else {
                rim += d;
                nr += 1;
            }
        }
    }
    (inner / ni as f64, rim / nr.max(1) as f64)
}

#[test]
fn per_vertex_converges_to_per_fragment() {
    let env = FnEnv(synthetic::demo_sky);
    let base = Options {
        size: 128,
        samples: 1,
        background: Background::Color(Vec4::ZERO),
        ..Options::default()
    };
    for name in ["chrome", "crystal"] {
        let m = material::preset(name).unwrap();
        let exact = preview::render(&env, &m, &Surface::default(), &base).unwrap();
        let mut last = f64::INFINITY;
        for t in [4, 8, 16, 32, 64] {
            let o = Options {
                shading: Shading::PerVertex,
                tessellation: t,
                ..base
            };
            let img = preview::render(&env, &m, &Surface::default(), &o).unwrap();
            let (inner, rim) = vertex_vs_fragment(&img, &exact);
            let err = (inner + rim) / 2.0;
            println!("{name} tessellation {t:>2}: mean error inner {inner:.5}, near the silhouette {rim:.5}");
            assert!(err < last, "error must fall as the tessellation grows");
            if t >= 8 {
                assert!(rim > inner, "the artefacts concentrate near the silhouette");
            }
            last = err;
        }
        assert!(
            last < 0.01,
            "{name}: fine tessellation nearly matches per-fragment"
        );
    }
}

#[test]
fn per_vertex_interpolates_the_vertex_outputs_perspective_correctly() {
    // A mesh vertex pixel shows exactly the vertex program's output there, and every
    // pixel's colour is the environment along a vector inside the triangle's cone of vertex
    // vectors. Simplest exact check: the vertex at the sphere's front (+Z, u = 0.5) is on
    // the mesh for an even number of longitude segments and reflects straight back.
    let m = material::preset("chrome").unwrap();
    let env = FnEnv(synthetic::smooth);
    let o = Options {
        size: 65,
        samples: 1,
        shading: Shading::PerVertex,
        tessellation: 8,
        ..Options::default()
    };
    let img = preview::render(&env, &m, &Surface::default(), &o).unwrap();
    // Pixel (32, 32) of a 65-pixel image looks exactly at the origin: hits (0, 0, 1), a mesh
    // vertex (theta = 90 degrees, phi = 0) whose reflected vector is +Z.
    let want = synthetic::smooth(Vec3::Z);
    assert!((img.get(32, 32) - want).abs().max_element() < 1e-5);
}

// ---------------------------------------------------------------------------------------
// Brennan's correction.

#[test]
fn parallax_modes_match_brennan_and_differ_as_expected() {
    let m = material::preset("chrome").unwrap();
    let n = 64;
    let center = Vec3::new(0.4, -0.2, 0.3);
    let radius = 3.0;
    let mut renders = Vec::new();
    for mode in [ParallaxMode::Approx, ParallaxMode::Exact] {
        let o = Options {
            parallax: Some(Parallax {
                radius,
                center,
                mode,
            }),
            ..opts(n)
        };
        let img = render(&m, &o);
        let c = center.as_dvec3();
        let r = radius as f64;
        let mut worst = 0.0f64;
        for y in 0..n {
            for x in 0..n {
                let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                let Some(p) = hit_sphere(eye, dir) else {
                    continue;
                };
                let v = reflect(p - eye, p).normalize();
                let look = match mode {
                    // Seed 002: R'' = R + CP / Radius, R of unit length.
                    ParallaxMode::Approx => v + (p - c) / r,
                    // The ray P + tV meets the sphere |X - C| = Radius at t > 0: look up X - C.
                    ParallaxMode::Exact => {
                        let cp = p - c;
                        let b = cp.dot(v);
                        let t = -b + (b * b - cp.dot(cp) + r * r).sqrt();
                        cp + v * t
                    }
                };
                let got = rgb(img.get(x, y));
                worst = worst.max((got - env(look)).abs().max_element());
            }
        }
        println!("{mode:?}: max error {worst:.2e}");
        assert!(worst < 5e-5, "{mode:?}: max error {worst}");
        renders.push(img);
    }
    let infinite = render(&m, &opts(n));
    let diff = |a: &Image, b: &Image| {
        a.pixels
            .iter()
            .zip(&b.pixels)
            .map(|(p, q)| (*p - *q).abs().max_element())
            .fold(0.0f32, f32::max)
    };
    let (approx_exact, approx_inf, exact_inf) = (
        diff(&renders[0], &renders[1]),
        diff(&renders[0], &infinite),
        diff(&renders[1], &infinite),
    );
    println!("max differences: approx-exact {approx_exact:.4}, approx-infinite {approx_inf:.4}, exact-infinite {exact_inf:.4}");
    // Both corrections move the lookups a lot more than they differ from each other.
    assert!(approx_inf > 0.05 && exact_inf > 0.05);
    assert!(approx_exact > 1e-3 && approx_exact < approx_inf.min(exact_inf));
    // Far away the environment is at infinity again: both converge to the plain lookup.
    let mut prev = (f32::INFINITY, f32::INFINITY);
    for radius in [4.0, 40.0, 400.0] {
        let d: Vec<f32> = [ParallaxMode::Approx, ParallaxMode::Exact]
            .iter()
            .map(|&mode| {
                let o = Options {
                    parallax: Some(Parallax {
                        radius,
                        center,
                        mode,
                    }),
                    ..opts(n)
                };
                diff(&render(&m, &o), &infinite)
            })
            .collect();
        assert!(d[0] < prev.0 && d[1] < prev.1);
        prev = (d[0], d[1]);
    }
    assert!(prev.0 < 0.01 && prev.1 < 0.01);
}

// ---------------------------------------------------------------------------------------
// Level of detail.

/// A chain whose level k is the constant k: a render then shows the level of detail itself.
fn level_chain(size: usize) -> CubeSampler {
    let count = CubeMap::full_chain_len(size);
    let levels = (0..count)
        .map(|k| {
            let n = (size >> k).max(1);
            std::array::from_fn(|_| {
                Image::filled(n, n, Vec4::new(k as f32, k as f32, k as f32, 1.0))
            })
        })
        .collect();
    CubeSampler::new(&CubeMap { levels })
}

/// The GPU's level for a chrome pixel from the reflected vectors at it and at the pixels to
/// its right and below (true neighbours, not extrapolated): projected on R's face, in
/// texels of a face of edge `size`.
fn expected_lod(x: usize, y: usize, n: usize, size: usize) -> Option<f64> {
    let r = |x: usize, y: usize| {
        let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
        hit_sphere(eye, dir).map(|p| (reflect(p - eye, p), -(p - eye).normalize().dot(p)))
    };
    let (v, facing) = r(x, y)?;
    let (vx, _) = r(x + 1, y)?;
    let (vy, _) = r(x, y + 1)?;
    if facing < 0.5 {
        return None;
    }
    let a = v.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let proj = |q: DVec3| {
        let m = q[axis] * v[axis].signum();
        let o: Vec<f64> = (0..3).filter(|&k| k != axis).map(|k| q[k] / m).collect();
        glam::DVec2::new(o[0], o[1])
    };
    let p = proj(v);
    let rho = (proj(vx) - p).length().max((proj(vy) - p).length()) * size as f64 / 2.0;
    Some(rho.log2())
}

#[test]
fn lod_follows_the_reflected_footprint_plus_bias() {
    let size = 64;
    let chain = level_chain(size);
    let max = (CubeMap::full_chain_len(size) - 1) as f64;
    let m = material::preset("chrome").unwrap();
    let n = 64;
    let mut checked = 0;
    let mut worst = 0.0f64;
    for bias in [0.0, 1.0, 2.5] {
        let o = Options {
            lod_bias: bias,
            ..opts(n)
        };
        let img = preview::render(&chain, &m, &Surface::default(), &o).unwrap();
        for y in 0..n - 1 {
            for x in 0..n - 1 {
                let Some(lod) = expected_lod(x, y, n, size) else {
                    continue;
                };
                let want = (lod + bias as f64).clamp(0.0, max);
                let got = img.get(x, y).x as f64;
                worst = worst.max((got - want).abs());
                checked += 1;
            }
        }
    }
    println!("level of detail: max error {worst:.3} levels over {checked} pixels");
    assert!(checked > 3000);
    assert!(worst < 0.1, "max error {worst} levels");
}

#[test]
fn lod_bias_selects_blurrier_levels() {
    // A checkerboard environment with plain box mipmaps: each unit of bias halves the detail.
    let checker = |d: Vec3| {
        let a = d.normalize();
        let u = (a.x.atan2(a.z) * 8.0).sin() * (a.y.asin() * 8.0).sin();
        let v = if u > 0.0 { 1.0 } else { 0.0 };
        Vec4::new(v, v, v, 1.0)
    };
    let chain = CubeSampler::new(&CubeMap::from_fn(128, checker).with_box_mips(None));
    let single = CubeSampler::new(&CubeMap::from_fn(128, checker));
    let m = material::preset("chrome").unwrap();
    let n = 64;
    let contrast = |img: &Image| {
        // Mean absolute difference between horizontal neighbours on the sphere.
        let mut s = 0.0;
        let mut c = 0;
        for y in 0..n {
            for x in 0..n - 1 {
                let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                let (_, dir2) = pixel_ray(x + 1, y, n, 30.0, 4.0);
                if hit_sphere(eye, dir).is_some() && hit_sphere(eye, dir2).is_some() {
                    s += (img.get(x, y).x - img.get(x + 1, y).x).abs() as f64;
                    c += 1;
                }
            }
        }
        s / c as f64
    };
    let mut prev = f64::INFINITY;
    for bias in [0.0, 1.0, 2.0, 3.0, 4.0] {
        let o = Options {
            lod_bias: bias,
            ..opts(n)
        };
        let img = preview::render(&chain, &m, &Surface::default(), &o).unwrap();
        let c = contrast(&img);
        println!("bias {bias}: neighbour contrast {c:.4}");
        assert!(c < prev * 0.9, "bias {bias} must blur more");
        prev = c;
        // A single level has nothing to blur with: the bias changes nothing.
        let flat = preview::render(&single, &m, &Surface::default(), &o).unwrap();
        let flat0 = preview::render(&single, &m, &Surface::default(), &opts(n)).unwrap();
        assert_eq!(flat, flat0);
    }
}

// ---------------------------------------------------------------------------------------
// Control maps (section 7.2.4).

#[test]
fn control_map_changes_reflectivity_where_it_says() {
    // R = 1 (mirror) for u < 0.5, R = 0 (decal only) for u >= 0.5; G = 1, B = 0, A = 1. The
    // default camera sees u = 0.25 to 0.75, the split (u = 0.5, +Z) down its middle.
    let (w, h) = (64, 32);
    let map = Image::from_fn(w, h, |x, _| {
        let r = if x < w / 2 { 1.0 } else { 0.0 };
        Vec4::new(r, 1.0, 0.0, 1.0)
    });
    let m = Material {
        decal_color: Vec3::new(1.0, 0.0, 0.0),
        reflectivity: 0.5,
        ..material::preset("chrome").unwrap()
    };
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &map,
            max_lod_bias: 4.0,
        }),
    };
    let n = 96;
    let img = preview::render(&smooth_env(), &m, &surface, &opts(n)).unwrap();
    let (mut mirror, mut decal) = (0, 0);
    for y in 0..n {
        for x in 0..n {
            let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
            let Some(p) = hit_sphere(eye, dir) else {
                continue;
            };
            // The equirect layout's u (around +Y, +Z at 0.5, +X at 0.75); v from the north pole.
            let u = 0.5 + p.x.atan2(p.z) / std::f64::consts::TAU;
            let v = p.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
            if !(0.1..0.9).contains(&v) {
                continue;
            }
            let got = rgb(img.get(x, y));
            let refl = env(reflect(p - eye, p.normalize()));
            if (0.26..0.49).contains(&u) {
                assert!(
                    (got - refl).abs().max_element() < 2e-5,
                    "mirror at ({x}, {y})"
                );
                mirror += 1;
            } else if (0.51..0.74).contains(&u) {
                assert!(
                    (got - DVec3::new(1.0, 0.0, 0.0)).abs().max_element() < 2e-5,
                    "decal at ({x}, {y})"
                );
                decal += 1;
            }
        }
    }
    println!("{mirror} mirror pixels, {decal} decal pixels");
    assert!(mirror > 500 && decal > 500);
    // The camera looks at -Z from +Z: image left is +X (u = 0.75), image right -X (u = 0.25).
    assert!(rgb(img.get(20, 48)).distance(DVec3::new(1.0, 0.0, 0.0)) < 1e-4);
    assert!(rgb(img.get(76, 48)).distance(DVec3::new(1.0, 0.0, 0.0)) > 0.1);
}

/// A decal painted as a panorama wraps the sphere as that panorama wraps the environment: the
/// sphere's (u, v) are the equirect layout's, so each point shows the decal's texel of its own
/// direction, the seam (at the back, -Z) included. Measured on a 256 x 128 panorama of the
/// smooth environment, decal only: largest error 6.0e-5 from the front and from the back
/// (bilinear between texels; the u of before, half a turn off, errs by 0.5). Bound: 5e-4.
#[test]
fn a_panorama_decal_wraps_like_the_environment() {
    let (w, h) = (256, 128);
    let pano = Image::from_fn(w, h, |x, y| {
        let u = (x as f32 + 0.5) / w as f32;
        let v = (y as f32 + 0.5) / h as f32;
        synthetic::smooth(cubeforge::layout::equirect::uv_to_dir(u, v))
    });
    let m = Material {
        reflectivity: 0.0,
        ..material::preset("mirror-decal").unwrap()
    };
    let surface = Surface {
        decal: Some(&pano),
        control: None,
    };
    let n = 96;
    for yaw in [0.0f32, 180.0] {
        let o = Options { yaw, ..opts(n) };
        let img = preview::render(&smooth_env(), &m, &surface, &o).unwrap();
        let (mut worst, mut count) = (0.0f64, 0);
        for y in 0..n {
            for x in 0..n {
                let (eye, dir) = pixel_ray(x, y, n, 30.0, 4.0);
                let Some(p) = hit_sphere(eye, dir) else {
                    continue;
                };
                // The orbit turns the hit point with the camera.
                let p = if yaw == 0.0 {
                    p
                } else {
                    DVec3::new(-p.x, p.y, -p.z)
                };
                let want = synthetic::smooth(p.normalize().as_vec3());
                worst = worst.max((rgb(img.get(x, y)) - rgb(want)).abs().max_element());
                count += 1;
            }
        }
        println!("yaw {yaw}: largest error {worst:.2e} over {count} pixels");
        assert!(count > 3000 && worst < 5e-4, "yaw {yaw}: {worst}");
    }
}

#[test]
fn control_map_transmittance_blur_and_mask() {
    let n = 48;
    // G = 0: glass shows only its decal.
    let map = Image::filled(8, 8, Vec4::new(0.0, 0.0, 0.0, 1.0));
    let glass = Material {
        decal_color: Vec3::new(0.0, 0.0, 1.0),
        ..material::preset("glass").unwrap()
    };
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &map,
            max_lod_bias: 4.0,
        }),
    };
    let img = preview::render(&smooth_env(), &glass, &surface, &opts(n)).unwrap();
    assert_eq!(img.get(n / 2, n / 2), Vec4::new(0.0, 0.0, 1.0, 1.0));
    // A = 0: the Fresnel term does not apply; the reflectivity R (here 1) does.
    let crystal = material::preset("crystal").unwrap();
    let mirror = Image::filled(8, 8, Vec4::new(1.0, 0.0, 0.0, 0.0));
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &mirror,
            max_lod_bias: 4.0,
        }),
    };
    let img = preview::render(&smooth_env(), &crystal, &surface, &opts(n)).unwrap();
    let chrome = render(&material::preset("chrome").unwrap(), &opts(n));
    assert!(img
        .pixels
        .iter()
        .zip(&chrome.pixels)
        .all(|(a, b)| (*a - *b).abs().max_element() < 1e-5));
    // B: blur 0.5 of max_lod_bias 4 adds 2 levels, like --lod-bias 2.
    let chain = level_chain(64);
    let blur = Image::filled(8, 8, Vec4::new(1.0, 1.0, 0.5, 1.0));
    let surface = Surface {
        decal: None,
        control: Some(Control {
            map: &blur,
            max_lod_bias: 4.0,
        }),
    };
    let chrome = material::preset("chrome").unwrap();
    let a = preview::render(&chain, &chrome, &surface, &opts(n)).unwrap();
    let b = preview::render(
        &chain,
        &chrome,
        &Surface::default(),
        &Options {
            lod_bias: 2.0,
            ..opts(n)
        },
    )
    .unwrap();
    assert_eq!(a, b);
}

#[test]
fn control_map_sidecar_gives_max_lod_bias() {
    let dir = tempfile::tempdir().unwrap();
    let map = dir.path().join("mask.png");
    let img = Image::filled(4, 2, Vec4::new(0.5, 0.25, 1.0, 1.0));
    std::fs::write(
        &map,
        io::encode_image(
            &map,
            &img,
            &WriteOptions {
                linear: true,
                ..WriteOptions::default()
            },
        )
        .unwrap(),
    )
    .unwrap();
    let (read, max, side) = preview::read_control(&map, 4.0, &Default::default()).unwrap();
    assert_eq!(max, 4.0);
    assert!(side.is_none());
    // Linear data: 0.5 stays 0.5 (no sRGB decode), to 8-bit precision.
    assert!((read.get(0, 0).x - 0.5).abs() < 0.003);
    std::fs::write(dir.path().join("mask.png.json"), r#"{"max_lod_bias": 6.5}"#).unwrap();
    let (_, max, side) = preview::read_control(&map, 4.0, &Default::default()).unwrap();
    assert_eq!(max, 6.5);
    assert!(side.is_some());
    std::fs::write(dir.path().join("mask.png.json"), "{oops").unwrap();
    let e = preview::read_control(&map, 4.0, &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("mask.png.json") && !e.contains('\n'), "{e}");
}

// ---------------------------------------------------------------------------------------
// Orientation, sampling, determinism.

#[test]
fn chrome_ball_matches_the_sphere_map_layout() {
    // From far along -Z (yaw 180), a chrome ball is the project's sphere map (camera facing
    // +Z, image right +X, up +Y; the centre shows -Z): the same directions at the same
    // places, so the preview's orientation agrees with `convert --to sphere`.
    let n = 64;
    let d = 1000.0f32;
    let fov = 2.0 * (1.0 / ((d * d - 1.0) as f64).sqrt()).atan().to_degrees() as f32;
    let o = Options {
        size: n,
        samples: 1,
        distance: d,
        fov,
        yaw: 180.0,
        background: Background::Color(Vec4::ZERO),
        ..Options::default()
    };
    let img = render(&material::preset("chrome").unwrap(), &o);
    let mut compared = 0;
    let mut worst = 0.0f32;
    for y in 0..n {
        for x in 0..n {
            let s = (x as f32 + 0.5) / n as f32;
            let t = 1.0 - (y as f32 + 0.5) / n as f32;
            let (cx, cy) = (2.0 * s - 1.0, 2.0 * t - 1.0);
            if cx * cx + cy * cy > 0.85 {
                continue;
            }
            let dir = sphere_map::st_to_dir(s, t).unwrap();
            let want = synthetic::smooth(dir.normalize());
            worst = worst.max((img.get(x, y) - want).abs().max_element());
            compared += 1;
        }
    }
    println!("chrome ball vs sphere map: max difference {worst:.2e} over {compared} pixels");
    assert!(compared > 2000);
    assert!(worst < 5e-3, "max difference {worst}");
}

#[test]
fn reflection_and_background_are_oriented_like_the_texts() {
    // Default camera: +Y at the top of the ball's reflection, the background straight ahead
    // is -Z, and image right is -X.
    let n = 64;
    let img = render(&material::preset("chrome").unwrap(), &opts(n));
    let top = img.get(n / 2, 4); // near the top of the ball: reflects upwards
    assert!(
        top.y > 0.8,
        "the top of the ball reflects +Y (green high): {top}"
    );
    let corner = img.get(n - 1, n / 2);
    let (_, dir) = pixel_ray(n - 1, n / 2, n, 30.0, 4.0);
    assert!(dir.x < 0.0);
    assert!((rgb(corner) - env(dir)).abs().max_element() < 1e-5);
    assert!(corner.x < 0.5, "image right looks towards -X (red low)");
}

#[test]
fn samples_are_stratified_and_one_is_the_centre() {
    assert_eq!(sample_offsets(1), vec![(0.5, 0.5)]);
    for s in [2, 3, 4, 5, 8, 16] {
        let o = sample_offsets(s);
        assert_eq!(o.len(), s);
        let mut cols: Vec<usize> = o.iter().map(|p| (p.0 * s as f32) as usize).collect();
        let mut rows: Vec<usize> = o.iter().map(|p| (p.1 * s as f32) as usize).collect();
        cols.sort();
        rows.sort();
        let all: Vec<usize> = (0..s).collect();
        assert_eq!(cols, all, "one sample per column for {s}");
        assert_eq!(rows, all, "one sample per row for {s}");
        assert_eq!(sample_offsets(s), o, "deterministic");
    }
}

#[test]
fn output_does_not_depend_on_thread_count() {
    let env = CubeSampler::new(&CubeMap::from_fn(32, synthetic::demo_sky).with_box_mips(None));
    let m = material::preset("crystal").unwrap();
    for shading in [Shading::PerFragment, Shading::PerVertex] {
        let o = Options {
            size: 48,
            samples: 4,
            shading,
            lod_bias: 0.5,
            ..Options::default()
        };
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| preview::render(&env, &m, &Surface::default(), &o).unwrap())
        };
        assert_eq!(run(1), run(3));
    }
}

// ---------------------------------------------------------------------------------------
// Materials, inputs and the command line.

#[test]
fn material_files_parse_and_errors_name_the_file_and_line() {
    let p = Path::new("mats/gem.toml");
    let m = material::parse_toml(
        "model = \"dispersion\"\neta_ratio = [0.65, 0.67, 0.69]\nfresnel_bias = 0.1\nfresnel_scale = 1.0\nfresnel_power = 5\n",
        p,
    )
    .unwrap();
    assert_eq!(m.model, Model::Dispersion);
    assert_eq!(m.eta_ratio, Vec3::new(0.65, 0.67, 0.69));
    assert_eq!(m.name, "gem");
    let m = material::parse_toml(
        "model = \"refract\"\neta_ratio = 0.75\ndecal = \"wood.png\"\n",
        p,
    )
    .unwrap();
    assert_eq!(m.eta_ratio, Vec3::splat(0.75));
    assert_eq!(m.decal.as_deref(), Some(Path::new("mats/wood.png")));
    // Every preset round-trips through the TOML it is listed as.
    for (preset, _) in material::presets() {
        let back = material::parse_toml(&material::to_toml(&preset), Path::new("x.toml")).unwrap();
        assert_eq!(back.model, preset.model);
        assert!((back.eta_ratio - preset.eta_ratio).abs().max_element() < 1e-4);
    }
    for (text, needle) in [
        ("model = \"reflect\"\nreflectivty = 0.5\n", "line 2"),
        ("model = \"glossy\"\n", "line 1"),
        ("model = \"refract\"\n", "needs eta_ratio"),
        (
            "model = \"reflect\"\nreflectivity = 1.5\n",
            "between 0 and 1",
        ),
        (
            "model = \"refract\"\neta_ratio = [0.6, 0.7, 0.8]\n",
            "dispersion",
        ),
        ("model = \"refract\"\neta_ratio = -1\n", "positive"),
        ("model = [\n", "line"),
    ] {
        let e = material::parse_toml(text, p).unwrap_err().to_string();
        assert!(e.starts_with("mats/gem.toml: "), "{e}");
        assert!(e.contains(needle), "{e} should say {needle}");
        assert!(!e.contains('\n'), "one line: {e}");
    }
    let e = material::resolve("velvet").unwrap_err().to_string();
    assert!(
        e.contains("unknown material") && e.contains("chrome"),
        "{e}"
    );
    let e = material::resolve("/nonexistent/m.toml")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("/nonexistent/m.toml: "), "{e}");
}

#[test]
fn presets_follow_table_7_2() {
    let eta = |n: &str| material::preset(n).unwrap().eta_ratio.x;
    assert!((eta("glass") - 1.0 / 1.5).abs() < 1e-6);
    assert!((eta("water") - 1.0 / 1.3333).abs() < 1e-6);
    assert!((eta("diamond") - 1.0 / 2.417).abs() < 1e-6);
    assert!((eta("plastic") - 1.0 / 1.5).abs() < 1e-6);
    let crystal = material::preset("crystal").unwrap();
    assert_eq!(crystal.model, Model::Dispersion);
    assert!(
        crystal.eta_ratio.x != crystal.eta_ratio.z,
        "a rainbow needs spread"
    );
    let names: Vec<String> = material::presets()
        .into_iter()
        .map(|(m, _)| m.name)
        .collect();
    assert_eq!(
        names,
        [
            "chrome",
            "mirror-decal",
            "glass",
            "water",
            "diamond",
            "plastic",
            "crystal",
            "pbr",
            "gold",
            "copper",
            "plastic-glossy",
            "plastic-rough"
        ]
    );
}

#[test]
fn prefilter_folder_chains_load_level_by_level() {
    let dir = tempfile::tempdir().unwrap();
    let sizes = [8usize, 4, 2, 1];
    for (k, n) in sizes.iter().enumerate() {
        let sub = dir.path().join(format!("m{k}"));
        std::fs::create_dir_all(&sub).unwrap();
        for f in cubeforge::cube::FACE_NAMES {
            let p = sub.join(format!("{f}.exr"));
            let img = Image::filled(*n, *n, Vec4::new(k as f32, 0.0, 0.0, 1.0));
            std::fs::write(
                &p,
                io::encode_image(&p, &img, &WriteOptions::default()).unwrap(),
            )
            .unwrap();
        }
    }
    std::fs::write(
        dir.path().join("levels.json"),
        r#"{"levels": [{"size": 8}, {"size": 4}, {"size": 2}, {"size": 1}]}"#,
    )
    .unwrap();
    let env = preview::load_environment(dir.path(), None, &ReadOptions::default()).unwrap();
    assert_eq!(env.levels(), 4);
    use cubeforge::cube::Environment;
    assert_eq!(env.sampler.lookup(Vec3::X, 2.0).x, 2.0);
    assert_eq!(env.sampler.lookup(Vec3::X, 1.5).x, 1.5);
    // A level of the wrong size is named.
    std::fs::remove_dir_all(dir.path().join("m3")).unwrap();
    std::fs::remove_dir_all(dir.path().join("m2")).unwrap();
    let sub = dir.path().join("m2");
    std::fs::create_dir_all(&sub).unwrap();
    for f in cubeforge::cube::FACE_NAMES {
        let p = sub.join(format!("{f}.exr"));
        let img = Image::filled(3, 3, Vec4::ONE);
        std::fs::write(
            &p,
            io::encode_image(&p, &img, &WriteOptions::default()).unwrap(),
        )
        .unwrap();
    }
    let e = preview::load_environment(dir.path(), None, &ReadOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("m2") && e.contains("2x2"), "{e}");
}

#[test]
fn command_line_renders_png_exr_and_grids() {
    let dir = tempfile::tempdir().unwrap();
    let out = |name: &str| dir.path().join(name).to_string_lossy().into_owned();
    let png = out("ball.png");
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &png,
        "--size",
        "48",
        "-m",
        "crystal",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let (img, meta) = io::read(Path::new(&png), &ReadOptions::default()).unwrap();
    assert_eq!(meta.file_format, io::FileFormat::Png);
    let io::Decoded::Image(img) = img else {
        panic!()
    };
    assert_eq!((img.width, img.height), (48, 48));
    // EXR: linear radiance, one sample through each pixel centre, as the library renders it.
    let exr = out("ball.exr");
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &exr,
        "--size",
        "32",
        "--yaw",
        "-40",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let got = common::read_image(Path::new(&exr));
    let env = preview::load_environment(
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr")),
        None,
        &ReadOptions::default(),
    )
    .unwrap();
    let want = preview::render(
        &env.sampler,
        &material::preset("chrome").unwrap(),
        &Surface::default(),
        &Options {
            size: 32,
            yaw: -40.0,
            ..Options::default()
        },
    )
    .unwrap();
    let worst = got
        .pixels
        .iter()
        .zip(&want.pixels)
        .map(|(a, b)| ((*a - *b).abs() / b.abs().max(Vec4::splat(1e-3))).max_element())
        .fold(0.0f32, f32::max);
    assert!(
        worst < 2e-3,
        "EXR holds the radiance (half precision): {worst}"
    );
    // A grid: three cells side by side with labels below.
    let grid = out("grid.png");
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &grid,
        "--size",
        "40",
        "--grid",
        "chrome,glass,crystal",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let g = common::read_image(Path::new(&grid));
    assert!(g.width > 3 * 40 && g.width < 3 * 40 + 20 && g.height > 40 + 7);
    let label_rows = (40..g.height).flat_map(|y| (0..g.width).map(move |x| (x, y)));
    assert!(
        label_rows.filter(|&(x, y)| g.get(x, y).x > 0.9).count() > 30,
        "labels are drawn"
    );
    // --grid-bias on a one-level map: rendered, with a warning that blur needs a chain.
    let r = common::run([
        "preview",
        "fixtures/sky.exr",
        "-o",
        &out("bias.png"),
        "--size",
        "24",
        "--grid-bias",
        "0,2",
    ]);
    assert!(r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("warning") && err.contains("prefilter"),
        "{err}"
    );
    // --material list prints every preset.
    let r = common::run(["preview", "--material", "list"]);
    let text = String::from_utf8_lossy(&r.stdout);
    for name in [
        "chrome",
        "mirror-decal",
        "glass",
        "water",
        "diamond",
        "plastic",
        "crystal",
    ] {
        assert!(text.contains(name), "{text}");
    }
}

#[test]
fn command_line_errors_are_one_line_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png").to_string_lossy().into_owned();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "model = \"reflect\"\nshininess = 3\n").unwrap();
    let bad = bad.to_string_lossy().into_owned();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["preview", "missing.exr", "-o", &out], "missing.exr"),
        (
            vec!["preview", "fixtures/sky.exr", "-o", &out, "-m", &bad],
            "bad.toml",
        ),
        (
            vec!["preview", "fixtures/sky.exr", "-o", &out, "-m", "velvet"],
            "velvet",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "-m",
                "nothere.toml",
            ],
            "nothere.toml",
        ),
        (
            vec!["preview", "fixtures/sky.exr", "-o", "x.ktx2"],
            "x.ktx2",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--decal",
                "nodecal.png",
            ],
            "nodecal.png",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--control",
                "nomask.png",
            ],
            "nomask.png",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--distance",
                "0.5",
            ],
            "--distance",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--background",
                "mauve",
            ],
            "--background",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--parallax",
                "exact",
            ],
            "--env-radius",
        ),
        (
            vec![
                "preview",
                "fixtures/sky.exr",
                "-o",
                &out,
                "--env-radius",
                "1.5",
                "--env-center",
                "1,0,0",
                "--parallax",
                "exact",
            ],
            "--env-radius",
        ),
        (vec!["preview", "fixtures/sky.exr"], "-o OUTPUT"),
    ];
    for (args, needle) in cases {
        let r = common::run(&args);
        let err = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.starts_with("cubeforge: error: "), "{args:?}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    assert!(!Path::new(&out).exists(), "nothing written on error");
}
