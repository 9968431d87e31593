//! Layouts: each is a mapping between directions and image coordinates, written once and used
//! both to read an input and to write an output. Each layout's file owns its geometry: the
//! mapping both ways, its texels' density and solid angles, and an output texel's footprint
//! (`ball` what mirror balls and angular maps share); [`Projection`] dispatches to them.

#![warn(missing_docs)]

pub mod angular;
mod ball;
pub mod cross;
pub mod equirect;
pub mod octahedral;
pub mod sphere;

use crate::cube::{Dirs, Environment, Interp, BATCH};
use crate::image::{Edges, Image};
use glam::{Vec2, Vec3, Vec4};

/// The layouts: how an environment map's directions lie on images (one image, or six faces).
/// Cube-map containers (KTX2, DDS, ...) are file formats that hold faces: `io::Container`, a
/// layer up; `convert::MapKind` names either.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Kind {
    /// Lat-long panorama, 2:1.
    Equirect,
    /// Six face images (px nx py ny pz nz).
    Faces,
    /// Horizontal cross, 4:3.
    Hcross,
    /// Vertical cross, 3:4 (-Z turned 180 degrees).
    Vcross,
    /// Horizontal strip, 6:1.
    Hstrip,
    /// Vertical strip, 1:6.
    Vstrip,
    /// Mirror ball (sphere map), square.
    Sphere,
    /// Angular map (light probe), square.
    Angular,
    /// Octahedral map (engines' probes), square: +Y at the centre, -Y in the corners.
    Octahedral,
}

impl Kind {
    /// The name on the command line (`--from`, `--to`) and in `info`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Equirect => "equirect",
            Kind::Faces => "faces",
            Kind::Hcross => "hcross",
            Kind::Vcross => "vcross",
            Kind::Hstrip => "hstrip",
            Kind::Vstrip => "vstrip",
            Kind::Sphere => "sphere",
            Kind::Angular => "angular",
            Kind::Octahedral => "octahedral",
        }
    }

    /// Crosses and strips (faces placed in cells) as the type [`cross`] lays out and cuts.
    pub fn cells(self) -> Option<cross::Cells> {
        match self {
            Kind::Hcross => Some(cross::Cells::Hcross),
            Kind::Vcross => Some(cross::Cells::Vcross),
            Kind::Hstrip => Some(cross::Cells::Hstrip),
            Kind::Vstrip => Some(cross::Cells::Vstrip),
            _ => None,
        }
    }

    /// The single-image layouts resampled by direction (not made of faces).
    pub fn projection(self) -> Option<Projection> {
        match self {
            Kind::Equirect => Some(Projection::Equirect),
            Kind::Sphere => Some(Projection::Sphere),
            Kind::Angular => Some(Projection::Angular),
            Kind::Octahedral => Some(Projection::Octahedral),
            _ => None,
        }
    }

    /// Whether a `w` x `h` image can hold this layout exactly.
    pub(crate) fn fits(self, w: usize, h: usize) -> bool {
        match self {
            Kind::Equirect => w == 2 * h,
            Kind::Sphere | Kind::Angular | Kind::Octahedral => w == h,
            _ => match self.cells() {
                Some(cells) => {
                    let (c, r) = cells.grid();
                    w.is_multiple_of(c) && h.is_multiple_of(r) && w / c == h / r
                }
                None => false,
            },
        }
    }

    /// Output image size for a face edge `n` (one face's for faces).
    pub fn image_size(self, n: usize) -> (usize, usize) {
        match self {
            Kind::Equirect => (4 * n, 2 * n),
            Kind::Sphere | Kind::Angular | Kind::Octahedral => (2 * n, 2 * n),
            _ => match self.cells() {
                Some(cells) => {
                    let (c, r) = cells.grid();
                    (c * n, r * n)
                }
                None => (n, n),
            },
        }
    }

    /// The face edge that keeps an input image's resolution.
    pub fn face_size(self, w: usize, h: usize) -> usize {
        match self {
            Kind::Equirect => w / 4,
            Kind::Sphere | Kind::Angular | Kind::Octahedral => w / 2,
            _ => match self.cells() {
                Some(cells) => w / cells.grid().0,
                None => w.min(h),
            },
        }
        .max(1)
    }
}

/// Detects the layout of a single image from its aspect ratio; square images are ambiguous.
pub fn detect(w: usize, h: usize) -> Result<Kind, String> {
    for k in [
        Kind::Equirect,
        Kind::Hcross,
        Kind::Vcross,
        Kind::Hstrip,
        Kind::Vstrip,
    ] {
        if k.fits(w, h) {
            return Ok(k);
        }
    }
    if w == h {
        return Err(format!(
            "a square {w}x{h} image may be a sphere map, an angular map or an octahedral map: say which with {f} sphere, {f} angular or {f} octahedral",
            f = crate::error::param("from")
        ));
    }
    Err(format!(
        "{w}x{h} has an aspect ratio no layout has (2:1 equirect, 4:3 hcross, 3:4 vcross, 6:1 hstrip, 1:6 vstrip, 1:1 sphere, angular or octahedral)"
    ))
}

/// The single-image layouts addressed by direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Projection {
    /// Equirectangular panorama, 2:1.
    Equirect,
    /// Mirror ball (sphere map), square.
    Sphere,
    /// Angular map (light probe), square.
    Angular,
    /// Octahedral map, square (see [`octahedral`]).
    Octahedral,
}

impl Projection {
    /// Normalised image coordinates (u right, v down, both 0..1) of a unit direction.
    #[inline]
    pub fn to_image(self, d: Vec3) -> Vec2 {
        match self {
            Projection::Equirect => equirect::dir_to_uv(d),
            Projection::Sphere => flip(sphere::dir_to_st(d)),
            Projection::Angular => flip(angular::dir_to_st(d)),
            Projection::Octahedral => octahedral::dir_to_uv(d),
        }
    }

    /// The unit direction at normalised image coordinates, None where the image shows nothing.
    #[inline]
    pub fn to_dir(self, u: f32, v: f32) -> Option<Vec3> {
        match self {
            Projection::Equirect => Some(equirect::uv_to_dir(u, v)),
            Projection::Sphere => sphere::st_to_dir(u, 1.0 - v).map(|d| d.normalize()),
            Projection::Angular => angular::st_to_dir(u, 1.0 - v),
            Projection::Octahedral => Some(octahedral::uv_to_dir(u, v)),
        }
    }

    /// A mirror ball or angular map: a disc in a square, its corners outside the sphere.
    pub(crate) fn is_ball(self) -> bool {
        matches!(self, Projection::Sphere | Projection::Angular)
    }

    /// Solid angle per unit texel area at continuous texel coordinates (x, y) of a w x h
    /// image (0 outside a ball): the weight of a point when a texel is cut into sub-cells.
    #[inline(always)]
    pub(crate) fn texel_density(self, w: usize, h: usize, x: f32, y: f32) -> f32 {
        match self {
            Projection::Equirect => equirect::texel_density(w, h, y),
            Projection::Sphere => sphere::texel_density(w, h, x, y),
            Projection::Angular => angular::texel_density(w, h, x, y),
            Projection::Octahedral => octahedral::texel_density(w, h, x, y),
        }
    }

    /// Solid angle of texel (x, y) of a w x h image: exact for panoramas and octahedral maps
    /// (closed forms), a fine midpoint sum on balls (see [`ball::texel_solid_angle`]).
    pub(crate) fn texel_solid_angle(self, w: usize, h: usize, x: usize, y: usize) -> f64 {
        match self {
            Projection::Equirect => equirect::texel_solid_angle(w, h, y),
            Projection::Octahedral => octahedral::texel_solid_angle(w, h, x, y),
            Projection::Sphere | Projection::Angular => {
                ball::texel_solid_angle(w, h, x, y, |px, py| self.texel_density(w, h, px, py))
            }
        }
    }

    /// Continuous texel coordinates in a w x h image of a unit direction. On a ball the point
    /// is kept inside [`ball::rim`], so the texel it names always covers some of the sphere.
    #[inline]
    pub(crate) fn position(self, w: usize, h: usize, d: Vec3) -> Vec2 {
        let mut uv = self.to_image(d);
        if self.is_ball() {
            uv = ball::inside_rim(uv, w.max(h));
        }
        Vec2::new(uv.x * w as f32, uv.y * h as f32)
    }

    /// How lookups read past the image's edges: a panorama's columns wrap, an octahedral
    /// map's edges fold onto themselves, a ball's (dark outside) edges clamp.
    pub(crate) fn edges(self) -> Edges {
        match self {
            Projection::Equirect => Edges::WrapX,
            Projection::Octahedral => Edges::Octahedral,
            Projection::Sphere | Projection::Angular => Edges::Clamp,
        }
    }
}

/// Image coordinates of every direction of a batch.
#[inline(always)]
fn project(dirs: &Dirs, u: &mut [f32], v: &mut [f32], f: impl Fn(Vec3) -> Vec2) {
    let n = dirs.len;
    for ((((u, v), &x), &y), &z) in u[..n]
        .iter_mut()
        .zip(v[..n].iter_mut())
        .zip(&dirs.x[..n])
        .zip(&dirs.y[..n])
        .zip(&dirs.z[..n])
    {
        let uv = f(Vec3::new(x, y, z));
        *u = uv.x;
        *v = uv.y;
    }
}

#[inline]
fn flip(st: Vec2) -> Vec2 {
    Vec2::new(st.x, 1.0 - st.y)
}

/// A panorama, mirror ball, angular or octahedral map prepared for lookups by direction, with
/// a pyramid of 2x2-averaged levels so a coarse output can be antialiased cheaply. Level 0 is
/// borrowed.
pub struct ImageEnv<'a> {
    projection: Projection,
    base: &'a Image,
    /// Levels 1 and up.
    pyramid: Vec<Image>,
    /// Each colour channel of level 0 is read clamped to this (see [`crate::flux`]).
    ceiling: Vec4,
}

impl<'a> ImageEnv<'a> {
    /// Prepares `levels` pyramid levels (None: down to 8 texels high).
    pub fn new(projection: Projection, base: &'a Image, levels: Option<usize>) -> ImageEnv<'a> {
        Self::below(projection, base, levels, Vec4::INFINITY)
    }

    /// `new`, with every texel read clamped to `ceiling` (per channel). Each pyramid texel is
    /// the mean of the four above weighted by the solid angles they cover, so the pyramid
    /// keeps the flux (plain means overweight a panorama's polar rows and a ball's rim).
    pub fn below(
        projection: Projection,
        base: &'a Image,
        levels: Option<usize>,
        ceiling: Vec4,
    ) -> ImageEnv<'a> {
        let mut pyramid = Vec::new();
        grow(projection, base, &mut pyramid, levels, ceiling);
        ImageEnv {
            projection,
            base,
            pyramid,
            ceiling,
        }
    }

    /// `below` for a panorama whose level 1 is already made: `first`, level 0 clamped to
    /// `ceiling` and reduced with [`equirect::row_weights`] (in the same pass that finds the
    /// peaks whose ceiling it is).
    pub(crate) fn panorama_from_level_one(
        base: &'a Image,
        first: Image,
        levels: Option<usize>,
        ceiling: Vec4,
    ) -> ImageEnv<'a> {
        let mut pyramid = vec![first];
        grow(Projection::Equirect, base, &mut pyramid, levels, ceiling);
        ImageEnv {
            projection: Projection::Equirect,
            base,
            pyramid,
            ceiling,
        }
    }

    fn level(&self, level: usize) -> &Image {
        match level {
            0 => self.base,
            l => &self.pyramid[(l - 1).min(self.pyramid.len().saturating_sub(1))],
        }
    }
}

/// Adds 2x2 solid-angle-weighted levels to `pyramid` (levels 1 and up of `base`) until it
/// holds `levels` - 1 of them or the last is 8 texels high. Level 0's reads are clamped to
/// `ceiling`.
fn grow(
    projection: Projection,
    base: &Image,
    pyramid: &mut Vec<Image>,
    levels: Option<usize>,
    ceiling: Vec4,
) {
    let want = levels.unwrap_or(usize::MAX);
    loop {
        let last = pyramid.last().unwrap_or(base);
        if last.height <= 8 || pyramid.len() + 1 >= want {
            break;
        }
        let clamp = if pyramid.is_empty() {
            ceiling
        } else {
            Vec4::INFINITY
        };
        let (w, h) = (last.width, last.height);
        let next = if projection == Projection::Equirect {
            last.downsample_2x_rows(&equirect::row_weights(w, h), clamp)
        } else {
            last.downsample_2x_weighted(
                |x, y| projection.texel_density(w, h, x as f32 + 0.5, y as f32 + 0.5),
                clamp,
            )
        };
        pyramid.push(next);
    }
}

impl ImageEnv<'_> {
    /// Reconstructs the value at normalised image coordinates `uv` of one pyramid level.
    #[inline]
    fn at(&self, mut uv: Vec2, level: usize, interp: Interp) -> Vec4 {
        let img = self.level(level);
        let edges = self.projection.edges();
        if self.projection.is_ball() {
            // Keep the taps inside the rim so the disc's dark outside never bleeds in.
            uv = ball::inside_rim(uv, img.width);
        }
        let x = uv.x * img.width as f32;
        let y = uv.y * img.height as f32;
        let ceiling = if level == 0 {
            self.ceiling
        } else {
            Vec4::INFINITY
        };
        match interp {
            Interp::Bilinear => img.bilinear_below(x, y, edges, ceiling),
            Interp::Bicubic => img.bicubic_below(x, y, edges, ceiling),
        }
    }
}

impl Environment for ImageEnv<'_> {
    #[inline]
    fn sample(&self, d: Vec3, level: usize, interp: Interp) -> Vec4 {
        self.at(self.projection.to_image(d), level, interp)
    }

    /// Image coordinates of the whole batch first (a vectorised loop: the trigonometry is
    /// most of a panorama lookup's cost), then the texel reads.
    fn sample_many(&self, dirs: &Dirs, level: usize, interp: Interp, out: &mut [Vec4]) {
        let n = dirs.len;
        let mut u = [0.0f32; BATCH];
        let mut v = [0.0f32; BATCH];
        // One loop per projection, so each is branch-free and vectorises.
        match self.projection {
            Projection::Equirect => project(dirs, &mut u, &mut v, equirect::dir_to_uv),
            Projection::Sphere => project(dirs, &mut u, &mut v, |d| flip(sphere::dir_to_st(d))),
            Projection::Angular => project(dirs, &mut u, &mut v, |d| flip(angular::dir_to_st(d))),
            Projection::Octahedral => project(dirs, &mut u, &mut v, octahedral::dir_to_uv),
        }
        if self.projection == Projection::Equirect && interp == Interp::Bilinear {
            let img = self.level(level);
            let (w, h) = (img.width as f32, img.height as f32);
            for (u, v) in u[..n].iter_mut().zip(v[..n].iter_mut()) {
                *u *= w;
                *v *= h;
            }
            let ceiling = if level == 0 {
                self.ceiling
            } else {
                Vec4::INFINITY
            };
            img.bilinear_many_below(&u[..n], &v[..n], true, ceiling, &mut out[..n]);
            return;
        }
        for ((o, &u), &v) in out[..n].iter_mut().zip(&u[..n]).zip(&v[..n]) {
            *o = self.at(Vec2::new(u, v), level, interp);
        }
    }

    fn texel_angle(&self) -> f32 {
        let img = self.base;
        match self.projection {
            Projection::Equirect => std::f32::consts::PI / img.height as f32,
            // Angle per unit radius is 2 at the ball's centre, pi everywhere on an angular map.
            Projection::Sphere => 4.0 / img.width as f32,
            Projection::Angular => std::f32::consts::TAU / img.width as f32,
            // One radian per unit of the square's half-width at its centre (up to 3 at
            // the faces' centres): the centre's texel, as for a ball.
            Projection::Octahedral => 2.0 / img.width as f32,
        }
    }

    fn levels(&self) -> usize {
        self.pyramid.len() + 1
    }
}
