//! `cubeforge preview`: every model against the source texts' formulas evaluated here,
//! independently, in double precision, for 1-sample renders of analytic environments; total
//! internal reflection, the Fresnel clamp, per-vertex converging to per-fragment, both
//! parallax modes, LOD bias, control maps, orientation, determinism and the command line; and
//! `--refraction exact` against a double-precision trace of the solid sphere.
//!
//! This module holds the reference geometry and formulas every part compares against; the
//! tests are split by topic below it.

mod command_line;
mod control_maps;
mod exact_glass;
mod lod;
mod models;
mod orientation;
mod parallax;
mod vertex;

use cubeforge::internals::cube::{CubeMap, CubeSampler};
use cubeforge::internals::image::Image;
use cubeforge::internals::io::{self, WriteOptions};
use cubeforge::internals::preview::material::{self, Material, Model};
use cubeforge::internals::preview::{self, Background, Options, Shading, Surface};
use cubeforge::internals::resample::FnEnv;
use cubeforge::internals::synthetic;
use glam::{DVec3, Vec3, Vec4};

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
// Shared by the level-of-detail and control-map tests.

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
