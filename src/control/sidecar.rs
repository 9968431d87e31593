//! The sidecar JSON written beside a map: what each channel holds and what blur = 1 means, so
//! a shader or `cubeforge preview` can read the map without the recipe.

#![warn(missing_docs)]

use super::bake::Baked;
use super::recipe::Slot;
use serde::Serialize;

/// The sidecar JSON written next to a map: enough for a shader or the preview to read it.
#[derive(Clone, Debug, Serialize)]
pub struct Sidecar {
    /// `cubeforge` and its version, for tracing a map back to what wrote it.
    pub generator: String,
    /// The map's file name (the sidecar sits beside it).
    pub image: String,
    /// The map's width in texels.
    pub width: usize,
    /// The map's height in texels.
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

/// One value per channel, written as a JSON object with keys `r`, `g`, `b`, `a`.
#[derive(Clone, Debug, Serialize)]
pub struct SidecarChannels<T> {
    /// Red.
    pub r: T,
    /// Green.
    pub g: T,
    /// Blue.
    pub b: T,
    /// Alpha.
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
