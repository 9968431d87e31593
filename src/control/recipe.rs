//! The recipe itself: its size, the parameters' sources and the channel packing, as parsed.
//! Kept apart from parsing and baking so the types read like the file format they mirror.

#![warn(missing_docs)]

use super::image::ImageFile;
use super::numbers::lod_bias;
use super::source::Source;
use crate::error::{Error, Result};
use serde::de::{self, Deserializer, Visitor};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// A whole recipe: the output size, the LOD bias that `blur = 1` stands for, each parameter's
/// source (an absent one is the constant 0), and the packing.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Recipe {
    /// The map's size; None takes the first image's (`--size` overrides both).
    #[serde(default)]
    pub size: Option<Size>,
    /// The LOD bias that `blur = 1` stands for; needed when blur is set.
    #[serde(default, deserialize_with = "lod_bias")]
    pub max_lod_bias: Option<f32>,
    /// The reflectivity parameter's source (0 matte, 1 chrome).
    #[serde(default)]
    pub reflectivity: Option<Source>,
    /// The transmittance parameter's source (0 opaque, 1 clear).
    #[serde(default)]
    pub transmittance: Option<Source>,
    /// The blur parameter's source (a fraction of `max_lod_bias`).
    #[serde(default)]
    pub blur: Option<Source>,
    /// The fresnel parameter's source (1 where the Fresnel term applies).
    #[serde(default)]
    pub fresnel: Option<Source>,
    /// Which parameter each channel holds (the `[pack]` table).
    #[serde(default)]
    pub pack: Pack,
    /// The line `size` is given on, for errors about it.
    #[serde(skip)]
    pub size_line: Option<usize>,
}

/// Width and height in texels; written `"512x256"`, or one number for a square.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Size {
    /// Texels across, 1 to 65536.
    pub width: usize,
    /// Texels down, 1 to 65536.
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
    /// `lerp(decal, reflected, reflectivity)`: 0 matte, 1 chrome; R by default.
    Reflectivity,
    /// `lerp(decal, refracted, transmittance)`: 0 opaque, 1 clear; G by default.
    Transmittance,
    /// LOD bias of the environment lookup as a fraction of `max_lod_bias`; B by default.
    Blur,
    /// Fresnel mask: 1 where the Fresnel term applies; A by default.
    Fresnel,
    /// Always 0.
    Zero,
    /// Always 1.
    One,
}

impl Slot {
    /// The name a recipe and the sidecar use (`reflectivity`, ..., `zero`, `one`).
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
    pub(crate) const PARAMETERS: [Slot; 4] = [
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
    /// What R holds; None: reflectivity.
    pub r: Option<Slot>,
    /// What G holds; None: transmittance.
    pub g: Option<Slot>,
    /// What B holds; None: blur.
    pub b: Option<Slot>,
    /// What A holds; None: fresnel.
    pub a: Option<Slot>,
}

impl Pack {
    /// What R, G, B and A hold.
    pub(crate) fn slots(&self) -> [Slot; 4] {
        let given = [self.r, self.g, self.b, self.a];
        std::array::from_fn(|i| given[i].unwrap_or(Slot::PARAMETERS[i]))
    }
}

impl Recipe {
    /// The source of a parameter (None: not in the recipe, the constant 0).
    pub(crate) fn source(&self, slot: Slot) -> Option<&Source> {
        match slot {
            Slot::Reflectivity => self.reflectivity.as_ref(),
            Slot::Transmittance => self.transmittance.as_ref(),
            Slot::Blur => self.blur.as_ref(),
            Slot::Fresnel => self.fresnel.as_ref(),
            Slot::Zero | Slot::One => None,
        }
    }

    /// The first image the recipe names (parameters in R G B A order, depth first).
    pub(crate) fn first_image(&self) -> Option<&ImageFile> {
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
                Error::usage(format!(
                    "the recipe gives no size and names no image: add `size = \"512x512\"` or pass {}",
                    crate::error::param("size")
                ))
            })
    }
}
