//! The texts' vertex and fragment programs with their uniforms bound, and the level of detail
//! a GPU would pick for a lookup: the per-pixel work both pipelines share.

#![warn(missing_docs)]

use super::glass;
use super::material::{fresnel, reflect, refract, Material, Model};
use super::options::{Parallax, Refraction};
use super::pbr::SplitSum;
use crate::cube::Environment;
use crate::image::Image;
use glam::{Vec2, Vec3, Vec4};

/// A control map (section 7.2.4) on the sphere's texture coordinates: R reflectivity,
/// G transmittance, B blur (a fraction of `max_lod_bias`), A Fresnel mask.
#[derive(Clone, Copy, Debug)]
pub struct Control<'a> {
    /// The map, linear data, read at the sphere's (u, v).
    pub map: &'a Image,
    /// The LOD bias that blur = 1 stands for (from the map's sidecar).
    pub max_lod_bias: f32,
}

/// Textures on the sphere's texture coordinates.
#[derive(Clone, Copy, Debug, Default)]
pub struct Surface<'a> {
    /// The decal (`decalMap`); without it the material's `decal_color`.
    pub decal: Option<&'a Image>,
    /// A control map that varies the material's parameters over the sphere.
    pub control: Option<Control<'a>>,
}

/// What the vertex stage hands the fragment stage (the texts' TEXCOORDs and COLOR).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Varyings {
    /// The sphere's texture coordinates at the point, for the decal and control map.
    pub uv: Vec2,
    /// Lookup vectors: R (reflect), T (refract), or R, TRed, TGreen, TBlue (dispersion),
    /// after any parallax correction; for `pbr` R, the normal N and the unit vector V towards
    /// the eye.
    pub v: [Vec3; 4],
    /// The clamped reflection factor (dispersion).
    pub factor: f32,
}

impl Varyings {
    /// Barycentric combination of three vertices' outputs.
    #[inline]
    pub(super) fn blend(a: &Varyings, b: &Varyings, c: &Varyings, l: Vec3) -> Varyings {
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
    pub(super) lod_on: bool,
    /// Half the level-0 face edge: texels per unit of the face's sc / |ma|.
    half_size: f32,
    lod_bias: f32,
    lookups: usize,
    /// A decal texture or control map is read: texture coordinates are needed.
    pub(super) uses_uv: bool,
    /// What a `pbr` material reads besides the chain.
    split_sum: Option<&'a SplitSum>,
    /// A refract or dispersion material traced through the solid sphere ([`Shader::exact`]).
    pub(super) exact: bool,
}

impl<'a, E: Environment + ?Sized> Shader<'a, E> {
    /// Binds the uniforms: the environment, the material, its textures, the eye position,
    /// Brennan's parallax if any and the LOD bias added to every lookup.
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
            // A pbr material's level comes from its roughness, not from derivatives.
            lod_on: env.levels() > 1 && mat.model != Model::Pbr,
            half_size: env.face_size() as f32 * 0.5,
            lod_bias,
            lookups: if mat.model == Model::Dispersion { 4 } else { 1 },
            uses_uv: surface.decal.is_some() || surface.control.is_some(),
            split_sum: None,
            exact: false,
        }
    }

    /// How refract and dispersion materials bend light, unless the material says; the other
    /// models ignore it.
    pub fn with_refraction(mut self, refraction: Refraction) -> Self {
        self.exact = self.mat.refraction.unwrap_or(refraction) == Refraction::Exact
            && matches!(self.mat.model, Model::Refract | Model::Dispersion);
        self
    }

    /// Binds the split-sum lighting a `pbr` material needs (its level mapping, irradiance and
    /// DFG table); without it a `pbr` material renders black.
    pub fn with_split_sum(mut self, split_sum: &'a SplitSum) -> Self {
        self.split_sum = Some(split_sum);
        self
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
            Model::Pbr => {
                out.v[0] = self.correct(reflect(i, n), p);
                out.v[1] = n;
                out.v[2] = -i.normalize();
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
        let (reflectivity, transmittance, blur, mask) = self.controls(var.uv);
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
        let decal = || self.decal(var.uv);
        if m.model == Model::Pbr {
            // The decal is glTF's baseColorTexture: it multiplies the base colour.
            let base = match self.surface.decal {
                Some(img) => m.base_color * tex2d(img, var.uv).truncate(),
                None => m.base_color,
            };
            let c = self.split_sum.map_or(Vec3::ZERO, |s| {
                s.shade(
                    self.env,
                    m,
                    base,
                    var.v[1],
                    var.v[2],
                    var.v[0],
                    self.lod_bias + blur,
                )
            });
            return c.extend(1.0);
        }
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
            Model::Pbr => Vec4::ZERO,
        };
        c.truncate().extend(1.0)
    }
}

impl<E: Environment + ?Sized> Shader<'_, E> {
    /// The control map's reflectivity, transmittance, blur (as a LOD bias) and Fresnel mask
    /// at `uv`, or the material's own values.
    #[inline]
    fn controls(&self, uv: Vec2) -> (f32, f32, f32, f32) {
        match &self.surface.control {
            Some(c) => {
                let t = tex2d(c.map, uv);
                (t.x, t.y, t.z * c.max_lod_bias, t.w)
            }
            None => (self.mat.reflectivity, self.mat.transmittance, 0.0, 1.0),
        }
    }

    #[inline]
    fn decal(&self, uv: Vec2) -> Vec4 {
        match self.surface.decal {
            Some(img) => tex2d(img, uv),
            None => self.mat.decal_color.extend(1.0),
        }
    }

    /// `Refraction::Exact` at world point `p` of the sphere with unit normal `n`: the light
    /// of every ray [`glass::trace`] makes of the eye ray, weighted. `refract` blends it with
    /// the decal by `transmittance` as C7E4f does; `dispersion` traces each channel with its
    /// own eta and sums, the exact Fresnel split replacing the texts' empirical bias, scale
    /// and power (and a control map's reflectivity and mask). The lookups read level 0 plus
    /// the LOD bias and the control map's blur: a lens's footprint differs at every bounce.
    /// Other models run the texts' programs.
    #[inline]
    pub fn exact(&self, p: Vec3, n: Vec3, uv: Vec2) -> Vec4 {
        let m = self.mat;
        let (_, transmittance, blur, _) = self.controls(uv);
        let lod = if self.lod_on {
            self.lod_bias + blur
        } else {
            0.0
        };
        let i = (p - self.eye).normalize();
        let look = |r: &glass::Ray| self.tex_cube(self.correct(r.dir, r.origin), lod);
        let c = match m.model {
            Model::Refract => {
                let mut c = Vec4::ZERO;
                for r in glass::trace(p, i, m.eta_ratio.x).rays() {
                    c += look(r) * r.weight;
                }
                self.decal(uv).lerp(c, transmittance)
            }
            Model::Dispersion => {
                // The front reflection goes the same way for every channel: one lookup.
                let reflected = self.tex_cube(self.correct(reflect(i, n), p), lod);
                let mut c = Vec4::ZERO;
                for ch in 0..3 {
                    let path = glass::trace(p, i, m.eta_ratio[ch]);
                    let (front, exits) = path.rays().split_at(1);
                    let mut v = front[0].weight * reflected[ch];
                    for r in exits {
                        v += look(r)[ch] * r.weight;
                    }
                    c[ch] = v;
                }
                c
            }
            _ => return self.fragment(&self.vertex(p, n, uv), None),
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
pub(crate) fn cube_lod(v: Vec3, vx: Vec3, vy: Vec3, half_size: f32) -> f32 {
    let a = v.abs();
    // The face the GPU picks is the cube's own (ties included); its two other axes span it.
    let axis = crate::cube::dir_face(v).0 / 2;
    let (u, w) = [(2, 1), (0, 2), (0, 1)][axis];
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
