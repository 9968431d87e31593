//! UltraHDR: a JPEG whose picture is an SDR rendition (tone-mapped, sRGB) and which carries a
//! second JPEG, the gain map, with the metadata (Adobe's `hdrgm` XMP and ISO 21496-1) that
//! rebuilds the radiance from the two: `hdr = (sdr + k) * 2^g - k` per channel, where `g`
//! runs from the map's smallest to its largest log2 gain over the gain map's 0..255. Every
//! JPEG reader shows the SDR picture; three.js, Android and Chrome rebuild the radiance.
//!
//! The container (MPF, XMP, ISO 21496-1) is the `ultrahdr-rs` crate's; the JPEG codec is the
//! `image` crate's. The gain range is the image's own: the largest gain is the brightest
//! texel's over its SDR value, so a sun survives whole.

#![warn(missing_docs)]

use super::guard::caught;
use super::{raster, Decoded, FileFormat, Limits, Meta, ReadOptions};
use crate::error::{Error, Result};
use crate::image::{linear_to_srgb, ColorSpace, Image};
use ::image::codecs::jpeg::JpegEncoder;
use ::image::{ExtendedColorType, ImageEncoder};
use glam::Vec4;
use rayon::prelude::*;
use std::path::Path;
use ultrahdr_rs::{ColorGamut, Decoder, GainMapMetadata};

mod fit;
mod meta;

/// How gain-map values become radiance: per channel, the log2 gain runs from `lo` to `hi` over
/// the map's 0..1 raised to 1/`gamma`, and `hdr = (sdr + k_sdr) * 2^gain - k_hdr`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Gains {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    pub gamma: [f64; 3],
    pub k_sdr: [f64; 3],
    pub k_hdr: [f64; 3],
}

/// Whose arithmetic rebuilds the radiance. The format's (ISO 21496-1, Android's and Chrome's
/// readers, cubeforge's), or three.js's `UltraHDRLoader` (r187), which applies the gain to
/// the sRGB-encoded values and linearizes after: `srgb((sdr8 + 64 k) 2^(w g) - 64 k)` with
/// `w = log2(1.8^(capacity/2)) / capacity` (0.424) and integer steps below 1024, within
/// 2-6% of the format's (the sign depends on the gain). A file fitted to three.js carries
/// [`THREE_MARK`], by which cubeforge reads it three.js's way too.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reader {
    /// ISO 21496-1, as written.
    #[default]
    Format,
    /// three.js's `UltraHDRLoader`.
    Three,
}

/// The JPEG comment by which a gain map fitted to three.js's arithmetic says so.
pub const THREE_MARK: &[u8] = b"cubeforge: gain map fitted to three.js UltraHDRLoader (r187)";

impl Gains {
    fn of(meta: &GainMapMetadata) -> Gains {
        Gains {
            lo: meta.gain_map_min,
            hi: meta.gain_map_max,
            gamma: meta.gamma,
            k_sdr: meta.base_offset,
            k_hdr: meta.alternate_offset,
        }
    }

    /// Channel `c`'s radiance from its SDR value (linear) and gain-map value (0..1).
    #[inline]
    fn radiance(&self, c: usize, sdr: f32, code: f32) -> f32 {
        let t = (code.clamp(0.0, 1.0) as f64).powf(1.0 / self.gamma[c]);
        let log = self.lo[c] + (self.hi[c] - self.lo[c]) * t;
        let v = (sdr as f64 + self.k_sdr[c]) * log.exp2() - self.k_hdr[c];
        (v.max(0.0) as f32).min(1e28)
    }

    /// Channel `c`'s radiance as three.js rebuilds it (see [`Reader::Three`]).
    #[inline]
    fn radiance_three(&self, c: usize, sdr: f32, code: f32) -> f32 {
        let capacity = self.hi[0].max(1e-6);
        let weight = ((1.8f64.powf(capacity * 0.5)).log2() / capacity).clamp(0.0, 1.0);
        let t = (code.clamp(0.0, 1.0) as f64).powf(1.0 / self.gamma[c]);
        let log = self.lo[c] + (self.hi[c] - self.lo[c]) * t;
        let s8 = (linear_to_srgb(sdr) * 255.0).round() as f64;
        // Offsets from the XMP, in 8-bit steps: `OffsetSDR / (1/64)`.
        let v = (s8 + self.k_sdr[c] * 64.0) * (log * weight).exp2() - self.k_hdr[c] * 64.0;
        let lin = if v < 10.31475 {
            v * 0.000303527
        } else if v < 1024.0 {
            (v.floor() * 0.003717127 + 0.0521327014).powf(2.4)
        } else {
            (v * 0.003717127 + 0.0521327014).powf(2.4)
        };
        lin.clamp(0.0, 65504.0) as f32
    }

    /// The radiance of `sdr` (linear) under the gain map `map` (values over 255), stretched
    /// bilinearly over the picture where it is smaller, as `reader` rebuilds it.
    pub(crate) fn apply(&self, sdr: &Image, map: &Image, reader: Reader) -> Image {
        let mut out = sdr.clone();
        self.apply_in_place(&mut out, map, reader);
        out
    }

    /// [`Gains::apply`] in `img`'s own texels (a reader holds no second picture). A gain map
    /// the picture's size is read code by code, through a table of the 256 gains.
    fn apply_in_place(&self, img: &mut Image, map: &Image, reader: Reader) {
        let f = match reader {
            Reader::Format => Gains::radiance,
            Reader::Three => Gains::radiance_three,
        };
        let w = img.width;
        if reader == Reader::Format && (map.width, map.height) == (w, img.height) {
            let table: Vec<[f64; 3]> = (0..256)
                .map(|code| {
                    [0, 1, 2].map(|c| {
                        let t = (code as f64 / 255.0).powf(1.0 / self.gamma[c]);
                        (self.lo[c] + (self.hi[c] - self.lo[c]) * t).exp2()
                    })
                })
                .collect();
            let k = (self.k_sdr, self.k_hdr);
            img.pixels
                .par_iter_mut()
                .zip(map.pixels.par_iter())
                .for_each(|(o, g)| {
                    let ch = |c: usize, sdr: f32, code: f32| {
                        let gain = table[(code.clamp(0.0, 1.0) * 255.0).round() as usize][c];
                        let v = (sdr as f64 + k.0[c]) * gain - k.1[c];
                        (v.max(0.0) as f32).min(1e28)
                    };
                    *o = Vec4::new(ch(0, o.x, g.x), ch(1, o.y, g.y), ch(2, o.z, g.z), 1.0);
                });
            return;
        }
        let sx = map.width as f32 / w as f32;
        let sy = map.height as f32 / img.height as f32;
        img.pixels
            .par_chunks_mut(w)
            .enumerate()
            .for_each(|(y, row)| {
                for (x, o) in row.iter_mut().enumerate() {
                    let g = map.bilinear((x as f32 + 0.5) * sx, (y as f32 + 0.5) * sy, false);
                    let s = *o;
                    *o = Vec4::new(
                        f(self, 0, s.x, g.x),
                        f(self, 1, s.y, g.y),
                        f(self, 2, s.z, g.z),
                        1.0,
                    );
                }
            });
    }
}

/// The offset added to both renditions before the ratio is taken (the format's usual 1/64):
/// it keeps the gain of black texels finite.
const OFFSET: f64 = 1.0 / 64.0;
/// Bytes a texel of an UltraHDR output takes while it is encoded, beyond the image itself: the
/// SDR picture and its decode, the gain targets, the decoded gain map, the light it rebuilds
/// and the neighbourhood sums (for the jobs' memory plans).
pub const ENCODE_BYTES_PER_TEXEL: u64 = 112;

/// JPEG quality of the SDR picture, and of the gain map (its steps are stops of light, so it
/// is kept finer). Chosen on the real test panoramas at 512 x 256, the hardest case (a sun in
/// a few texels): the largest base quality that keeps the sunniest under an eighth of its
/// `.hdr`, with three.js reading every one's light within 1% (at 72 it was 1/7.9).
const BASE_QUALITY: u8 = 71;
const GAIN_QUALITY: u8 = 85;
/// Rounds of fitting the gain map to the light through its own JPEG ([`fit::fit`]).
const ROUNDS: usize = 12;
/// What writing a gain map kept of the radiance, as the reader it was fitted to rebuilds it.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GainStats {
    /// The largest radiance the gain range rebuilds (over an SDR white).
    pub largest_kept: f32,
    /// The brightest channel value in the source.
    pub brightest: f32,
    /// The gain map's range in stops (log2 of the smallest and largest gain).
    pub stops: (f32, f32),
    /// The rebuilt radiance's total per channel against the source's, minus 1.
    pub flux_error: [f64; 3],
    /// The file's size in bytes.
    pub bytes: usize,
}

impl GainStats {
    /// One line for a report.
    pub fn summary(&self) -> String {
        let pct = |v: f64| format!("{:+.2}%", v * 100.0);
        let e = self.flux_error;
        format!(
            "UltraHDR: gains 2^{:.2} to 2^{:.2}, radiance kept up to {} (the brightest texel: {}); \
             totals read back R {} G {} B {}; {} KB",
            self.stops.0,
            self.stops.1,
            short(self.largest_kept),
            short(self.brightest),
            pct(e[0]),
            pct(e[1]),
            pct(e[2]),
            self.bytes.div_ceil(1024)
        )
    }
}

fn short(v: f32) -> String {
    if v >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

/// Whether `bytes` is a JPEG that carries a gain map, or says it does (its container
/// directory names one): a file cut short is then refused, not read as its SDR picture.
pub fn has_gain_map(bytes: &[u8]) -> bool {
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return false;
    }
    let head = &bytes[..bytes.len().min(1 << 16)];
    let says = |needle: &[u8]| head.windows(needle.len()).any(|w| w == needle);
    says(b"Item:Semantic=\"GainMap\"")
        || says(b"hdr-gain-map")
        || meta::declares_iso(head)
        || caught(|| {
            Decoder::new(bytes).is_ok_and(|d| {
                d.is_ultrahdr() && d.gainmap_jpeg().is_some() && meta::of(&d).is_ok()
            })
        })
        .unwrap_or(false)
}

/// What an image's light is, per channel, as the gain-map fit weighs it: the caller's
/// measure (an equirect's texels by their solid angle, `flux`'s), above the codec.
pub type Light = dyn Fn(&Image) -> [f64; 3] + Sync;

/// Encodes `img` (linear radiance) as an UltraHDR JPEG over `base`, its SDR picture (sRGB
/// RGB8, made above `io` by a tone curve), its gain map fitted to `reader`'s arithmetic; the
/// statistics are those of the file as that reader rebuilds it, its light measured by
/// `light`.
pub fn encode(
    img: &Image,
    base: &[u8],
    reader: Reader,
    light: &Light,
) -> std::result::Result<(Vec<u8>, GainStats), String> {
    let (w, h) = (img.width as u32, img.height as u32);
    let mut base_jpeg = jpeg(base, w, h, BASE_QUALITY)?;
    // The gain is taken against the SDR picture as a reader decodes it, so the base's JPEG
    // error is not carried into the radiance.
    let sdr = decode_jpeg(&base_jpeg, false, &Limits::default()).map_err(|e| inner(&e))?;
    let fitted = fit::fit(img, &sdr, reader, light, ROUNDS, |codes| {
        jpeg(codes, w, h, GAIN_QUALITY)
    })?;
    let (lo, hi) = (fitted.gains.lo[0], fitted.gains.hi[0]);
    if reader == Reader::Three {
        // A comment segment right after SOI: FF FE, its length, the text.
        let len = (THREE_MARK.len() + 2) as u16;
        let mut seg = vec![0xFF, 0xFE];
        seg.extend_from_slice(&len.to_be_bytes());
        seg.extend_from_slice(THREE_MARK);
        base_jpeg.splice(2..2, seg);
    }
    let mut meta = GainMapMetadata::default();
    meta.gain_map_min = [lo; 3];
    meta.gain_map_max = [hi; 3];
    meta.gamma = [1.0; 3];
    meta.base_offset = [OFFSET; 3];
    meta.alternate_offset = [OFFSET; 3];
    meta.base_hdr_headroom = 0.0;
    meta.alternate_hdr_headroom = hi.max(0.0);
    meta.use_base_color_space = true;
    meta.backward_direction = false;
    let bytes = caught(|| {
        ultrahdr_rs::encode_ultrahdr(&base_jpeg, &fitted.jpeg, &meta, ColorGamut::Bt709)
    })?
    .map_err(|e| format!("cannot assemble the UltraHDR file: {e}"))?;
    // The light was measured on the kept round's own decode; the file is checked to hold the
    // two pictures and the metadata.
    let assembled = caught(|| Decoder::new(&bytes))?.is_ok_and(|d| {
        d.metadata().is_some() && d.primary_jpeg().is_some() && d.gainmap_jpeg().is_some()
    });
    if !assembled {
        return Err("the assembled UltraHDR file does not read back".into());
    }
    let largest = match reader {
        Reader::Format => (1.0 + OFFSET) * hi.exp2() - OFFSET,
        Reader::Three => fitted.gains.radiance_three(0, 1.0, 1.0) as f64,
    };
    let stats = GainStats {
        largest_kept: largest as f32,
        brightest: img
            .pixels
            .par_iter()
            .map(|p| p.x.max(p.y).max(p.z))
            .reduce(|| 0.0, f32::max),
        stops: (lo as f32, hi as f32),
        flux_error: fitted.flux_error,
        bytes: bytes.len(),
    };
    Ok((bytes, stats))
}

/// An RGB JPEG of `data` (8 bits a channel, chroma whole: the gain map's chroma is light).
fn jpeg(data: &[u8], w: u32, h: u32, quality: u8) -> std::result::Result<Vec<u8>, String> {
    let mut out = Vec::new();
    JpegEncoder::new_with_quality(&mut out, quality)
        .write_image(data, w, h, ExtendedColorType::Rgb8)
        .map_err(|e| e.to_string())?;
    Ok(out)
}

/// A JPEG's pixels: linear light (sRGB decoded), or its stored values over 255 (`raw`), its
/// size checked against `limits` first. Its errors name no file (see [`inner`]).
fn decode_jpeg(bytes: &[u8], raw: bool, limits: &Limits) -> Result<Image> {
    let opts = ReadOptions {
        linear: raw,
        limits: *limits,
        ..ReadOptions::default()
    };
    match raster::decode(bytes, FileFormat::Jpeg, Path::new("-"), &opts)? {
        (Decoded::Image(img), _) => Ok(img),
        _ => Err(Error::file("-", "not an image")),
    }
}

/// What went wrong in a JPEG inside the file, without the stand-in name [`decode_jpeg`] gave
/// it (the file is named by the caller).
fn inner(e: &Error) -> String {
    match e {
        Error::Io { source, .. } => crate::io::io_msg(source),
        Error::Decode { msg, .. }
        | Error::Unsupported { msg, .. }
        | Error::Limit { msg, .. }
        | Error::Recipe { msg, .. }
        | Error::InvalidOption(msg) => msg.clone(),
    }
}

/// An error of the JPEG `what` inside the UltraHDR file `path`: a limit stays a limit (the
/// front end says how to raise it), anything else is the file's decode error.
fn in_file(e: Error, path: &Path, what: &str) -> Error {
    match e {
        Error::Limit { kind, msg, .. } => Error::limit(Some(path), kind, format!("{what}: {msg}")),
        e => Error::file(
            path,
            format!("cannot decode UltraHDR: {what}: {}", inner(&e)),
        ),
    }
}

/// The radiance an UltraHDR file holds at full boost, its SDR picture and gain map decoded
/// and the gain map stretched bilinearly over the picture where it is smaller, with the
/// arithmetic it was fitted to ([`THREE_MARK`]).
fn rebuild(
    decoder: &Decoder,
    path: &Path,
    limits: &Limits,
) -> Result<(Image, Reader, meta::Source)> {
    let fail = |msg: &str| Error::file(path, format!("cannot decode UltraHDR: {msg}"));
    rebuild_checked(decoder, limits).map_err(|e| match e {
        Rebuild::Said(msg) => fail(&msg),
        Rebuild::Jpeg(e, what) => in_file(e, path, what),
    })
}

/// Why [`rebuild`] stopped: a message about the file, or an error of one JPEG inside it.
enum Rebuild {
    Said(String),
    Jpeg(Error, &'static str),
}

impl From<&str> for Rebuild {
    fn from(s: &str) -> Rebuild {
        Rebuild::Said(s.into())
    }
}

impl From<String> for Rebuild {
    fn from(s: String) -> Rebuild {
        Rebuild::Said(s)
    }
}

fn rebuild_checked(
    decoder: &Decoder,
    limits: &Limits,
) -> std::result::Result<(Image, Reader, meta::Source), Rebuild> {
    let (meta, source) = meta::of(decoder)?;
    if meta.backward_direction {
        return Err("its base picture is the HDR rendition (backward direction), which cubeforge does not read".into());
    }
    let (Some(primary), Some(gain)) = (decoder.primary_jpeg(), decoder.gainmap_jpeg()) else {
        return Err("the gain map or the primary picture is missing".into());
    };
    if !meta::finite(&meta) {
        return Err("its gain-map metadata holds a value that is not finite".into());
    }
    let map = decode_jpeg(gain, true, limits).map_err(|e| Rebuild::Jpeg(e, "its gain map"))?;
    let mut img =
        decode_jpeg(primary, false, limits).map_err(|e| Rebuild::Jpeg(e, "its primary picture"))?;
    if map.width > img.width || map.height > img.height {
        return Err(Rebuild::Said(format!(
            "its gain map ({} x {}) is larger than its picture ({} x {})",
            map.width, map.height, img.width, img.height
        )));
    }
    let reader = if primary
        .windows(THREE_MARK.len())
        .take(4096)
        .any(|w| w == THREE_MARK)
    {
        Reader::Three
    } else {
        Reader::Format
    };
    Gains::of(&meta).apply_in_place(&mut img, &map, reader);
    // A profile's parser is given the file's bytes: a panic in it is no reason to stop.
    if let Some(m) = caught(|| meta::primaries(decoder)).ok().flatten() {
        // Colours outside BT.709 clip at 0, as libultrahdr's own decode clips them.
        img.pixels.par_iter_mut().for_each(|p| {
            *p = (m * p.truncate()).max(glam::Vec3::ZERO).extend(p.w);
        });
    }
    Ok((img, reader, source))
}

/// Decodes an UltraHDR file to its radiance at full boost.
pub fn decode(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Result<(Decoded, Meta)> {
    let decoder = caught(|| Decoder::new(bytes))
        .map_err(|e| Error::file(path, format!("cannot decode UltraHDR: {e}")))?
        .map_err(|e| Error::file(path, format!("cannot decode UltraHDR: {e}")))?;
    if let Some(p) = decoder.primary_jpeg() {
        // The limits, from the primary picture's frame header, before any pixel is decoded.
        let (w, h) = raster::dimensions(p, FileFormat::Jpeg, path)?;
        opts.limits.check(path, w as u64, h as u64)?;
    }
    let (img, reader, source) = rebuild(&decoder, path, &opts.limits)?;
    let by = match source {
        meta::Source::Iso => "ISO 21496-1",
        meta::Source::Xmp => "hdrgm XMP",
    };
    let meta = Meta {
        file_format: FileFormat::UltraHdr,
        pixel_format: match reader {
            Reader::Format => format!("RGB8 + RGB gain map ({by})"),
            Reader::Three => format!("RGB8 + RGB gain map ({by}, fitted to three.js)"),
        },
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values: 0,
        stored_levels: 1,
        declared: None,
        undo: Default::default(),
        part: None,
    };
    Ok((Decoded::Image(img), meta))
}

/// Each channel's light in `back` against `src`'s, minus 1 (0 where the source is black),
/// measured by `light`.
fn flux_error(src: &Image, back: &Image, light: &Light) -> [f64; 3] {
    let (a, b) = (light(src), light(back));
    [0, 1, 2].map(|c| if a[c] > 0.0 { b[c] / a[c] - 1.0 } else { 0.0 })
}
