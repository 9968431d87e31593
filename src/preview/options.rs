//! What to draw: the camera, the shading, Brennan's parallax and the background, checked
//! together before anything is rendered.

#![warn(missing_docs)]

use crate::error::{param, Error, Result};
use glam::{Vec3, Vec4};

/// Where the vectors come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Shading {
    /// The vertex program runs at every sample's exact point on the sphere.
    #[default]
    PerFragment,
    /// The vertex program runs at the mesh's vertices; the rasterizer interpolates.
    PerVertex,
}

/// How the `refract` and `dispersion` materials bend light (the others ignore it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum Refraction {
    /// The texts' programs: one refraction at the front surface, looked up at once.
    #[default]
    Texts,
    /// A solid sphere: Fresnel split at the front, refraction in and out at the back, the
    /// internal bounces summed (per channel for dispersion); see `preview::glass`.
    Exact,
}

/// Brennan's correction for an environment at finite distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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
    /// The environment sphere's radius, in radii of the shaded (unit) sphere.
    pub radius: f32,
    /// The environment sphere's centre, in cube-map space.
    pub center: Vec3,
    /// Which form of the correction.
    pub mode: ParallaxMode,
}

impl Parallax {
    /// The lookup vector for a ray from `p` along `v` (the texts' R or T). The zero vector
    /// (total internal reflection) stays zero.
    #[inline]
    pub(crate) fn correct(&self, v: Vec3, p: Vec3) -> Vec3 {
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
    /// Where the vertex program runs.
    pub shading: Shading,
    /// Latitude bands of the per-vertex mesh (longitude segments: twice as many).
    pub tessellation: usize,
    /// Added to every lookup's level of detail (needs a chain).
    pub lod_bias: f32,
    /// Brennan's correction for a nearby environment; None: at infinity.
    pub parallax: Option<Parallax>,
    /// Samples per pixel (1: the pixel centre).
    pub samples: usize,
    /// What fills the pixels that miss the sphere.
    pub background: Background,
    /// The texts' single refraction or the solid sphere's exact path (per fragment only), for
    /// materials whose file does not say.
    pub refraction: Refraction,
    /// A grey floor under the sphere (y = -1) where the background would show, lit by the
    /// pbr lighting: the map's irradiance facing up and the sun (`--sun`) where the sphere
    /// does not shadow it.
    pub ground: bool,
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
            refraction: Refraction::Texts,
            ground: false,
        }
    }
}

impl Options {
    /// Checks that the options describe a picture.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::usage(m));
        if self.size == 0 || self.size > 16384 {
            return bad(format!(
                "{} must be 1 to 16384 (got {})",
                param("size"),
                self.size
            ));
        }
        if !(self.fov > 0.0 && self.fov < 179.0) {
            return bad(format!(
                "{} must be between 0 and 179 degrees (got {})",
                param("fov"),
                self.fov
            ));
        }
        if !(self.distance.is_finite() && self.distance > 1.0) {
            return bad(format!(
                "{} must be more than 1, outside the unit sphere (got {})",
                param("distance"),
                self.distance
            ));
        }
        if !self.yaw.is_finite() || !self.pitch.is_finite() || !self.lod_bias.is_finite() {
            return bad(format!(
                "{}, {} and {} must be finite numbers",
                param("yaw"),
                param("pitch"),
                param("lod_bias")
            ));
        }
        if self.samples == 0 || self.samples > 256 {
            return bad(format!(
                "{} must be 1 to 256 (got {})",
                param("samples"),
                self.samples
            ));
        }
        if self.shading == Shading::PerVertex && !(2..=1024).contains(&self.tessellation) {
            return bad(format!(
                "{} must be 2 to 1024 (got {})",
                param("tessellation"),
                self.tessellation
            ));
        }
        if self.refraction == Refraction::Exact && self.shading == Shading::PerVertex {
            return bad(format!(
                "{} exact traces each fragment's path through the sphere: it needs {} per-fragment",
                param("refraction"),
                param("shading")
            ));
        }
        if let Some(p) = self.parallax {
            if !(p.radius.is_finite() && p.radius > 0.0 && p.center.is_finite()) {
                return bad(format!(
                    "{} must be positive and {} finite (got {})",
                    param("env_radius"),
                    param("env_center"),
                    p.radius
                ));
            }
            if p.mode == ParallaxMode::Exact && p.radius <= 1.0 + p.center.length() {
                return bad(format!(
                    "{} exact needs the sphere inside the environment: {} ({}) must exceed 1 + |{}| ({})",
                    param("parallax"),
                    param("env_radius"),
                    p.radius,
                    param("env_center"),
                    1.0 + p.center.length()
                ));
            }
        }
        Ok(())
    }
}
