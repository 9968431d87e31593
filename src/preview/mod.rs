//! Preview: a CPU renderer that shows a cube map on a sphere, shaded by exactly the programs of
//! The Cg Tutorial, chapter 7 (reflection, refraction, Fresnel with chromatic dispersion) and
//! Brennan's correction for an environment at finite distance.
//!
//! Geometry: the unit sphere at the origin, world space = cube-map space, the camera of
//! [`camera::Camera`] at distance D looking at the origin. Every shading runs in two stages
//! like the texts' program pairs: a *vertex stage* ([`Shader::vertex`]) computes the lookup
//! vectors and the Fresnel factor at a surface point, a *fragment stage*
//! ([`Shader::fragment`]) looks them up and blends. Per-fragment shading runs the vertex stage
//! at every sample's exact ray/sphere hit; per-vertex shading runs it at the vertices of a
//! tessellated sphere and interpolates its outputs perspective-correctly across each
//! triangle, as a rasterizer does, so section 7.2.5's artefacts appear.
//!
//! Level of detail: with a prefiltered chain, each lookup picks the level a GPU would, from
//! the derivatives of its lookup vector across neighbouring pixels projected on the selected
//! cube face (the OpenGL scale factor rho in texels, lod = log2 rho), plus `--lod-bias` and
//! the control map's blur, trilinear between levels.

pub mod camera;
pub mod grid;
pub mod material;
pub mod sphere;
pub mod tonemap;

use crate::convert::{self, Source};
use crate::cube::{CubeSampler, Environment};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::io::{self, Decoded, ReadOptions};
use crate::layout::Kind;
use crate::resample::Resampler;
use camera::{sample_offsets, Camera};
use glam::{Vec2, Vec3, Vec4};
use material::{fresnel, reflect, refract, Material, Model};
use std::path::{Path, PathBuf};

/// Where the vectors come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Shading {
    /// The vertex program runs at every sample's exact point on the sphere.
    #[default]
    PerFragment,
    /// The vertex program runs at the mesh's vertices; the rasterizer interpolates.
    PerVertex,
}

/// Brennan's correction for an environment at finite distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum ParallaxMode {
    /// normalize(V) + (P - C) / R: the vertex-shader approximation of the paper.
    #[default]
    Approx,
    /// The hit point of the ray P + tV on the sphere of radius R around C, minus C.
    Exact,
}

/// An environment of radius `radius` centred at `center` instead of at infinity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parallax {
    pub radius: f32,
    pub center: Vec3,
    pub mode: ParallaxMode,
}

impl Parallax {
    /// The lookup vector for a ray from `p` along `v` (the texts' R or T). The zero vector
    /// (total internal reflection) stays zero.
    #[inline]
    pub fn correct(&self, v: Vec3, p: Vec3) -> Vec3 {
        if v == Vec3::ZERO {
            return v;
        }
        let d = v.normalize();
        let cp = p - self.center;
        match self.mode {
            ParallaxMode::Approx => d + cp / self.radius,
            ParallaxMode::Exact => {
                // |cp + t d|^2 = R^2 with |d| = 1: t = -b + sqrt(b^2 - c), the far root, which
                // is the only one ahead for a point inside the environment's sphere.
                let b = cp.dot(d);
                let c = cp.length_squared() - self.radius * self.radius;
                let disc = b * b - c;
                if disc < 0.0 {
                    return d;
                }
                let t = -b + disc.sqrt();
                if t <= 0.0 {
                    return d;
                }
                cp + d * t
            }
        }
    }
}

/// What the camera sees where it misses the sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Background {
    /// The environment (level 0) along the camera ray.
    Env,
    /// A constant (linear RGBA; alpha 0 for transparent).
    Color(Vec4),
}

/// How to render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Options {
    /// Image edge in pixels (square).
    pub size: usize,
    /// Vertical field of view, degrees.
    pub fov: f32,
    /// Camera distance from the origin (> 1).
    pub distance: f32,
    /// Orbit about +Y, degrees.
    pub yaw: f32,
    /// Orbit towards +Y, degrees.
    pub pitch: f32,
    pub shading: Shading,
    /// Latitude bands of the per-vertex mesh (longitude segments: twice as many).
    pub tessellation: usize,
    /// Added to every lookup's level of detail (needs a chain).
    pub lod_bias: f32,
    pub parallax: Option<Parallax>,
    /// Samples per pixel (1: the pixel centre).
    pub samples: usize,
    pub background: Background,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            size: 512,
            fov: 30.0,
            distance: 4.0,
            yaw: 0.0,
            pitch: 0.0,
            shading: Shading::PerFragment,
            tessellation: 16,
            lod_bias: 0.0,
            parallax: None,
            samples: 1,
            background: Background::Env,
        }
    }
}

impl Options {
    /// Checks that the options describe a picture.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::usage(m));
        if self.size == 0 || self.size > 16384 {
            return bad(format!("--size must be 1 to 16384 (got {})", self.size));
        }
        if !(self.fov > 0.0 && self.fov < 179.0) {
            return bad(format!(
                "--fov must be between 0 and 179 degrees (got {})",
                self.fov
            ));
        }
        if !(self.distance.is_finite() && self.distance > 1.0) {
            return bad(format!(
                "--distance must be more than 1, outside the unit sphere (got {})",
                self.distance
            ));
        }
        if !self.yaw.is_finite() || !self.pitch.is_finite() || !self.lod_bias.is_finite() {
            return bad("--yaw, --pitch and --lod-bias must be finite numbers".into());
        }
        if self.samples == 0 || self.samples > 256 {
            return bad(format!("--samples must be 1 to 256 (got {})", self.samples));
        }
        if self.shading == Shading::PerVertex && !(2..=1024).contains(&self.tessellation) {
            return bad(format!(
                "--tessellation must be 2 to 1024 (got {})",
                self.tessellation
            ));
        }
        if let Some(p) = self.parallax {
            if !(p.radius.is_finite() && p.radius > 0.0 && p.center.is_finite()) {
                return bad(format!(
                    "--env-radius must be positive and --env-center finite (got {})",
                    p.radius
                ));
            }
            if p.mode == ParallaxMode::Exact && p.radius <= 1.0 + p.center.length() {
                return bad(format!(
                    "--parallax exact needs the sphere inside the environment: --env-radius ({}) must exceed 1 + |--env-center| ({})",
                    p.radius,
                    1.0 + p.center.length()
                ));
            }
        }
        Ok(())
    }
}

/// A control map (section 7.2.4) on the sphere's texture coordinates: R reflectivity,
/// G transmittance, B blur (a fraction of `max_lod_bias`), A Fresnel mask.
#[derive(Clone, Copy, Debug)]
pub struct Control<'a> {
    pub map: &'a Image,
    pub max_lod_bias: f32,
}

/// Textures on the sphere's texture coordinates.
#[derive(Clone, Copy, Debug, Default)]
pub struct Surface<'a> {
    /// The decal (`decalMap`); without it the material's `decal_color`.
    pub decal: Option<&'a Image>,
    pub control: Option<Control<'a>>,
}

/// What the vertex stage hands the fragment stage (the texts' TEXCOORDs and COLOR).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Varyings {
    pub uv: Vec2,
    /// Lookup vectors: R (reflect), T (refract), or R, TRed, TGreen, TBlue (dispersion),
    /// after any parallax correction.
    pub v: [Vec3; 4],
    /// The clamped reflection factor (dispersion).
    pub factor: f32,
}

impl Varyings {
    /// Barycentric combination of three vertices' outputs.
    #[inline]
    fn blend(a: &Varyings, b: &Varyings, c: &Varyings, l: Vec3) -> Varyings {
        let mut v = [Vec3::ZERO; 4];
        for (k, o) in v.iter_mut().enumerate() {
            *o = a.v[k] * l.x + b.v[k] * l.y + c.v[k] * l.z;
        }
        Varyings {
            uv: a.uv * l.x + b.uv * l.y + c.uv * l.z,
            v,
            factor: a.factor * l.x + b.factor * l.y + c.factor * l.z,
        }
    }
}

/// The texts' programs with their uniforms bound.
pub struct Shader<'a, E: Environment + ?Sized> {
    env: &'a E,
    mat: &'a Material,
    surface: Surface<'a>,
    eye: Vec3,
    parallax: Option<Parallax>,
    /// Levels beyond 0 exist: compute derivatives and levels of detail.
    lod_on: bool,
    /// Half the level-0 face edge: texels per unit of the face's sc / |ma|.
    half_size: f32,
    lod_bias: f32,
    lookups: usize,
    /// A decal texture or control map is read: texture coordinates are needed.
    uses_uv: bool,
}

impl<'a, E: Environment + ?Sized> Shader<'a, E> {
    pub fn new(
        env: &'a E,
        mat: &'a Material,
        surface: Surface<'a>,
        eye: Vec3,
        parallax: Option<Parallax>,
        lod_bias: f32,
    ) -> Self {
        Shader {
            env,
            mat,
            surface,
            eye,
            parallax,
            lod_on: env.levels() > 1,
            half_size: env.face_size() as f32 * 0.5,
            lod_bias,
            lookups: if mat.model == Model::Dispersion { 4 } else { 1 },
            uses_uv: surface.decal.is_some() || surface.control.is_some(),
        }
    }

    #[inline]
    fn correct(&self, v: Vec3, p: Vec3) -> Vec3 {
        match &self.parallax {
            Some(px) => px.correct(v, p),
            None => v,
        }
    }

    /// The vertex programs (C7E1v, C7E3v, C7E5v) at world position `p` with unit normal `n`.
    #[inline]
    pub fn vertex(&self, p: Vec3, n: Vec3, uv: Vec2) -> Varyings {
        let m = self.mat;
        let i = p - self.eye;
        let mut out = Varyings {
            uv,
            ..Varyings::default()
        };
        match m.model {
            Model::Reflect => out.v[0] = self.correct(reflect(i, n), p),
            Model::Refract => {
                out.v[0] = self.correct(refract(i.normalize(), n, m.eta_ratio.x), p);
            }
            Model::Dispersion => {
                out.v[0] = self.correct(reflect(i, n), p);
                let iu = i.normalize();
                out.v[1] = self.correct(refract(iu, n, m.eta_ratio.x), p);
                out.v[2] = self.correct(refract(iu, n, m.eta_ratio.y), p);
                out.v[3] = self.correct(refract(iu, n, m.eta_ratio.z), p);
                out.factor = fresnel(iu, n, m.fresnel_bias, m.fresnel_scale, m.fresnel_power);
            }
        }
        out
    }

    /// texCUBE; the zero vector (the texts' refract on total internal reflection) transmits
    /// nothing: black.
    #[inline]
    fn tex_cube(&self, v: Vec3, lod: f32) -> Vec4 {
        if v == Vec3::ZERO {
            Vec4::ZERO
        } else {
            self.env.lookup(v, lod)
        }
    }

    /// The fragment programs (C7E2f, C7E4f, C7E6f). `neighbours` are the varyings one pixel
    /// to the right and one below (None: unbounded footprint, the coarsest level), used for
    /// the level of detail when the environment has a chain.
    #[inline]
    pub fn fragment(&self, var: &Varyings, neighbours: Option<(&Varyings, &Varyings)>) -> Vec4 {
        let m = self.mat;
        // Control map: reflectivity, transmittance, blur, Fresnel mask.
        let (reflectivity, transmittance, blur, mask) = match &self.surface.control {
            Some(c) => {
                let t = tex2d(c.map, var.uv);
                (t.x, t.y, t.z * c.max_lod_bias, t.w)
            }
            None => (m.reflectivity, m.transmittance, 0.0, 1.0),
        };
        let mut lods = [0.0f32; 4];
        if self.lod_on {
            let bias = self.lod_bias + blur;
            for (k, lod) in lods.iter_mut().enumerate().take(self.lookups) {
                let base = match neighbours {
                    Some((x, y)) => cube_lod(var.v[k], x.v[k], y.v[k], self.half_size),
                    None => f32::INFINITY,
                };
                *lod = base + bias;
            }
        }
        let decal = || match self.surface.decal {
            Some(img) => tex2d(img, var.uv),
            None => m.decal_color.extend(1.0),
        };
        let c = match m.model {
            Model::Reflect => decal().lerp(self.tex_cube(var.v[0], lods[0]), reflectivity),
            Model::Refract => decal().lerp(self.tex_cube(var.v[0], lods[0]), transmittance),
            Model::Dispersion => {
                let reflected = self.tex_cube(var.v[0], lods[0]);
                let refracted = Vec4::new(
                    self.tex_cube(var.v[1], lods[1]).x,
                    self.tex_cube(var.v[2], lods[2]).y,
                    self.tex_cube(var.v[3], lods[3]).z,
                    1.0,
                );
                // Where the mask is 0 the Fresnel term does not apply: reflectivity instead.
                let factor = mask * var.factor + (1.0 - mask) * reflectivity;
                refracted.lerp(reflected, factor)
            }
        };
        c.truncate().extend(1.0)
    }
}

/// tex2D on the sphere's texture coordinates: bilinear, repeating around u, clamped in v.
#[inline]
fn tex2d(img: &Image, uv: Vec2) -> Vec4 {
    img.bilinear(uv.x * img.width as f32, uv.y * img.height as f32, true)
}

/// The level of detail a GPU picks for lookup vector `v` whose neighbours one pixel to the
/// right and one below are `vx` and `vy`: the vectors projected on `v`'s cube face (sc / |ma|,
/// tc / |ma|), their differences scaled to texels of level 0 (`half_size` = face edge / 2),
/// rho the longer, lod = log2(rho). A neighbour not in front of the face counts as unbounded.
#[inline]
pub fn cube_lod(v: Vec3, vx: Vec3, vy: Vec3, half_size: f32) -> f32 {
    let a = v.abs();
    let (axis, u, w) = if a.x >= a.y && a.x >= a.z {
        (0, 2, 1)
    } else if a.y >= a.z {
        (1, 0, 2)
    } else {
        (2, 0, 1)
    };
    let ma = v[axis];
    if ma == 0.0 {
        return 0.0;
    }
    let proj = |q: Vec3| {
        let m = q[axis] / ma.signum();
        (m > 0.0).then(|| Vec2::new(q[u] / m, q[w] / m))
    };
    let p = Vec2::new(v[u] / a[axis], v[w] / a[axis]);
    let d = |q: Vec3| proj(q).map_or(f32::INFINITY, |pq| (pq - p).length());
    let rho = d(vx).max(d(vy)) * half_size;
    rho.log2()
}

/// One triangle of the per-vertex mesh set up for rasterization: edge functions giving the
/// screen-space barycentrics directly, 1/z per vertex for perspective correction.
struct Tri {
    idx: [u32; 3],
    ea: Vec3,
    eb: Vec3,
    ec: Vec3,
    inv_z: Vec3,
    ymin: f32,
    ymax: f32,
    xmin: f32,
    xmax: f32,
}

impl Tri {
    #[inline]
    fn bary(&self, x: f32, y: f32) -> Vec3 {
        self.ea * x + self.eb * y + self.ec
    }
    /// Perspective-correct barycentrics at (x, y), extrapolated outside the triangle as a
    /// GPU does for helper pixels.
    #[inline]
    fn persp(&self, x: f32, y: f32) -> Vec3 {
        let q = self.bary(x, y) * self.inv_z;
        q / (q.x + q.y + q.z)
    }
}

/// A rasterized sample: the triangle and its 1/depth.
#[derive(Clone, Copy)]
struct Frag {
    tri: u32,
    inv_z: f32,
}

const NO_TRI: u32 = u32::MAX;

/// The per-vertex pipeline's data: vertex outputs, visible triangles, triangles per row.
struct Raster {
    varyings: Vec<Varyings>,
    tris: Vec<Tri>,
    row_start: Vec<u32>,
    row_tris: Vec<u32>,
}

fn setup_raster<E: Environment + ?Sized>(
    shader: &Shader<'_, E>,
    cam: &Camera,
    tessellation: usize,
    offsets: &[(f32, f32)],
) -> Raster {
    use rayon::prelude::*;
    let mesh = sphere::tessellate(tessellation);
    // The vertex program at every vertex (normal = position on the unit sphere).
    let varyings: Vec<Varyings> = mesh
        .positions
        .par_iter()
        .zip(mesh.uvs.par_iter())
        .map(|(&p, &uv)| shader.vertex(p, p, uv))
        .collect();
    let screen: Vec<(f32, f32, f32)> = mesh.positions.iter().map(|&p| cam.project(p)).collect();
    let mut tris = Vec::with_capacity(mesh.triangles.len() / 2 + 1);
    for t in &mesh.triangles {
        let [p0, p1, p2] = t.map(|i| mesh.positions[i as usize]);
        let mut n = (p1 - p0).cross(p2 - p0);
        if n.dot(p0 + p1 + p2) < 0.0 {
            n = -n;
        }
        // Back faces are hidden by the front ones (the mesh is convex): cull them.
        if n.length_squared() < 1e-20 || (p0 - cam.eye).dot(n) >= 0.0 {
            continue;
        }
        let [s0, s1, s2] = t.map(|i| screen[i as usize]);
        let area2 = (s1.0 - s0.0) * (s2.1 - s0.1) - (s2.0 - s0.0) * (s1.1 - s0.1);
        if area2.abs() < 1e-12 {
            continue;
        }
        // e_i = E(a, b, p) / area2 for the edge a -> b opposite vertex i.
        let edge = |a: (f32, f32, f32), b: (f32, f32, f32)| {
            (
                -(b.1 - a.1) / area2,
                (b.0 - a.0) / area2,
                ((b.1 - a.1) * a.0 - (b.0 - a.0) * a.1) / area2,
            )
        };
        let (e0, e1, e2) = (edge(s1, s2), edge(s2, s0), edge(s0, s1));
        tris.push(Tri {
            idx: *t,
            ea: Vec3::new(e0.0, e1.0, e2.0),
            eb: Vec3::new(e0.1, e1.1, e2.1),
            ec: Vec3::new(e0.2, e1.2, e2.2),
            inv_z: Vec3::new(1.0 / s0.2, 1.0 / s1.2, 1.0 / s2.2),
            ymin: s0.1.min(s1.1).min(s2.1),
            ymax: s0.1.max(s1.1).max(s2.1),
            xmin: s0.0.min(s1.0).min(s2.0),
            xmax: s0.0.max(s1.0).max(s2.0),
        });
    }
    // Bin triangles by the pixel rows whose samples they may cover.
    let h = cam.height;
    let (oy_min, oy_max) = offsets
        .iter()
        .fold((1.0f32, 0.0f32), |(lo, hi), o| (lo.min(o.1), hi.max(o.1)));
    let rows_of = |t: &Tri| {
        let r0 = (t.ymin - oy_max).ceil().max(0.0);
        let r1 = (t.ymax - oy_min).floor().min(h as f32 - 1.0);
        (r0 as usize, r1)
    };
    let mut count = vec![0u32; h + 1];
    for t in &tris {
        let (r0, r1) = rows_of(t);
        if r1 >= r0 as f32 {
            for c in &mut count[r0..=r1 as usize] {
                *c += 1;
            }
        }
    }
    let mut row_start = vec![0u32; h + 1];
    for r in 0..h {
        row_start[r + 1] = row_start[r] + count[r];
    }
    let mut fill = row_start.clone();
    let mut row_tris = vec![0u32; row_start[h] as usize];
    for (ti, t) in tris.iter().enumerate() {
        let (r0, r1) = rows_of(t);
        if r1 >= r0 as f32 {
            for r in r0..=r1 as usize {
                row_tris[fill[r] as usize] = ti as u32;
                fill[r] += 1;
            }
        }
    }
    Raster {
        varyings,
        tris,
        row_start,
        row_tris,
    }
}

impl Raster {
    /// Rasterizes row `y`'s samples into `buf` (pixel-major, `offsets.len()` per pixel):
    /// for each sample the nearest covering triangle.
    fn rasterize_row(&self, y: usize, width: usize, offsets: &[(f32, f32)], buf: &mut [Frag]) {
        let s = offsets.len();
        buf.fill(Frag {
            tri: NO_TRI,
            inv_z: 0.0,
        });
        let list = &self.row_tris[self.row_start[y] as usize..self.row_start[y + 1] as usize];
        for (k, &(ox, oy)) in offsets.iter().enumerate() {
            let ys = y as f32 + oy;
            for &ti in list {
                let t = &self.tris[ti as usize];
                if ys < t.ymin || ys > t.ymax {
                    continue;
                }
                // The x interval where all three edge functions are >= 0 on this scanline.
                let (mut lo, mut hi) = (t.xmin, t.xmax);
                let c = t.eb * ys + t.ec;
                for i in 0..3 {
                    let a = t.ea[i];
                    if a > 0.0 {
                        lo = lo.max(-c[i] / a);
                    } else if a < 0.0 {
                        hi = hi.min(-c[i] / a);
                    } else if c[i] < 0.0 {
                        hi = f32::NEG_INFINITY;
                    }
                }
                if lo > hi {
                    continue;
                }
                let x0 = (lo - ox).ceil().max(0.0) as usize;
                let x1 = (hi - ox).floor();
                if x1 < 0.0 {
                    continue;
                }
                let x1 = (x1 as usize).min(width - 1);
                for px in x0..=x1 {
                    let sx = px as f32 + ox;
                    let b = t.bary(sx, ys);
                    if b.min_element() < -1e-5 {
                        continue;
                    }
                    let iz = b.dot(t.inv_z);
                    let slot = &mut buf[px * s + k];
                    if slot.tri == NO_TRI || iz > slot.inv_z {
                        *slot = Frag { tri: ti, inv_z: iz };
                    }
                }
            }
        }
    }

    #[inline]
    fn interpolate(&self, t: &Tri, l: Vec3) -> Varyings {
        let [a, b, c] = t.idx.map(|i| &self.varyings[i as usize]);
        Varyings::blend(a, b, c, l)
    }
}

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
    use rayon::prelude::*;
    opts.validate()?;
    material::validate(material).map_err(Error::usage)?;
    let n = opts.size;
    let cam = Camera::new(opts.distance, opts.fov, opts.yaw, opts.pitch, n, n);
    let shader = Shader::new(
        env,
        material,
        *surface,
        cam.eye,
        opts.parallax,
        opts.lod_bias,
    );
    let offsets = sample_offsets(opts.samples);
    let s = offsets.len();
    let inv_s = 1.0 / s as f32;
    let raster = (opts.shading == Shading::PerVertex)
        .then(|| setup_raster(&shader, &cam, opts.tessellation, &offsets));
    let eye = cam.eye;
    let background = |d: Vec3| match opts.background {
        Background::Env => env.lookup(d, 0.0).truncate().extend(1.0),
        Background::Color(c) => c,
    };
    // Per fragment: the vertex stage at the exact hit, and at the points where the rays one
    // pixel right and below meet the hit's tangent plane (a GPU's neighbouring fragments on
    // the surface's local plane).
    let per_fragment = |sx: f32, sy: f32| -> Vec4 {
        let d = cam.ray(sx, sy);
        let Some(p) = sphere::hit(eye, d) else {
            return background(d);
        };
        let nrm = p.normalize();
        let uv = if shader.uses_uv {
            sphere::uv(nrm)
        } else {
            Vec2::ZERO
        };
        let var = shader.vertex(p, nrm, uv);
        if !shader.lod_on {
            return shader.fragment(&var, None);
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
        match (at(sx + 1.0, sy), at(sx, sy + 1.0)) {
            (Some(vx), Some(vy)) => shader.fragment(&var, Some((&vx, &vy))),
            _ => shader.fragment(&var, None),
        }
    };
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

/// An environment ready for the preview, with what the user should be told about it.
pub struct LoadedEnv {
    pub sampler: CubeSampler,
    /// Every file read.
    pub files: Vec<PathBuf>,
    /// Holds values above 1.
    pub hdr: bool,
    /// NaN, infinite or negative values replaced by 0 on read (values above 1e28 by 1e28).
    pub replaced_values: usize,
}

impl LoadedEnv {
    pub fn levels(&self) -> usize {
        Environment::levels(&self.sampler)
    }
}

/// Loads an environment for the preview. A KTX2 or DDS cube map keeps all its stored levels
/// (they are the prefiltered chain); a directory holding `m0/`, `m1/`, ... (from
/// `cubeforge prefilter`) is read level by level; anything else `convert` reads becomes a
/// one-level cube map at the input's resolution.
pub fn load_environment(path: &Path, from: Option<Kind>, opts: &ReadOptions) -> Result<LoadedEnv> {
    if path.is_dir() && crate::chain::is_chain_dir(path) {
        return load_chain_dir(path, opts);
    }
    let loaded = convert::load(&[path.to_path_buf()], from, opts)?;
    let cube = match &loaded.source {
        Source::Cube(c) => CubeSampler::new(c),
        Source::Projection(..) => {
            let size = loaded.face_size().max(1);
            CubeSampler::new(&convert::to_cube(&loaded, size, &Resampler::default()))
        }
    };
    Ok(LoadedEnv {
        sampler: cube,
        files: loaded.files.clone(),
        hdr: loaded.hdr,
        replaced_values: loaded.meta.replaced_values,
    })
}

/// Reads `DIR/m0`, `DIR/m1`, ... (each a folder of six faces) as one chain; each level must
/// be half the size of the one before (down to 1).
fn load_chain_dir(dir: &Path, opts: &ReadOptions) -> Result<LoadedEnv> {
    let c = crate::chain::read_dir(dir, opts)?;
    Ok(LoadedEnv {
        sampler: CubeSampler::new(&c.cube),
        files: c.files,
        hdr: c.meta.hdr,
        replaced_values: c.meta.replaced_values,
    })
}

/// Reads a 2D texture for the sphere (decal: colour, sRGB-decoded; control map: `linear`).
pub fn read_texture(path: &Path, linear: bool) -> Result<Image> {
    let opts = ReadOptions {
        linear,
        ..ReadOptions::default()
    };
    match io::read(path, &opts)?.0 {
        Decoded::Image(img) => Ok(img),
        Decoded::Cube(_) => Err(Error::file(
            path,
            "holds a cube map; a texture on the sphere must be a 2D image",
        )),
    }
}

/// The sidecar a control map's `max_lod_bias` is stored in: `MAP.json` (e.g. `mask.png.json`)
/// or the map's name with `.json` for its extension (`mask.json`), whichever exists.
pub fn control_sidecar(map: &Path) -> Option<PathBuf> {
    let mut appended = map.as_os_str().to_owned();
    appended.push(".json");
    [PathBuf::from(appended), map.with_extension("json")]
        .into_iter()
        .find(|p| p.is_file() && p != map)
}

/// Reads a control map (linear data) and its `max_lod_bias`: from the sidecar when there is
/// one, else `default_max`. Returns the map, the value and the sidecar used.
pub fn read_control(path: &Path, default_max: f32) -> Result<(Image, f32, Option<PathBuf>)> {
    let img = read_texture(path, true)?;
    let Some(side) = control_sidecar(path) else {
        return Ok((img, default_max, None));
    };
    let text = String::from_utf8(io::read_file(&side)?)
        .map_err(|_| Error::file(&side, "not UTF-8 text"))?;
    let json: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| Error::file(&side, format!("not valid JSON: {e}")))?;
    let max = match json.get("max_lod_bias") {
        None => default_max,
        Some(v) => v
            .as_f64()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| Error::file(&side, "max_lod_bias must be a number >= 0"))?
            as f32,
    };
    Ok((img, max, Some(side)))
}
