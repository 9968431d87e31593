//! PNG, JPEG, TGA and Radiance HDR through the `image` crate, converted to and from linear f32.

#![warn(missing_docs)]

use super::guard::{caught, one_line};
use super::{unorm8, Decoded, FileFormat, Meta, ReadOptions, WriteOptions};
use crate::error::{Error, Result};
use crate::image::{linear_to_srgb, srgb_to_linear, ColorSpace, Image};
use ::image::{codecs, ColorType, DynamicImage, ImageDecoder, ImageEncoder, ImageFormat};
use glam::Vec4;
use rayon::prelude::*;
use std::io::Cursor;
use std::path::Path;

fn image_format(f: FileFormat) -> ImageFormat {
    match f {
        FileFormat::Png => ImageFormat::Png,
        FileFormat::Jpeg => ImageFormat::Jpeg,
        FileFormat::Tga => ImageFormat::Tga,
        _ => ImageFormat::Hdr,
    }
}

/// The width and height a PNG, JPEG, TGA or HDR header declares, nothing decoded.
pub(crate) fn dimensions(bytes: &[u8], f: FileFormat, path: &Path) -> Result<(u32, u32)> {
    let fail = |msg: String| Error::file(path, format!("cannot decode {}: {msg}", f.name()));
    let reader = ::image::ImageReader::with_format(Cursor::new(bytes), image_format(f));
    let decoder = caught(|| reader.into_decoder())
        .map_err(fail)?
        .map_err(|e| fail(one_line(&e.to_string())))?;
    Ok(decoder.dimensions())
}

/// Decodes, checking the header's size against the limit before the pixels are read.
pub fn decode(
    bytes: &[u8],
    f: FileFormat,
    path: &Path,
    opts: &ReadOptions,
) -> Result<(Decoded, Meta)> {
    let what = f.name();
    let fail = |msg: String| Error::file(path, format!("cannot decode {what}: {msg}"));
    let err = |e: ::image::ImageError| fail(one_line(&e.to_string()));
    // The PNG decoder reads on to the first IDAT before it tells the size: check IHDR first.
    if let Some((w, h)) = png_ihdr_size(bytes).filter(|_| f == FileFormat::Png) {
        opts.limits.check(path, w as u64, h as u64)?;
    }
    // Every call into the image crate is caught (`guard::caught`): a panic on corrupt data
    // becomes this file's error. None of them hands work to rayon.
    let reader = ::image::ImageReader::with_format(Cursor::new(bytes), image_format(f));
    let mut decoder = caught(|| reader.into_decoder())
        .map_err(fail)?
        .map_err(err)?;
    let (w, h) = decoder.dimensions();
    opts.limits.check(path, w as u64, h as u64)?;
    if f == FileFormat::Jpeg {
        jpeg_can_hold(bytes.len(), w, h).map_err(|e| Error::file(path, e))?;
    }
    let mut limits = ::image::Limits::default();
    limits.max_alloc = Some(opts.limits.max_pixels.saturating_mul(16).max(1 << 20));
    decoder.set_limits(limits).map_err(err)?;
    let color = decoder.color_type();
    let img = caught(|| DynamicImage::from_decoder(decoder))
        .map_err(fail)?
        .map_err(err)?;
    let (w, h) = (w as usize, h as usize);
    let float = matches!(color, ColorType::Rgb32F | ColorType::Rgba32F);
    let srgb = !float && !opts.linear;
    let pixels = to_rgba(img, color, float, srgb);
    let meta = Meta {
        file_format: f,
        pixel_format: pixel_format_name(color, f),
        color_space: if srgb {
            ColorSpace::Srgb
        } else {
            ColorSpace::Linear
        },
        hdr: float,
        replaced_values: 0,
        stored_levels: 1,
        declared: None,
        undo: Default::default(),
        part: None,
    };
    Ok((
        Decoded::Image(Image {
            width: w,
            height: h,
            pixels,
        }),
        meta,
    ))
}

/// A decoded image's texels as linear RGBA f32: floats as they are, 8- and 16-bit values
/// through the sRGB curve when `srgb` (8-bit ones by a table).
fn to_rgba(img: DynamicImage, color: ColorType, float: bool, srgb: bool) -> Vec<Vec4> {
    if let DynamicImage::ImageRgb32F(buf) = &img {
        // The common HDR case, without an intermediate RGBA copy.
        buf.as_raw()
            .par_chunks_exact(3)
            .map(|c| Vec4::new(c[0], c[1], c[2], 1.0))
            .collect()
    } else if float {
        img.into_rgba32f()
            .into_raw()
            .par_chunks_exact(4)
            .map(|c| Vec4::new(c[0], c[1], c[2], c[3]))
            .collect()
    } else if matches!(color.bytes_per_pixel() / color.channel_count(), 1) {
        let lut: Vec<f32> = (0..256)
            .map(|i| {
                let v = i as f32 / 255.0;
                if srgb {
                    srgb_to_linear(v)
                } else {
                    v
                }
            })
            .collect();
        img.into_rgba8()
            .into_raw()
            .chunks_exact(4)
            .map(|c| {
                Vec4::new(
                    lut[c[0] as usize],
                    lut[c[1] as usize],
                    lut[c[2] as usize],
                    c[3] as f32 / 255.0,
                )
            })
            .collect()
    } else {
        let raw = img.into_rgba16().into_raw();
        raw.par_chunks_exact(4)
            .map(|c| {
                let v = |x: u16| {
                    let v = x as f32 / 65535.0;
                    if srgb {
                        srgb_to_linear(v)
                    } else {
                        v
                    }
                };
                Vec4::new(v(c[0]), v(c[1]), v(c[2]), c[3] as f32 / 65535.0)
            })
            .collect()
    }
}

/// Refuses a JPEG too small to hold the pixels its frame header claims, before the decoder
/// spends time on them: it decodes every block whether the file has data for it or not (a
/// 1 KB file claiming 16384x16384 took 20 s). Every 8x8 block of the full-size component
/// costs at least one bit in a complete file (its DC difference; Huffman codes are never
/// shorter, progressive files included, and arithmetic coding is not decoded), so a file
/// under a bit per block is truncated or lies. The floor here is half that, a byte per 16
/// blocks: a blank baseline JPEG with the standard tables needs 6 bits a block, 12 times it.
fn jpeg_can_hold(len: usize, w: u32, h: u32) -> std::result::Result<(), String> {
    let blocks = (w as u64).div_ceil(8) * (h as u64).div_ceil(8);
    let floor = blocks / 16;
    if (len as u64) < floor {
        return Err(format!(
            "cannot decode JPEG: the file has {len} bytes, too few for the {w}x{h} pixels its header claims (even a blank image needs about {} bytes): it is truncated or its header is corrupt",
            blocks / 8
        ));
    }
    Ok(())
}

/// Width and height from a PNG's IHDR chunk (which must come first), if present.
fn png_ihdr_size(bytes: &[u8]) -> Option<(u32, u32)> {
    let be = |i: usize| Some(u32::from_be_bytes(bytes.get(i..i + 4)?.try_into().ok()?));
    (bytes.get(12..16)? == b"IHDR").then_some(())?;
    Some((be(16)?, be(20)?))
}

pub(super) fn pixel_format_name(c: ColorType, f: FileFormat) -> String {
    if f == FileFormat::Hdr {
        return "RGBE (shared exponent)".into();
    }
    match c {
        ColorType::L8 => "L8",
        ColorType::La8 => "LA8",
        ColorType::Rgb8 => "RGB8",
        ColorType::Rgba8 => "RGBA8",
        ColorType::L16 => "L16",
        ColorType::La16 => "LA16",
        ColorType::Rgb16 => "RGB16",
        ColorType::Rgba16 => "RGBA16",
        ColorType::Rgb32F => "RGB32F",
        ColorType::Rgba32F => "RGBA32F",
        _ => "other",
    }
    .into()
}

/// Encodes linear pixels: sRGB-encoded 8 or 16 bits (unless `linear`), or linear floats for HDR.
pub fn encode(
    img: &Image,
    f: FileFormat,
    opts: &WriteOptions,
) -> std::result::Result<Vec<u8>, String> {
    let (w, h) = (img.width as u32, img.height as u32);
    let tf = |v: f32| {
        if opts.linear {
            v.clamp(0.0, 1.0)
        } else {
            linear_to_srgb(v)
        }
    };
    let mut out = Vec::new();
    let e = |e: ::image::ImageError| e.to_string();
    match f {
        FileFormat::Hdr => {
            let rgb: Vec<::image::Rgb<f32>> = img
                .pixels
                .iter()
                .map(|p| ::image::Rgb([p.x.max(0.0), p.y.max(0.0), p.z.max(0.0)]))
                .collect();
            codecs::hdr::HdrEncoder::new(&mut out)
                .encode(&rgb, img.width, img.height)
                .map_err(e)?;
        }
        FileFormat::Png if opts.png16 => {
            let native: Vec<u8> = img
                .pixels
                .par_iter()
                .flat_map_iter(|p| {
                    let q = |v: f32| ((v * 65535.0 + 0.5) as u16).to_ne_bytes();
                    [q(tf(p.x)), q(tf(p.y)), q(tf(p.z)), q(p.w.clamp(0.0, 1.0))]
                        .into_iter()
                        .flatten()
                })
                .collect();
            codecs::png::PngEncoder::new(&mut out)
                .write_image(&native, w, h, ::image::ExtendedColorType::Rgba16)
                .map_err(e)?;
        }
        FileFormat::Png | FileFormat::Tga | FileFormat::Jpeg => {
            let alpha = f != FileFormat::Jpeg;
            let data: Vec<u8> = img
                .pixels
                .par_iter()
                .flat_map_iter(|p| {
                    let rgb = [unorm8(tf(p.x)), unorm8(tf(p.y)), unorm8(tf(p.z))];
                    let a = unorm8(p.w);
                    rgb.into_iter().chain(alpha.then_some(a))
                })
                .collect();
            let ct = if alpha {
                ::image::ExtendedColorType::Rgba8
            } else {
                ::image::ExtendedColorType::Rgb8
            };
            match f {
                FileFormat::Png => codecs::png::PngEncoder::new(&mut out)
                    .write_image(&data, w, h, ct)
                    .map_err(e)?,
                FileFormat::Tga => codecs::tga::TgaEncoder::new(&mut out)
                    .write_image(&data, w, h, ct)
                    .map_err(e)?,
                _ => codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 95)
                    .write_image(&data, w, h, ct)
                    .map_err(e)?,
            }
        }
        _ => return Err(format!("{} is not written by this encoder", f.name())),
    }
    Ok(out)
}
