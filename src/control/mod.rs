//! Control maps: textures whose texels hold shading parameters instead of colour (section
//! 7.2.4 of the source text), baked from a recipe an artist can write without knowing how
//! environment mapping works.
//!
//! # What the channels mean
//!
//! By default a control map packs four parameters, each a fraction in [0, 1], stored as linear
//! data (never sRGB):
//!
//! | channel | parameter       | meaning                                                        |
//! |---------|-----------------|----------------------------------------------------------------|
//! | R       | `reflectivity`  | `lerp(decal, reflected, reflectivity)`: 0 matte, 1 chrome      |
//! | G       | `transmittance` | `lerp(decal, refracted, transmittance)`: 0 opaque, 1 clear     |
//! | B       | `blur`          | LOD bias of the environment lookup: `blur * max_lod_bias`      |
//! | A       | `fresnel`       | Fresnel mask: 1 where the Fresnel term applies, 0 where not    |
//!
//! `max_lod_bias` is stored in the recipe and in the sidecar JSON written next to the map. A
//! `[pack]` table puts any parameter (or `zero` or `one`) in any channel.
//!
//! # Recipes
//!
//! TOML (or the same structure in JSON, chosen by the file's extension): every parameter is a
//! number or a table naming one *source* (constant, image, linear_gradient, radial_gradient,
//! checker, stripes, noise) and, optionally, operations on it (remap, invert, multiply, mix).
//! The format is described in one place, the repository's `docs/control-maps.md`, with worked
//! recipes in `fixtures/control/`; [`Recipe`] and [`Source`] are its types, [`load`] reads a
//! file. Every value is checked as it is read: a missing image, an unknown key, channel or
//! parameter, a fraction outside [0, 1] are errors naming the recipe's line.

#![warn(missing_docs)]

// One file per step of the way from recipe to map: the recipe's types, its parsing, the
// sources (numbers checked as read, patterns, image channels and their resizing), baking and
// the sidecar. Everything public is re-exported here, so callers name `control::X`.
mod bake;
mod image;
mod numbers;
mod parse;
mod pattern;
mod recipe;
mod resize;
mod sidecar;
mod source;

pub use bake::{Baked, ChannelUse};
pub use image::{Channel, ImageChannel, ImageFile};
pub use parse::{load, parse, Syntax};
pub use pattern::{lattice, Checker, LinearGradient, Noise, RadialGradient, Stripes};
pub use recipe::{Pack, Recipe, Size, Slot};
pub use resize::resize;
pub use sidecar::{Sidecar, SidecarChannels};
pub use source::{Kind, Mix, Remap, Source};
