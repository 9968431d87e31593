//! RGBM and RGBD: HDR radiance in four 8-bit channels, as cmft writes and engines still read
//! (a shared multiplier in alpha), for PNG and RGBA8 (UNORM) KTX2 and DDS.
//!
//! - RGBM, range R (6, 7, 8 or 16): L = rgb * a * R. Written with the smallest a on the 8-bit grid
//!   that holds the texel's largest channel, a = ceil(max(L) / R * 255) / 255 (at least
//!   1/255), then rgb = L / (a R) rounded: what three.js's `RGBMToLinear` and a linear-space
//!   Unity/cmft shader decode. Largest value R.
//! - RGBD, Babylon's (`toRGBD`): D = clamp(floor(max(255 / max(L), 1)) / 255, 0, 1),
//!   rgb = (L D)^(1/2.2), a = D; read back as rgb^2.2 / a (Babylon's `fromRGBD`). Largest 255.
//!
//! The stored bytes are data, never sRGB: PNGs are written and read linear.

#![warn(missing_docs)]

use super::{FileFormat, GpuFormat, WriteOptions};
use crate::cube::CubeMap;
use crate::error::{param, Error, Result};
use crate::image::Image;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::path::Path;

/// KTX2 key naming the encoding (`rgbm6`, `rgbm8`, `rgbd`): such a file reads back as HDR
/// with no flag.
pub const KTX2_KEY: &str = "cubeforge.hdrEncoding";

/// Babylon's `rgbdMaxRange`: the largest radiance RGBD holds.
pub(crate) const RGBD_MAX: f32 = 255.0;
/// Babylon's approximate sRGB curve (`toGammaSpace` without exact conversions).
const GAMMA: f32 = 2.2;

/// An 8-bit HDR encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum HdrEncoding {
    /// RGBM, L = rgb * a * 6 (cmft's, Marmoset's range).
    Rgbm6,
    /// RGBM, L = rgb * a * 7: what three.js's `RGBMLoader` decodes unless told (its RGBM7).
    Rgbm7,
    /// RGBM, L = rgb * a * 8.
    Rgbm8,
    /// RGBM, L = rgb * a * 16: three.js's RGBM16 (`RGBMLoader.setMaxRange(16)`).
    Rgbm16,
    /// Babylon's RGBD, L = rgb^2.2 / a, up to 255.
    Rgbd,
}

impl HdrEncoding {
    /// Every encoding, for messages.
    pub const ALL: [HdrEncoding; 5] = [
        HdrEncoding::Rgbm6,
        HdrEncoding::Rgbm7,
        HdrEncoding::Rgbm8,
        HdrEncoding::Rgbm16,
        HdrEncoding::Rgbd,
    ];

    /// The name on the command line and in a KTX2's metadata.
    pub fn name(self) -> &'static str {
        match self {
            HdrEncoding::Rgbm6 => "rgbm6",
            HdrEncoding::Rgbm7 => "rgbm7",
            HdrEncoding::Rgbm8 => "rgbm8",
            HdrEncoding::Rgbm16 => "rgbm16",
            HdrEncoding::Rgbd => "rgbd",
        }
    }

    /// The encoding a name (or a KTX2's metadata value) stands for.
    pub fn from_name(name: &[u8]) -> Option<HdrEncoding> {
        let name = name.strip_suffix(&[0]).unwrap_or(name);
        Self::ALL.into_iter().find(|e| e.name().as_bytes() == name)
    }

    /// The largest radiance it holds: brighter texels are clamped (and counted).
    pub fn largest(self) -> f32 {
        match self {
            HdrEncoding::Rgbm6 => 6.0,
            HdrEncoding::Rgbm7 => 7.0,
            HdrEncoding::Rgbm8 => 8.0,
            HdrEncoding::Rgbm16 => 16.0,
            HdrEncoding::Rgbd => RGBD_MAX,
        }
    }

    /// How a reader decodes `file` (of `format`), printed with the output: engines disagree
    /// on RGBM's range, and a loader told none assumes its own (three.js's RGBMLoader 7).
    pub fn loader_line(self, format: FileFormat, file: &str) -> String {
        let r = self.largest();
        match (self, format) {
            (HdrEncoding::Rgbd, _) => format!(
                "{file}: RGBD, as Babylon.js writes it: L = rgb^2.2 / a (its fromRGBD), up to 255"
            ),
            (_, FileFormat::Png) => format!(
                "{file}: RGBM range {r}, L = rgb a {r}; three.js's RGBMLoader (gone since 2025): \
                 new RGBMLoader().setMaxRange({r}).load('{file}') (it assumes 7 when not told); \
                 a shader: rgb * a * {r}.0"
            ),
            _ => format!("{file}: RGBM range {r} texels; decode in the shader: rgb * a * {r}.0"),
        }
    }

    /// One linear texel as its four bytes.
    pub fn encode(self, c: Vec4) -> [u8; 4] {
        let c = c.truncate().max(Vec3::ZERO);
        let q = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        match self {
            HdrEncoding::Rgbd => {
                let max = c.max_element().max(1e-7);
                let d = ((RGBD_MAX / max).max(1.0).floor() / 255.0).clamp(0.0, 1.0);
                let g = |v: f32| q((v * d).powf(1.0 / GAMMA));
                [g(c.x), g(c.y), g(c.z), q(d)]
            }
            _ => {
                let range = self.largest();
                let m = (c.max_element() / range * 255.0).ceil().clamp(1.0, 255.0);
                let k = 255.0 / (m * range);
                [q(c.x * k), q(c.y * k), q(c.z * k), m as u8]
            }
        }
    }

    /// Four bytes back to linear radiance (opaque). An RGBD alpha of 0, which Babylon never
    /// writes, is read as 1/255.
    pub fn decode(self, t: [u8; 4]) -> Vec4 {
        let u = |v: u8| v as f32 / 255.0;
        match self {
            HdrEncoding::Rgbd => {
                let a = t[3].max(1) as f32 / 255.0;
                let l = |v: u8| u(v).powf(GAMMA) / a;
                Vec4::new(l(t[0]), l(t[1]), l(t[2]), 1.0)
            }
            _ => {
                let k = u(t[3]) * self.largest();
                Vec4::new(u(t[0]) * k, u(t[1]) * k, u(t[2]) * k, 1.0)
            }
        }
    }

    /// An image as its encoded bytes over 255: what an 8-bit writer that stores values as
    /// data (no sRGB) turns back into exactly those bytes.
    pub fn encode_image(self, img: &Image) -> Image {
        let mut out = Image::new(img.width, img.height);
        out.pixels
            .par_iter_mut()
            .zip(&img.pixels)
            .for_each(|(o, &p)| {
                let b = self.encode(p);
                *o = Vec4::new(b[0] as f32, b[1] as f32, b[2] as f32, b[3] as f32) / 255.0;
            });
        out
    }
}

/// The options that write `format` as an encoding's bytes (data, no sRGB; the encoding
/// cleared), or the error for a file that cannot hold them: RGBM and RGBD are four 8-bit
/// channels, a PNG (not 16-bit) or a KTX2 or DDS of `rgba8`.
pub(crate) fn check(path: &Path, format: FileFormat, opts: &WriteOptions) -> Result<WriteOptions> {
    let name = opts.hdr_encoding.map_or("", HdrEncoding::name);
    let fits = match format {
        FileFormat::Png => !opts.png16,
        FileFormat::Ktx2 | FileFormat::Dds => opts.gpu_format == GpuFormat::Rgba8,
        _ => false,
    };
    if !fits {
        return Err(Error::file(
            path,
            format!(
                "{} {name} stores four 8-bit channels: write an 8-bit PNG, or a KTX2 or DDS with {} rgba8",
                param("hdr_encoding"),
                param("gpu_format")
            ),
        ));
    }
    Ok(WriteOptions {
        linear: true,
        hdr_encoding: None,
        ..*opts
    })
}

/// The PNG text keyword that names an 8-bit PNG's encoding, as [`KTX2_KEY`] does in KTX2: a
/// marked PNG reads back as radiance with no `--decode`. Other readers show the bytes.
pub const PNG_KEY: &str = KTX2_KEY;

/// An encoded file of `format` (an encoder's whole output): a PNG gains a tEXt chunk naming
/// `e` right after its IHDR chunk, where readers look for text before the pixels; other
/// formats (KTX2 and DDS carry their own metadata, or none) and anything that does not start
/// as a PNG are unchanged.
pub(crate) fn marked(format: FileFormat, png: Vec<u8>, e: HdrEncoding) -> Vec<u8> {
    // The 8-byte signature, then IHDR: length 13, type, 13 bytes, CRC.
    const IHDR_END: usize = 8 + 4 + 4 + 13 + 4;
    if format != FileFormat::Png || png.len() < IHDR_END || &png[12..16] != b"IHDR" {
        return png;
    }
    let mut body = b"tEXt".to_vec();
    body.extend_from_slice(PNG_KEY.as_bytes());
    body.push(0);
    body.extend_from_slice(e.name().as_bytes());
    let mut out = Vec::with_capacity(png.len() + body.len() + 8);
    out.extend_from_slice(&png[..IHDR_END]);
    out.extend_from_slice(&((body.len() - 4) as u32).to_be_bytes());
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
    out.extend_from_slice(&png[IHDR_END..]);
    out
}

/// The encoding a PNG's text names ([`PNG_KEY`]), read by the png crate. Only an 8-bit RGBA
/// PNG can hold one (the encodings keep a scale in alpha), so on any other the text is not
/// obeyed; two texts that name different encodings are refused, never settled by order.
pub(crate) fn png_encoding(bytes: &[u8]) -> std::result::Result<Option<HdrEncoding>, String> {
    let Ok(reader) = png::Decoder::new(std::io::Cursor::new(bytes)).read_info() else {
        return Ok(None);
    };
    let info = reader.info();
    if info.color_type != png::ColorType::Rgba || info.bit_depth != png::BitDepth::Eight {
        return Ok(None);
    }
    let mut named = info
        .uncompressed_latin1_text
        .iter()
        .filter(|t| t.keyword == PNG_KEY)
        .map(|t| t.text.as_str());
    let Some(first) = named.next() else {
        return Ok(None);
    };
    if let Some(other) = named.find(|t| *t != first) {
        return Err(format!(
            "its {PNG_KEY} texts disagree ({first:?} and {other:?}): give {} to say which",
            param("decode")
        ));
    }
    Ok(HdrEncoding::from_name(first.as_bytes()))
}

/// Every level of `cube` encoded ([`HdrEncoding::encode_image`]).
pub(crate) fn encode_cube(cube: &CubeMap, e: HdrEncoding) -> CubeMap {
    CubeMap {
        levels: cube
            .levels
            .iter()
            .map(|faces| std::array::from_fn(|f| e.encode_image(&faces[f])))
            .collect(),
    }
}

/// The encoding a KTX2's metadata names (None: none, or not a KTX2).
pub(crate) fn ktx2_encoding(bytes: &[u8]) -> Option<HdrEncoding> {
    super::ktx2::metadata(bytes)
        .iter()
        .find(|(k, _)| k == KTX2_KEY)
        .and_then(|(_, v)| HdrEncoding::from_name(v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_within_the_8_bit_grid() {
        for e in HdrEncoding::ALL {
            for v in [0.0f32, 0.01, 0.3, 1.0, 2.5, 5.9] {
                let c = Vec4::new(v, v * 0.5, v * 0.25, 1.0);
                let back = e.decode(e.encode(c));
                let err = (back - c).truncate().abs().max_element();
                // Half a step of the largest channel's grid, or of the gamma curve.
                assert!(err <= 0.02 * v.max(0.05), "{e:?} {v}: {back:?}");
            }
            assert_eq!(HdrEncoding::from_name(e.name().as_bytes()), Some(e));
        }
        // RGBM: a = ceil(max / range * 255) / 255.
        assert_eq!(
            HdrEncoding::Rgbm6.encode(Vec4::new(6.0, 3.0, 0.0, 1.0)),
            [255, 128, 0, 255]
        );
        assert_eq!(
            HdrEncoding::Rgbm8.encode(Vec4::new(1.0, 0.0, 0.0, 1.0))[3],
            32
        );
    }
}
