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
//! TOML (or the same structure in JSON, chosen by the file's extension). Every parameter is a
//! *source*: a number (a constant), or a table naming exactly one kind of source and,
//! optionally, operations on it.
//!
//! ```toml
//! size = "512x512"          # WIDTHxHEIGHT, or one number for a square; --size overrides
//! max_lod_bias = 6.0        # blur = 1 means this LOD bias (needed when blur is set)
//!
//! reflectivity = 0.9        # a constant
//!
//! [transmittance]           # a channel of an image, resized to the output
//! image = { path = "masks/glass.png", channel = "r" }
//!
//! [blur]                    # a procedural pattern with operations
//! linear_gradient = { from = [0, 0], to = [0, 1] }
//! remap = { in = [0.2, 0.8], out = [0, 1], gamma = 1.5 }
//!
//! [fresnel]
//! checker = { cells = [8, 8] }
//! invert = true
//! mix = { with = 1, amount = { noise = { cells = [4, 4], seed = 7 } } }
//!
//! # [pack]                  # optional: which parameter each channel holds, e.g.
//! # a = "one"               # an opaque alpha when there is no Fresnel mask
//! ```
//!
//! Sources (positions are fractions of the image, `[u, v]`, u to the right, v down, texel
//! centres at `(x + 0.5) / width`):
//! - `constant = v`, or just a number.
//! - `image = { path, channel = "luminance", srgb = false }`: `channel` is `r`, `g`, `b`, `a` or
//!   `luminance` (Rec. 709); the path is relative to the recipe. 8- and 16-bit files are read as
//!   data unless `srgb = true`, which decodes painted colour (float files are always linear).
//!   The channel is resized to the output with an area (box) filter when shrinking and bilinear
//!   interpolation when enlarging, each axis on its own, and clamped to [0, 1].
//! - `linear_gradient = { from = [0, 0], to = [1, 0] }`: 0 at `from` to 1 at `to`, clamped.
//! - `radial_gradient = { center = [0.5, 0.5], radius = 0.5 }`: 0 at the centre to 1 at
//!   `radius` (a fraction of the image, up to 2) and beyond.
//! - `checker = { cells = [8, 8] }`: 0 in the top-left cell, 1 in the next.
//! - `stripes = { count = 8, width = 0.5, angle = 0, offset = 0 }`: `count` periods across the
//!   image, each 1 over its first `width` and 0 over the rest; `angle` in degrees (0: the value
//!   changes left to right, 90: top to bottom); `offset` shifts by a fraction of a period.
//! - `noise = { cells = [8, 8], seed = 0, octaves = 1, persistence = 0.5 }`: value noise, a
//!   hash of the integer lattice point and the seed, interpolated smoothly (quintic), in [0, 1];
//!   it tiles, and each further octave has twice the cells and `persistence` times the weight.
//!
//! Operations, applied in this order whatever their order in the file:
//! `remap = { in = [lo, hi], out = [lo, hi], gamma = 1 }` (levels: `t = (v - in.lo) /
//! (in.hi - in.lo)` clamped, `t^(1/gamma)`, then from `out.lo` to `out.hi`; gamma above 1
//! brightens like the middle slider of Levels), `invert = true` (`1 - v`), `multiply = source`,
//! `mix = { with = source, amount = source }` (`v * (1 - amount) + with * amount`).
//!
//! Every value is checked as it is read: a missing image, an unknown key, channel or parameter,
//! a fraction outside [0, 1] are errors naming the recipe's line.

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
