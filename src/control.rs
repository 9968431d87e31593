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

use crate::error::{Error, Result};
use crate::image::{luminance, srgb_to_linear, Image};
use crate::io::{self, Decoded, Limits, ReadOptions};
use glam::Vec4;
use rayon::prelude::*;
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::sync::Arc;

/// Recipes larger than this are refused before they are read.
const MAX_RECIPE_BYTES: u64 = 4 << 20;

/// A whole recipe: the output size, the LOD bias that `blur = 1` stands for, each parameter's
/// source (an absent one is the constant 0), and the packing.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    #[serde(default)]
    pub size: Option<Size>,
    #[serde(default, deserialize_with = "lod_bias")]
    pub max_lod_bias: Option<f32>,
    #[serde(default)]
    pub reflectivity: Option<Source>,
    #[serde(default)]
    pub transmittance: Option<Source>,
    #[serde(default)]
    pub blur: Option<Source>,
    #[serde(default)]
    pub fresnel: Option<Source>,
    #[serde(default)]
    pub pack: Pack,
    /// The line `size` is given on, for errors about it.
    #[serde(skip)]
    pub size_line: Option<usize>,
}

/// Width and height in texels; written `"512x256"`, or one number for a square.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Size {
    pub width: usize,
    pub height: usize,
}

impl FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Size, String> {
        let bad = || format!("size `{s}`: write WIDTHxHEIGHT (e.g. 512x256) or one number");
        let t = s.trim();
        let (w, h) = match t.split_once(['x', 'X']) {
            Some((w, h)) => (w.trim(), h.trim()),
            None => (t, t),
        };
        let width: usize = w.parse().map_err(|_| bad())?;
        let height: usize = h.parse().map_err(|_| bad())?;
        Size::new(width, height)
    }
}

impl Size {
    /// Checks that neither side is 0 nor absurd (the pixel limit is checked when baking).
    pub fn new(width: usize, height: usize) -> std::result::Result<Size, String> {
        const MAX: usize = 65536;
        if width == 0 || height == 0 || width > MAX || height > MAX {
            return Err(format!(
                "size {width}x{height}: each side must be 1 to {MAX} texels"
            ));
        }
        Ok(Size { width, height })
    }
}

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

impl<'de> Deserialize<'de> for Size {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Size, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Size;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a size such as \"512x256\", or one number for a square")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> std::result::Result<Size, E> {
                s.parse().map_err(E::custom)
            }
            fn visit_u64<E: de::Error>(self, n: u64) -> std::result::Result<Size, E> {
                let n = usize::try_from(n).unwrap_or(usize::MAX);
                Size::new(n, n).map_err(E::custom)
            }
            fn visit_i64<E: de::Error>(self, n: i64) -> std::result::Result<Size, E> {
                if n < 0 {
                    return Err(E::custom(format!("size {n}: must be positive")));
                }
                self.visit_u64(n as u64)
            }
        }
        d.deserialize_any(V)
    }
}

/// What a channel of the map holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Slot {
    Reflectivity,
    Transmittance,
    Blur,
    Fresnel,
    /// Always 0.
    Zero,
    /// Always 1.
    One,
}

impl Slot {
    pub fn name(self) -> &'static str {
        match self {
            Slot::Reflectivity => "reflectivity",
            Slot::Transmittance => "transmittance",
            Slot::Blur => "blur",
            Slot::Fresnel => "fresnel",
            Slot::Zero => "zero",
            Slot::One => "one",
        }
    }
    /// The four parameters in their default channels R, G, B, A.
    pub const PARAMETERS: [Slot; 4] = [
        Slot::Reflectivity,
        Slot::Transmittance,
        Slot::Blur,
        Slot::Fresnel,
    ];
}

/// The `[pack]` table: which parameter each channel holds; a channel left out keeps its
/// default (R reflectivity, G transmittance, B blur, A fresnel).
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Pack {
    pub r: Option<Slot>,
    pub g: Option<Slot>,
    pub b: Option<Slot>,
    pub a: Option<Slot>,
}

impl Pack {
    /// What R, G, B and A hold.
    pub fn slots(&self) -> [Slot; 4] {
        let given = [self.r, self.g, self.b, self.a];
        std::array::from_fn(|i| given[i].unwrap_or(Slot::PARAMETERS[i]))
    }
}

/// Where a parameter's values come from, and what is done to them.
#[derive(Clone, Debug)]
pub struct Source {
    pub kind: Kind,
    pub remap: Option<Remap>,
    pub invert: bool,
    pub multiply: Option<Box<Source>>,
    pub mix: Option<Box<Mix>>,
}

/// The kinds of source.
#[derive(Clone, Debug)]
pub enum Kind {
    Constant(f32),
    Image(ImageChannel),
    LinearGradient(LinearGradient),
    RadialGradient(RadialGradient),
    Checker(Checker),
    Stripes(Stripes),
    Noise(Noise),
}

/// One channel of an image file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageChannel {
    pub path: ImageFile,
    #[serde(default)]
    pub channel: Channel,
    /// Decode sRGB (painted colour) before taking the channel; 8- and 16-bit files only.
    #[serde(default)]
    pub srgb: bool,
}

/// Which channel of an image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    #[serde(alias = "red")]
    R,
    #[serde(alias = "green")]
    G,
    #[serde(alias = "blue")]
    B,
    #[serde(alias = "alpha")]
    A,
    /// Rec. 709 luminance of R, G and B.
    #[default]
    Luminance,
}

impl Channel {
    fn name(self) -> &'static str {
        match self {
            Channel::R => "r",
            Channel::G => "g",
            Channel::B => "b",
            Channel::A => "a",
            Channel::Luminance => "luminance",
        }
    }
}

/// An image read while the recipe was parsed: as stored (no sRGB decode), at full size.
#[derive(Clone)]
pub struct ImageFile {
    /// The path as the recipe writes it.
    pub name: String,
    /// Where it was read from.
    pub path: PathBuf,
    pub image: Arc<Image>,
    /// Float data (EXR, HDR, float KTX2/DDS): never sRGB-decoded.
    pub float: bool,
}

impl fmt::Debug for ImageFile {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "ImageFile({}, {}x{})",
            self.path.display(),
            self.image.width,
            self.image.height
        )
    }
}

/// 0 at `from`, 1 at `to`, clamped beyond them.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearGradient {
    #[serde(default = "origin", deserialize_with = "point")]
    pub from: [f32; 2],
    #[serde(default = "right", deserialize_with = "point")]
    pub to: [f32; 2],
}

/// 0 at `center`, 1 at `radius` and beyond.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadialGradient {
    #[serde(default = "middle", deserialize_with = "point")]
    pub center: [f32; 2],
    #[serde(default = "half", deserialize_with = "radius")]
    pub radius: f32,
}

/// `cells[0]` x `cells[1]` cells, 0 in the top-left one.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checker {
    #[serde(default = "eight_cells", deserialize_with = "cells")]
    pub cells: [u32; 2],
}

/// `count` periods, each 1 over its first `width` and 0 over the rest.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stripes {
    #[serde(default = "eight", deserialize_with = "count")]
    pub count: u32,
    #[serde(default = "half", deserialize_with = "unit")]
    pub width: f32,
    /// Degrees: 0 changes left to right, 90 top to bottom.
    #[serde(default, deserialize_with = "angle")]
    pub angle: f32,
    /// Shift, as a fraction of a period.
    #[serde(default, deserialize_with = "unit")]
    pub offset: f32,
}

/// Seeded, tiling value noise.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    #[serde(default = "eight_cells", deserialize_with = "cells")]
    pub cells: [u32; 2],
    #[serde(default)]
    pub seed: u64,
    #[serde(default = "one_octave", deserialize_with = "octaves")]
    pub octaves: u32,
    #[serde(default = "half", deserialize_with = "unit")]
    pub persistence: f32,
}

/// Levels: input range, output range, gamma.
#[derive(Clone, Debug, Deserialize)]
#[serde(try_from = "RawRemap")]
pub struct Remap {
    pub input: [f32; 2],
    pub output: [f32; 2],
    pub gamma: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRemap {
    #[serde(rename = "in", default = "unit_range", deserialize_with = "pair")]
    input: [f32; 2],
    #[serde(rename = "out", default = "unit_range", deserialize_with = "pair")]
    output: [f32; 2],
    #[serde(default = "one", deserialize_with = "gamma")]
    gamma: f32,
}

impl TryFrom<RawRemap> for Remap {
    type Error = String;
    fn try_from(r: RawRemap) -> std::result::Result<Remap, String> {
        if r.input[0] == r.input[1] {
            return Err(format!(
                "remap: `in` needs two different levels, not {} and {}",
                r.input[0], r.input[1]
            ));
        }
        Ok(Remap {
            input: r.input,
            output: r.output,
            gamma: r.gamma,
        })
    }
}

impl Remap {
    #[inline]
    pub fn apply(&self, v: f32) -> f32 {
        let [i0, i1] = self.input;
        let [o0, o1] = self.output;
        let mut t = ((v - i0) / (i1 - i0)).clamp(0.0, 1.0);
        if self.gamma != 1.0 {
            t = t.powf(1.0 / self.gamma);
        }
        o0 * (1.0 - t) + o1 * t
    }
}

/// `v * (1 - amount) + with * amount`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mix {
    pub with: Source,
    pub amount: Source,
}

fn origin() -> [f32; 2] {
    [0.0, 0.0]
}
fn right() -> [f32; 2] {
    [1.0, 0.0]
}
fn middle() -> [f32; 2] {
    [0.5, 0.5]
}
fn half() -> f32 {
    0.5
}
fn one() -> f32 {
    1.0
}
fn eight() -> u32 {
    8
}
fn eight_cells() -> [u32; 2] {
    [8, 8]
}
fn one_octave() -> u32 {
    1
}
fn unit_range() -> [f32; 2] {
    [0.0, 1.0]
}

// ---------------------------------------------------------------------------------------------
// Checked numbers. Each check runs inside the visitor, while the parser still stands on the
// value, so its error points at the value's line (serde_json places an error where it is
// raised; toml at the value being read).

/// Reads any number (integer or float) and passes it through `check`.
fn checked<'de, D: Deserializer<'de>>(
    d: D,
    check: impl Fn(f64) -> std::result::Result<f64, String>,
) -> std::result::Result<f64, D::Error> {
    struct V<F>(F);
    impl<F: Fn(f64) -> std::result::Result<f64, String>> Visitor<'_> for V<F> {
        type Value = f64;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a number")
        }
        fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<f64, E> {
            (self.0)(v).map_err(E::custom)
        }
        fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<f64, E> {
            self.visit_f64(v as f64)
        }
        fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<f64, E> {
            self.visit_f64(v as f64)
        }
    }
    d.deserialize_any(V(check))
}

fn check_unit(v: f64) -> std::result::Result<f64, String> {
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{v} is outside [0, 1]: values, levels and positions are fractions from 0 to 1"
        ))
    }
}

fn check_whole(v: f64, max: u32, what: &str) -> std::result::Result<f64, String> {
    if v.fract() == 0.0 && (1.0..=max as f64).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{v}: {what} must be a whole number from 1 to {max}"
        ))
    }
}

/// A fraction in [0, 1].
struct Unit(f32);

impl<'de> Deserialize<'de> for Unit {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Unit, D::Error> {
        checked(d, check_unit).map(|v| Unit(v as f32))
    }
}

fn unit<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    Ok(Unit::deserialize(d)?.0)
}

fn pair<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<[f32; 2], D::Error> {
    let [a, b] = <[Unit; 2]>::deserialize(d)?;
    Ok([a.0, b.0])
}

fn point<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<[f32; 2], D::Error> {
    pair(d)
}

fn ranged<'de, D: Deserializer<'de>>(
    d: D,
    ok: impl Fn(f64) -> bool,
    what: &str,
) -> std::result::Result<f32, D::Error> {
    checked(d, |v| {
        if ok(v) {
            Ok(v)
        } else {
            Err(format!("{v}: {what}"))
        }
    })
    .map(|v| v as f32)
}

fn radius<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    ranged(
        d,
        |v| v > 0.0 && v <= 2.0,
        "the radius must be above 0 and at most 2 (a fraction of the image)",
    )
}

fn gamma<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    ranged(
        d,
        |v| v > 0.0 && v <= 10.0,
        "gamma must be above 0 and at most 10",
    )
}

fn angle<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<f32, D::Error> {
    ranged(
        d,
        f64::is_finite,
        "the angle must be a finite number of degrees",
    )
}

fn lod_bias<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<Option<f32>, D::Error> {
    ranged(
        d,
        |v| (0.0..=16.0).contains(&v),
        "max_lod_bias must be from 0 to 16 (mip levels)",
    )
    .map(Some)
}

fn count<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<u32, D::Error> {
    checked(d, |v| check_whole(v, 4096, "the stripe count")).map(|v| v as u32)
}

fn octaves<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<u32, D::Error> {
    checked(d, |v| check_whole(v, 12, "octaves")).map(|v| v as u32)
}

/// Cells across and down, each 1 to 65536.
struct Cells(u32);

impl<'de> Deserialize<'de> for Cells {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Cells, D::Error> {
        checked(d, |v| check_whole(v, 65536, "a cell count")).map(|v| Cells(v as u32))
    }
}

fn cells<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<[u32; 2], D::Error> {
    let [a, b] = <[Cells; 2]>::deserialize(d)?;
    Ok([a.0, b.0])
}

// ---------------------------------------------------------------------------------------------
// Sources: a number, or a table with exactly one kind and any operations.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSource {
    #[serde(default, deserialize_with = "some_unit")]
    constant: Option<f32>,
    image: Option<ImageChannel>,
    linear_gradient: Option<LinearGradient>,
    radial_gradient: Option<RadialGradient>,
    checker: Option<Checker>,
    stripes: Option<Stripes>,
    noise: Option<Noise>,
    remap: Option<Remap>,
    #[serde(default)]
    invert: bool,
    multiply: Option<Box<Source>>,
    mix: Option<Box<Mix>>,
}

fn some_unit<'de, D: Deserializer<'de>>(d: D) -> std::result::Result<Option<f32>, D::Error> {
    unit(d).map(Some)
}

const KINDS: &str = "constant, image, linear_gradient, radial_gradient, checker, stripes or noise";

impl TryFrom<RawSource> for Source {
    type Error = String;
    fn try_from(r: RawSource) -> std::result::Result<Source, String> {
        let mut kinds: Vec<(&str, Kind)> = Vec::new();
        if let Some(v) = r.constant {
            kinds.push(("constant", Kind::Constant(v)));
        }
        if let Some(v) = r.image {
            kinds.push(("image", Kind::Image(v)));
        }
        if let Some(v) = r.linear_gradient {
            kinds.push(("linear_gradient", Kind::LinearGradient(v)));
        }
        if let Some(v) = r.radial_gradient {
            kinds.push(("radial_gradient", Kind::RadialGradient(v)));
        }
        if let Some(v) = r.checker {
            kinds.push(("checker", Kind::Checker(v)));
        }
        if let Some(v) = r.stripes {
            kinds.push(("stripes", Kind::Stripes(v)));
        }
        if let Some(v) = r.noise {
            kinds.push(("noise", Kind::Noise(v)));
        }
        if kinds.len() != 1 {
            let names: Vec<&str> = kinds.iter().map(|(n, _)| *n).collect();
            return Err(if names.is_empty() {
                format!("a source needs one of {KINDS}")
            } else {
                format!(
                    "a source has exactly one of {KINDS}, but this one has {}",
                    names.join(" and ")
                )
            });
        }
        if let Kind::LinearGradient(g) = &kinds[0].1 {
            if g.from == g.to {
                return Err("linear_gradient: `from` and `to` are the same point".into());
            }
        }
        Ok(Source {
            kind: kinds.pop().map(|(_, k)| k).unwrap_or(Kind::Constant(0.0)),
            remap: r.remap,
            invert: r.invert,
            multiply: r.multiply,
            mix: r.mix,
        })
    }
}

impl<'de> Deserialize<'de> for Source {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Source, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Source;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "a number from 0 to 1, or a table with one of {KINDS}")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> std::result::Result<Source, E> {
                check_unit(v)
                    .map(|v| Source::constant(v as f32))
                    .map_err(E::custom)
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> std::result::Result<Source, E> {
                self.visit_f64(v as f64)
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> std::result::Result<Source, E> {
                self.visit_f64(v as f64)
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> std::result::Result<Source, A::Error> {
                let raw = RawSource::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Source::try_from(raw).map_err(de::Error::custom)
            }
        }
        d.deserialize_any(V)
    }
}

// ---------------------------------------------------------------------------------------------
// Reading images while the recipe is parsed, so their errors name the recipe's line.

struct ParseContext {
    base: PathBuf,
    limits: Limits,
    cache: HashMap<PathBuf, (Arc<Image>, bool)>,
}

thread_local! {
    static CONTEXT: RefCell<Option<ParseContext>> = const { RefCell::new(None) };
}

/// Sets the folder image paths are relative to (and the size limit) for one parse.
struct ContextGuard(Option<ParseContext>);

impl ContextGuard {
    fn enter(base: &Path, limits: &Limits) -> ContextGuard {
        let ctx = ParseContext {
            base: base.to_path_buf(),
            limits: *limits,
            cache: HashMap::new(),
        };
        ContextGuard(CONTEXT.with(|c| c.replace(Some(ctx))))
    }
}

impl Drop for ContextGuard {
    fn drop(&mut self) {
        let previous = self.0.take();
        CONTEXT.with(|c| *c.borrow_mut() = previous);
    }
}

fn load_image(name: &str) -> std::result::Result<ImageFile, String> {
    if name.is_empty() {
        return Err("the image path is empty".into());
    }
    CONTEXT.with(|c| {
        let mut guard = c.borrow_mut();
        let ctx = guard.get_or_insert_with(|| ParseContext {
            base: PathBuf::from("."),
            limits: Limits::default(),
            cache: HashMap::new(),
        });
        let path = if ctx.base == Path::new(".") {
            PathBuf::from(name)
        } else {
            ctx.base.join(name)
        };
        if let Some((image, float)) = ctx.cache.get(&path) {
            return Ok(ImageFile {
                name: name.to_string(),
                path,
                image: image.clone(),
                float: *float,
            });
        }
        if !path.is_file() {
            let what = if path.exists() {
                "is not a file"
            } else {
                "image not found"
            };
            return Err(format!("{}: {what}", path.display()));
        }
        let read = ReadOptions {
            limits: ctx.limits,
            linear: true,
            as_stored: false,
        };
        let (decoded, meta) = io::read(&path, &read).map_err(|e| e.to_string())?;
        let image = match decoded {
            Decoded::Image(img) => Arc::new(img),
            Decoded::Cube(_) => {
                return Err(format!(
                    "{}: holds a cube map; a control-map source must be a 2D image",
                    path.display()
                ))
            }
        };
        ctx.cache.insert(path.clone(), (image.clone(), meta.hdr));
        Ok(ImageFile {
            name: name.to_string(),
            path,
            image,
            float: meta.hdr,
        })
    })
}

impl<'de> Deserialize<'de> for ImageFile {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<ImageFile, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = ImageFile;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("the path of an image file")
            }
            fn visit_str<E: de::Error>(self, name: &str) -> std::result::Result<ImageFile, E> {
                load_image(name).map_err(E::custom)
            }
        }
        d.deserialize_str(V)
    }
}

// ---------------------------------------------------------------------------------------------
// Loading and parsing.

/// The recipe languages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Syntax {
    Toml,
    Json,
}

impl Syntax {
    /// By the file's extension: `.toml` or `.json`.
    pub fn from_path(path: &Path) -> Option<Syntax> {
        match path.extension()?.to_str()?.to_ascii_lowercase().as_str() {
            "toml" => Some(Syntax::Toml),
            "json" => Some(Syntax::Json),
            _ => None,
        }
    }
}

/// Reads a recipe file (`.toml` or `.json`) and every image it names, relative to its folder.
pub fn load(path: &Path, limits: &Limits) -> Result<Recipe> {
    let syntax = Syntax::from_path(path)
        .ok_or_else(|| Error::file(path, "a recipe must be a .toml or .json file"))?;
    let len = std::fs::metadata(path)
        .map_err(|e| Error::file(path, io::io_msg(&e)))?
        .len();
    if len > MAX_RECIPE_BYTES {
        return Err(Error::file(
            path,
            format!("{len} bytes is too long for a recipe (at most {MAX_RECIPE_BYTES})"),
        ));
    }
    let text =
        String::from_utf8(io::read_file(path)?).map_err(|_| Error::file(path, "not UTF-8 text"))?;
    let base = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    parse(&text, syntax, path, base, limits)
}

/// Parses recipe text; `origin` names it in errors, `base` is the folder image paths are
/// relative to. Images are read here, so every problem is reported with its line.
pub fn parse(
    text: &str,
    syntax: Syntax,
    origin: &Path,
    base: &Path,
    limits: &Limits,
) -> Result<Recipe> {
    let recipe: Recipe = {
        let _context = ContextGuard::enter(base, limits);
        match syntax {
            Syntax::Toml => toml::from_str(text).map_err(|e| {
                let line = e.span().map(|s| line_of(text, s.start));
                Error::file(origin, with_line(line, e.message().trim()))
            })?,
            Syntax::Json if !text.trim_start().starts_with('{') => {
                let at = text.len() - text.trim_start().len();
                return Err(Error::file(
                    origin,
                    with_line(
                        Some(line_of(text, at)),
                        "a JSON recipe is one object: { \"size\": ..., \"reflectivity\": ... }",
                    ),
                ));
            }
            Syntax::Json => serde_json::from_str(text).map_err(|e| {
                let msg = e.to_string();
                let suffix = format!(" at line {} column {}", e.line(), e.column());
                let msg = msg.strip_suffix(&suffix).unwrap_or(&msg);
                Error::file(origin, with_line((e.line() > 0).then_some(e.line()), msg))
            })?,
        }
    };
    let mut recipe = recipe;
    if recipe.size.is_some() {
        recipe.size_line = text
            .lines()
            .position(|l| {
                let l = l.trim_start();
                let rest = l
                    .strip_prefix("\"size\"")
                    .or_else(|| l.strip_prefix("size"));
                rest.is_some_and(|r| r.trim_start().starts_with(['=', ':']))
            })
            .map(|i| i + 1);
    }
    if recipe.blur.is_some() && recipe.max_lod_bias.is_none() {
        return Err(Error::file(
            origin,
            "blur is set but max_lod_bias is not: add `max_lod_bias = <mip levels>` at the top \
             (the LOD bias that blur = 1 stands for)",
        ));
    }
    Ok(recipe)
}

/// The 1-based line holding byte `offset`.
fn line_of(text: &str, offset: usize) -> usize {
    let end = offset.min(text.len());
    text.as_bytes()[..end]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

fn with_line(line: Option<usize>, msg: &str) -> String {
    match line {
        Some(n) => format!("line {n}: {msg}"),
        None => msg.to_string(),
    }
}

// ---------------------------------------------------------------------------------------------
// Baking.

/// A baked control map and what went where.
#[derive(Clone, Debug)]
pub struct Baked {
    /// Linear data, R G B A as packed.
    pub image: Image,
    /// The LOD bias that blur = 1 stands for (0 when the recipe has none).
    pub max_lod_bias: f32,
    /// What each channel holds, R G B A.
    pub channels: [ChannelUse; 4],
    /// Parameters the recipe sets but no channel holds.
    pub warnings: Vec<String>,
}

/// What one channel holds and where it came from.
#[derive(Clone, Debug, Serialize)]
pub struct ChannelUse {
    pub holds: Slot,
    /// A one-line description of the source ("checker 8x8 cells; inverted").
    pub source: String,
}

/// The sidecar JSON written next to a map: enough for a shader or the preview to read it.
#[derive(Clone, Debug, Serialize)]
pub struct Sidecar {
    pub generator: String,
    /// The map's file name (the sidecar sits beside it).
    pub image: String,
    pub width: usize,
    pub height: usize,
    /// Always "linear": values are data, never sRGB-encoded.
    pub encoding: &'static str,
    /// `lod_bias = blur * max_lod_bias`.
    pub max_lod_bias: f32,
    /// What R, G, B and A hold.
    pub channels: SidecarChannels<Slot>,
    /// Where each channel's values came from.
    pub sources: SidecarChannels<String>,
}

#[derive(Clone, Debug, Serialize)]
pub struct SidecarChannels<T> {
    pub r: T,
    pub g: T,
    pub b: T,
    pub a: T,
}

impl Baked {
    /// The sidecar for this map, saved as `image`.
    pub fn sidecar(&self, image: &str) -> Sidecar {
        let [r, g, b, a] = self.channels.clone();
        Sidecar {
            generator: format!("cubeforge {}", env!("CARGO_PKG_VERSION")),
            image: image.to_string(),
            width: self.image.width,
            height: self.image.height,
            encoding: "linear",
            max_lod_bias: self.max_lod_bias,
            channels: SidecarChannels {
                r: r.holds,
                g: g.holds,
                b: b.holds,
                a: a.holds,
            },
            sources: SidecarChannels {
                r: r.source,
                g: g.source,
                b: b.source,
                a: a.source,
            },
        }
    }
}

impl Recipe {
    /// The source of a parameter (None: not in the recipe, the constant 0).
    pub fn source(&self, slot: Slot) -> Option<&Source> {
        match slot {
            Slot::Reflectivity => self.reflectivity.as_ref(),
            Slot::Transmittance => self.transmittance.as_ref(),
            Slot::Blur => self.blur.as_ref(),
            Slot::Fresnel => self.fresnel.as_ref(),
            Slot::Zero | Slot::One => None,
        }
    }

    /// The first image the recipe names (parameters in R G B A order, depth first).
    pub fn first_image(&self) -> Option<&ImageFile> {
        Slot::PARAMETERS
            .iter()
            .filter_map(|&s| self.source(s))
            .find_map(Source::first_image)
    }

    /// Every image the recipe names.
    pub fn images(&self) -> Vec<&ImageFile> {
        let mut out = Vec::new();
        for s in Slot::PARAMETERS.iter().filter_map(|&s| self.source(s)) {
            s.images(&mut out);
        }
        out
    }

    /// The output size: `size` if given, else the recipe's, else its first image's.
    pub fn output_size(&self, size: Option<Size>) -> Result<Size> {
        size.or(self.size)
            .or_else(|| {
                self.first_image().map(|f| Size {
                    width: f.image.width,
                    height: f.image.height,
                })
            })
            .ok_or_else(|| {
                Error::usage(
                    "the recipe gives no size and names no image: add `size = \"512x512\"` or pass --size",
                )
            })
    }

    /// Bakes the map at `size` (None: [`Recipe::output_size`]).
    pub fn bake(&self, size: Option<Size>, limits: &Limits) -> Result<Baked> {
        let size = self.output_size(size)?;
        let (w, h) = (size.width, size.height);
        limits.check(Path::new("control map"), w as u64, h as u64)?;
        let slots = self.pack.slots();
        let planes: Vec<(Slot, Vec<f32>, String)> = slots
            .iter()
            .map(|&slot| match slot {
                Slot::Zero => (slot, vec![0.0; w * h], "0".to_string()),
                Slot::One => (slot, vec![1.0; w * h], "1".to_string()),
                _ => match self.source(slot) {
                    Some(src) => (slot, src.eval(w, h), src.describe()),
                    None => (slot, vec![0.0; w * h], "0 (not in the recipe)".to_string()),
                },
            })
            .collect();
        let image = Image::from_fn(w, h, |x, y| {
            let i = y * w + x;
            Vec4::new(
                planes[0].1[i],
                planes[1].1[i],
                planes[2].1[i],
                planes[3].1[i],
            )
        });
        let warnings = Slot::PARAMETERS
            .iter()
            .filter(|&&p| self.source(p).is_some() && !slots.contains(&p))
            .map(|p| {
                format!(
                    "{} is set in the recipe but [pack] puts it in no channel",
                    p.name()
                )
            })
            .collect();
        let channels = std::array::from_fn(|i| ChannelUse {
            holds: planes[i].0,
            source: planes[i].2.clone(),
        });
        Ok(Baked {
            image,
            max_lod_bias: self.max_lod_bias.unwrap_or(0.0),
            channels,
            warnings,
        })
    }
}

impl Source {
    pub fn constant(v: f32) -> Source {
        Source {
            kind: Kind::Constant(v),
            remap: None,
            invert: false,
            multiply: None,
            mix: None,
        }
    }

    fn first_image(&self) -> Option<&ImageFile> {
        let mut v = Vec::new();
        self.images(&mut v);
        v.into_iter().next()
    }

    fn images<'a>(&'a self, out: &mut Vec<&'a ImageFile>) {
        if let Kind::Image(i) = &self.kind {
            out.push(&i.path);
        }
        if let Some(m) = &self.multiply {
            m.images(out);
        }
        if let Some(m) = &self.mix {
            m.with.images(out);
            m.amount.images(out);
        }
    }

    /// The values at `width` x `height`, rows top to bottom, each in [0, 1].
    pub fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let mut v = match &self.kind {
            Kind::Constant(c) => vec![*c; width * height],
            Kind::Image(i) => i.eval(width, height),
            Kind::LinearGradient(g) => {
                let (fx, fy) = (g.from[0] as f64, g.from[1] as f64);
                let (dx, dy) = (g.to[0] as f64 - fx, g.to[1] as f64 - fy);
                let len2 = dx * dx + dy * dy;
                plane(width, height, |u, v| {
                    (((u - fx) * dx + (v - fy) * dy) / len2).clamp(0.0, 1.0)
                })
            }
            Kind::RadialGradient(g) => {
                let (cx, cy) = (g.center[0] as f64, g.center[1] as f64);
                let r = g.radius as f64;
                plane(width, height, |u, v| {
                    ((u - cx).hypot(v - cy) / r).clamp(0.0, 1.0)
                })
            }
            Kind::Checker(c) => {
                let (cx, cy) = (c.cells[0] as f64, c.cells[1] as f64);
                plane(width, height, |u, v| {
                    let i = (u * cx).floor() as u64 + (v * cy).floor() as u64;
                    (i % 2) as f64
                })
            }
            Kind::Stripes(s) => {
                let (sin, cos) = sin_cos_degrees(s.angle as f64);
                let (n, wd, off) = (s.count as f64, s.width as f64, s.offset as f64);
                plane(width, height, |u, v| {
                    let p = (u * cos + v * sin) * n - off;
                    if p - p.floor() < wd {
                        1.0
                    } else {
                        0.0
                    }
                })
            }
            Kind::Noise(n) => plane(width, height, |u, v| n.at(u, v)),
        };
        if let Some(r) = &self.remap {
            v.par_iter_mut().for_each(|x| *x = r.apply(*x));
        }
        if self.invert {
            v.par_iter_mut().for_each(|x| *x = 1.0 - *x);
        }
        if let Some(m) = &self.multiply {
            let o = m.eval(width, height);
            v.par_iter_mut().zip(o).for_each(|(x, o)| *x *= o);
        }
        if let Some(m) = &self.mix {
            let with = m.with.eval(width, height);
            let amount = m.amount.eval(width, height);
            v.par_iter_mut()
                .zip(with)
                .zip(amount)
                .for_each(|((x, b), t)| *x = *x * (1.0 - t) + b * t);
        }
        v
    }

    /// One line saying where the values come from and what is done to them.
    pub fn describe(&self) -> String {
        let mut s = match &self.kind {
            Kind::Constant(c) => format!("{c}"),
            Kind::Image(i) => format!(
                "{} of {}{}",
                i.channel.name(),
                i.path.name,
                if i.srgb && !i.path.float {
                    " (sRGB decoded)"
                } else if i.srgb {
                    " (float data: srgb ignored)"
                } else {
                    ""
                }
            ),
            Kind::LinearGradient(g) => format!(
                "linear gradient ({}, {}) to ({}, {})",
                g.from[0], g.from[1], g.to[0], g.to[1]
            ),
            Kind::RadialGradient(g) => format!(
                "radial gradient at ({}, {}), radius {}",
                g.center[0], g.center[1], g.radius
            ),
            Kind::Checker(c) => format!("checker {}x{} cells", c.cells[0], c.cells[1]),
            Kind::Stripes(st) => format!(
                "stripes, count {} at {} deg, width {}{}",
                st.count,
                st.angle,
                st.width,
                if st.offset != 0.0 {
                    format!(", offset {}", st.offset)
                } else {
                    String::new()
                }
            ),
            Kind::Noise(n) => format!(
                "noise {}x{} cells, seed {}{}",
                n.cells[0],
                n.cells[1],
                n.seed,
                if n.octaves > 1 {
                    format!(", {} octaves x {}", n.octaves, n.persistence)
                } else {
                    String::new()
                }
            ),
        };
        if let Some(r) = &self.remap {
            s += &format!(
                ", remapped {}..{} to {}..{}",
                r.input[0], r.input[1], r.output[0], r.output[1]
            );
            if r.gamma != 1.0 {
                s += &format!(" gamma {}", r.gamma);
            }
        }
        if self.invert {
            s += ", inverted";
        }
        if let Some(m) = &self.multiply {
            s += &format!(", times [{}]", m.describe());
        }
        if let Some(m) = &self.mix {
            s += &format!(
                ", mixed with [{}] by [{}]",
                m.with.describe(),
                m.amount.describe()
            );
        }
        s
    }
}

/// Fills a plane from `f(u, v)` at texel centres, rows in parallel.
fn plane(width: usize, height: usize, f: impl Fn(f64, f64) -> f64 + Sync) -> Vec<f32> {
    let mut out = vec![0.0f32; width * height];
    if width == 0 {
        return out;
    }
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let v = (y as f64 + 0.5) / height as f64;
        for (x, p) in row.iter_mut().enumerate() {
            let u = (x as f64 + 0.5) / width as f64;
            *p = f(u, v) as f32;
        }
    });
    out
}

/// Exact at multiples of 90 degrees, so axis-aligned stripes have no drift.
fn sin_cos_degrees(deg: f64) -> (f64, f64) {
    let a = deg.rem_euclid(360.0);
    if a == 0.0 {
        (0.0, 1.0)
    } else if a == 90.0 {
        (1.0, 0.0)
    } else if a == 180.0 {
        (0.0, -1.0)
    } else if a == 270.0 {
        (-1.0, 0.0)
    } else {
        a.to_radians().sin_cos()
    }
}

impl ImageChannel {
    /// The channel at full size, decoded as asked and clamped to [0, 1], then resized.
    fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let img = &self.path.image;
        let decode = self.srgb && !self.path.float;
        let tf = |v: f32| if decode { srgb_to_linear(v) } else { v };
        let channel = self.channel;
        let values: Vec<f32> = img
            .pixels
            .par_iter()
            .map(|p| {
                let v = match channel {
                    Channel::R => tf(p.x),
                    Channel::G => tf(p.y),
                    Channel::B => tf(p.z),
                    Channel::A => p.w,
                    Channel::Luminance => luminance(Vec4::new(tf(p.x), tf(p.y), tf(p.z), 0.0)),
                };
                v.clamp(0.0, 1.0)
            })
            .collect();
        resize(&values, img.width, img.height, width, height)
    }
}

/// Resizes a plane: each axis on its own, with an area (box) filter when it shrinks and
/// bilinear interpolation between texel centres (edges clamped) when it grows.
pub fn resize(src: &[f32], sw: usize, sh: usize, dw: usize, dh: usize) -> Vec<f32> {
    if sw == dw && sh == dh {
        return src.to_vec();
    }
    // Horizontal pass: sh rows of dw.
    let taps_x = taps(sw, dw);
    let mut mid = vec![0.0f32; dw * sh];
    if dw > 0 {
        mid.par_chunks_mut(dw).enumerate().for_each(|(y, row)| {
            let s = &src[y * sw..(y + 1) * sw];
            for (x, out) in row.iter_mut().enumerate() {
                *out = taps_x[x]
                    .iter()
                    .map(|&(i, wt)| s[i] as f64 * wt)
                    .sum::<f64>() as f32;
            }
        });
    }
    // Vertical pass: dh rows of dw.
    let taps_y = taps(sh, dh);
    let mut out = vec![0.0f32; dw * dh];
    if dw > 0 {
        out.par_chunks_mut(dw).enumerate().for_each(|(y, row)| {
            for (x, o) in row.iter_mut().enumerate() {
                *o = taps_y[y]
                    .iter()
                    .map(|&(j, wt)| mid[j * dw + x] as f64 * wt)
                    .sum::<f64>() as f32;
            }
        });
    }
    out
}

/// For each output index along an axis, the source indices and their weights.
fn taps(src: usize, dst: usize) -> Vec<Vec<(usize, f64)>> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|i| {
            if dst == src {
                vec![(i, 1.0)]
            } else if dst < src {
                // The source interval [i * scale, (i + 1) * scale), each texel by its overlap.
                let (a, b) = (i as f64 * scale, (i + 1) as f64 * scale);
                let first = a.floor() as usize;
                let last = (b.ceil() as usize).min(src);
                (first..last)
                    .filter_map(|j| {
                        let overlap = (b.min(j as f64 + 1.0) - a.max(j as f64)) / scale;
                        (overlap > 0.0).then_some((j, overlap))
                    })
                    .collect()
            } else {
                let x = (i as f64 + 0.5) * scale - 0.5;
                let x0 = x.floor();
                let f = x - x0;
                let clamp = |j: f64| j.clamp(0.0, src as f64 - 1.0) as usize;
                vec![(clamp(x0), 1.0 - f), (clamp(x0 + 1.0), f)]
            }
        })
        .collect()
}

impl Noise {
    /// The value at (u, v): octaves of smoothly interpolated lattice values, in [0, 1].
    pub fn at(&self, u: f64, v: f64) -> f64 {
        let mut sum = 0.0;
        let mut total = 0.0;
        let mut weight = 1.0;
        for octave in 0..self.octaves {
            let cx = (self.cells[0] as u64) << octave;
            let cy = (self.cells[1] as u64) << octave;
            let (px, py) = (u * cx as f64, v * cy as f64);
            let (x0, y0) = (px.floor(), py.floor());
            let (fx, fy) = (smoother(px - x0), smoother(py - y0));
            let (ix, iy) = (x0 as u64 % cx, y0 as u64 % cy);
            let (ix1, iy1) = ((ix + 1) % cx, (iy + 1) % cy);
            let l = |x, y| lattice(self.seed, octave, x, y);
            let top = l(ix, iy) * (1.0 - fx) + l(ix1, iy) * fx;
            let bottom = l(ix, iy1) * (1.0 - fx) + l(ix1, iy1) * fx;
            sum += weight * (top * (1.0 - fy) + bottom * fy);
            total += weight;
            weight *= self.persistence as f64;
        }
        (sum / total).clamp(0.0, 1.0)
    }
}

/// Quintic smoothstep: 6t^5 - 15t^4 + 10t^3 (zero first and second derivative at 0 and 1).
#[inline]
fn smoother(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The noise value at lattice point (x, y) of an octave: a hash of the point and the seed,
/// in [0, 1]. The same inputs give the same value on every run and machine.
pub fn lattice(seed: u64, octave: u32, x: u64, y: u64) -> f64 {
    let mut h = mix64(seed ^ 0x9E37_79B9_7F4A_7C15);
    h = mix64(h ^ x.wrapping_mul(0xA24B_AED4_963E_E407));
    h = mix64(h ^ y.wrapping_mul(0x9FB2_1C65_1E98_DF25));
    h = mix64(h ^ (octave as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93));
    (h >> 11) as f64 / ((1u64 << 53) - 1) as f64
}

/// The splitmix64 finaliser.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toml(text: &str) -> Result<Recipe> {
        parse(
            text,
            Syntax::Toml,
            Path::new("r.toml"),
            Path::new("."),
            &Limits::default(),
        )
    }

    #[test]
    fn taps_sum_to_one() {
        for (s, d) in [(7, 3), (3, 7), (512, 100), (5, 4), (1, 9), (9, 1)] {
            for t in taps(s, d) {
                let sum: f64 = t.iter().map(|p| p.1).sum();
                assert!((sum - 1.0).abs() < 1e-12, "{s}->{d}: {sum}");
                assert!(t.iter().all(|p| p.0 < s));
            }
        }
    }

    #[test]
    fn lines_of_errors() {
        let e = toml("size = 4\n\n[blur]\nconstant = 2\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4"), "{e}");
        let e = toml("size = 4\nroughness = 1\n").unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("roughness"), "{e}");
    }

    #[test]
    fn lattice_is_in_range() {
        for i in 0..1000 {
            let v = lattice(i, 0, i * 7, i * 13);
            assert!((0.0..=1.0).contains(&v));
        }
    }
}
