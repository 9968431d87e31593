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
//! `Refraction::Exact` replaces the texts' single refraction of the `refract` and
//! `dispersion` materials with the path through the solid sphere ([`glass`]), per fragment.
//!
//! The `pbr` material is not the texts': glTF's metallic-roughness parameters shaded with the
//! split-sum approximation engines use ([`pbr`]), its level chosen by roughness; with
//! `--sun` the map's sun is taken out and shone back as a directional light ([`sun`]).
//!
//! Level of detail: with a prefiltered chain, each lookup picks the level a GPU would, from
//! the derivatives of its lookup vector across neighbouring pixels projected on the selected
//! cube face (the OpenGL scale factor rho in texels, lod = log2 rho), plus `--lod-bias` and
//! the control map's blur, trilinear between levels.

#![warn(missing_docs)]

pub mod camera;
pub mod glass;
pub mod grid;
pub mod material;
pub mod pbr;
pub mod sphere;
pub mod sun;

// The renderer in the order a frame flows: what to draw (options), the texts' programs
// (shader), the per-vertex rasterizer (raster), the loop over pixels (render), and reading
// what it shows (load). The public items are re-exported here: callers name `preview::X`.
mod load;
mod options;
mod raster;
mod render;
mod shader;

pub(crate) use load::control_sidecar;
pub use load::{load_environment, read_control, read_texture, LoadedEnv};
pub use options::{Background, Options, Parallax, ParallaxMode, Refraction, Shading};
pub use render::{render, render_lit, render_with_progress};
pub use shader::{Control, Shader, Surface, Varyings};
