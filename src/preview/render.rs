//! The picture: every pixel's samples through the shader, per fragment at the exact hit or
//! per vertex through the rasterizer, rows in parallel.

#![warn(missing_docs)]

use super::camera::{sample_offsets, Camera};
use super::material::{self, Material};
use super::options::{Background, Options, Refraction, Shading};
use super::pbr::SplitSum;
use super::raster::{setup_raster, Frag, NO_TRI};
use super::shader::{Shader, Surface};
use super::sphere;
use crate::cube::Environment;
use crate::error::{param, Error, Result};
use crate::image::Image;
use glam::{Vec2, Vec3, Vec4};

/// Renders the sphere: linear radiance, alpha the coverage of the background's alpha.
/// Rows run in parallel; the result does not depend on the thread count.
pub fn render<E: Environment + ?Sized>(
    env: &E,
    material: &Material,
    surface: &Surface<'_>,
    opts: &Options,
) -> Result<Image> {
    render_with_progress(env, material, surface, opts, &|_| {})
}

/// [`render`], calling `progress(1)` as each of the `opts.size` rows is done (for a progress
/// bar: a large preview with many samples takes seconds).
pub fn render_with_progress<E: Environment + ?Sized>(
    env: &E,
    material: &Material,
    surface: &Surface<'_>,
    opts: &Options,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Image> {
    render_lit(env, None, material, surface, opts, progress)
}

/// [`render_with_progress`] with the split-sum lighting a `pbr` material needs (see
/// [`super::pbr::prepare`] and [`SplitSum`]); the texts' materials ignore it.
pub fn render_lit<E: Environment + ?Sized>(
    env: &E,
    split_sum: Option<&SplitSum>,
    material: &Material,
    surface: &Surface<'_>,
    opts: &Options,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Image> {
    use rayon::prelude::*;
    refuse(split_sum, material, opts)?;
    let n = opts.size;
    let cam = Camera::new(opts.distance, opts.fov, opts.yaw, opts.pitch, n, n);
    let mut shader = Shader::new(
        env,
        material,
        *surface,
        cam.eye,
        opts.parallax,
        opts.lod_bias,
    );
    if let Some(s) = split_sum {
        shader = shader.with_split_sum(s);
    }
    shader = shader.with_refraction(opts.refraction);
    let offsets = sample_offsets(opts.samples);
    let s = offsets.len();
    let inv_s = 1.0 / s as f32;
    let raster = (opts.shading == Shading::PerVertex)
        .then(|| setup_raster(&shader, &cam, opts.tessellation, &offsets));
    let floor = split_sum.filter(|_| opts.ground);
    let background = |d: Vec3| match (floor.and_then(|s| ground(s, cam.eye, d)), opts.background) {
        (Some(c), _) => c,
        (None, Background::Env) => env.lookup(d, 0.0).truncate().extend(1.0),
        (None, Background::Color(c)) => c,
    };
    let per_fragment =
        |sx: f32, sy: f32| fragment(&shader, &cam, sx, sy).unwrap_or_else(&background);
    let mut img = Image::new(n, n);
    img.pixels.par_chunks_mut(n).enumerate().for_each_init(
        || {
            vec![
                Frag {
                    tri: NO_TRI,
                    inv_z: 0.0
                };
                if raster.is_some() { n * s } else { 0 }
            ]
        },
        |buf, (y, row)| {
            if let Some(r) = &raster {
                r.rasterize_row(y, n, &offsets, buf);
            }
            for (x, out) in row.iter_mut().enumerate() {
                let mut acc = Vec4::ZERO;
                for (k, &(ox, oy)) in offsets.iter().enumerate() {
                    let (sx, sy) = (x as f32 + ox, y as f32 + oy);
                    acc += match &raster {
                        None => per_fragment(sx, sy),
                        Some(r) => {
                            let f = buf[x * s + k];
                            if f.tri == NO_TRI {
                                background(cam.ray(sx, sy))
                            } else {
                                let t = &r.tris[f.tri as usize];
                                let var = r.interpolate(t, t.persp(sx, sy));
                                if shader.lod_on {
                                    let vx = r.interpolate(t, t.persp(sx + 1.0, sy));
                                    let vy = r.interpolate(t, t.persp(sx, sy + 1.0));
                                    shader.fragment(&var, Some((&vx, &vy)))
                                } else {
                                    shader.fragment(&var, None)
                                }
                            }
                        }
                    };
                }
                *out = acc * inv_s;
            }
            progress(1);
        },
    );
    Ok(img)
}

/// What the renderer refuses before any pixel: bad options or material, a pbr material
/// without split-sum lighting, and exact refraction per vertex.
fn refuse(split_sum: Option<&SplitSum>, material: &Material, opts: &Options) -> Result<()> {
    opts.validate()?;
    material::validate(material)?;
    if opts.ground && material.model != material::Model::Pbr {
        return Err(Error::usage(format!(
            "{} is lit by the pbr lighting: material \"{}\" is not pbr",
            param("ground"),
            material.name
        )));
    }
    if material.model == material::Model::Pbr && split_sum.is_none() {
        return Err(Error::usage(format!(
        "material \"{}\" is pbr: it needs split-sum lighting (preview::render_lit with a preview::pbr::SplitSum)",
        material.name
    )));
    }
    if opts.shading == Shading::PerVertex
        && material.refraction == Some(Refraction::Exact)
        && matches!(
            material.model,
            material::Model::Refract | material::Model::Dispersion
        )
    {
        return Err(Error::usage(format!(
        "material \"{}\" asks for refraction exact, which traces each fragment's path: it needs {} per-fragment",
        material.name,
        param("shading")
    )));
    }
    Ok(())
}

/// Albedo of the `--ground` floor: a grey that neither a white sphere nor a dark one hides.
pub const GROUND_ALBEDO: f32 = 0.5;

/// The floor y = -1 seen along `d` from `eye` (None: `d` does not reach it): Lambertian, lit
/// by the map's irradiance facing up (the sphere's occlusion of the sky left out, as engines
/// leave it to ambient occlusion) and by the sun where the sphere does not stand between.
fn ground(split: &SplitSum, eye: Vec3, d: Vec3) -> Option<Vec4> {
    let t = (-1.0 - eye.y) / d.y;
    if !(d.y < 0.0 && t > 0.0) {
        return None;
    }
    let p = eye + d * t;
    let mut e = split.irradiance_over_pi(Vec3::Y);
    if let Some(s) = split.sun() {
        let l = s.direction;
        if l.y > 0.0 && sphere::hit(p, l).is_none() {
            e += s.irradiance * (l.y / std::f32::consts::PI);
        }
    }
    Some((e * GROUND_ALBEDO).extend(1.0))
}

/// One sample of the per-fragment path: the vertex stage at the exact hit, and at the points
/// where the rays one pixel right and below meet the hit's tangent plane (a GPU's
/// neighbouring fragments on the surface's local plane). `Err`: the ray's direction, which
/// missed the sphere (the background shows).
fn fragment<E: Environment + ?Sized>(
    shader: &Shader<'_, E>,
    cam: &Camera,
    sx: f32,
    sy: f32,
) -> std::result::Result<Vec4, Vec3> {
    let eye = cam.eye;
    let d = cam.ray(sx, sy);
    let Some(p) = sphere::hit(eye, d) else {
        return Err(d);
    };
    let nrm = p.normalize();
    let uv = if shader.uses_uv {
        sphere::uv(nrm)
    } else {
        Vec2::ZERO
    };
    if shader.exact {
        return Ok(shader.exact(p, nrm, uv));
    }
    let var = shader.vertex(p, nrm, uv);
    if !shader.lod_on {
        return Ok(shader.fragment(&var, None));
    }
    let plane = (p - eye).dot(nrm);
    let at = |sx2: f32, sy2: f32| {
        let d2 = cam.ray(sx2, sy2);
        let den = d2.dot(nrm);
        if den >= -1e-9 {
            return None;
        }
        let p2 = eye + d2 * (plane / den);
        Some(shader.vertex(p2, p2.normalize(), var.uv))
    };
    Ok(match (at(sx + 1.0, sy), at(sx, sy + 1.0)) {
        (Some(vx), Some(vy)) => shader.fragment(&var, Some((&vx, &vy))),
        _ => shader.fragment(&var, None),
    })
}
