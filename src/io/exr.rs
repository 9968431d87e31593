//! OpenEXR through the `exr` crate: the first RGB(A) layer in, half-float RGBA out.

use super::{Decoded, FileFormat, Limits, Meta};
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use exr::prelude::*;
use glam::Vec4;
use std::io::Cursor;
use std::path::Path;

pub fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    let err = |e: exr::error::Error| Error::file(path, format!("cannot decode OpenEXR: {e}"));
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(err)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| Error::file(path, "OpenEXR file has no layers"))?;
    let size = header.layer_size;
    limits.check(path, size.0 as u64, size.1 as u64)?;
    let channel = |n: &str| header.channels.list.iter().find(|c| c.name.eq(n));
    if channel("R").is_none() || channel("G").is_none() || channel("B").is_none() {
        let names: Vec<String> = header
            .channels
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        return Err(Error::file(
            path,
            format!(
                "OpenEXR first layer has channels [{}], not R, G and B",
                names.join(", ")
            ),
        ));
    }
    let sample = match channel("R").map(|c| c.sample_type) {
        Some(SampleType::F16) => "16F",
        Some(SampleType::U32) => "32UI",
        _ => "32F",
    };
    let alpha = channel("A").is_some();
    let pixel_format = format!(
        "{}{sample} ({:?})",
        if alpha { "RGBA" } else { "RGB" },
        header.compression
    );
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| Image::new(res.0, res.1),
            |img: &mut Image, pos, (r, g, b, a): (f32, f32, f32, f32)| {
                img.set(pos.0, pos.1, Vec4::new(r, g, b, a))
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(err)?;
    let meta = Meta {
        file_format: FileFormat::Exr,
        pixel_format,
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values: 0,
    };
    Ok((Decoded::Image(image.layer_data.channel_data.pixels), meta))
}

/// Half-float RGBA, ZIP-compressed in 16-line blocks (what most tools read and write).
pub fn encode(img: &Image) -> std::result::Result<Vec<u8>, String> {
    let channels = SpecificChannels::rgba(|Vec2(x, y)| {
        let p = img.get(x, y);
        (
            f16::from_f32(p.x),
            f16::from_f32(p.y),
            f16::from_f32(p.z),
            f16::from_f32(p.w),
        )
    });
    let layer = Layer::new(
        (img.width, img.height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    let mut out = Vec::new();
    exr::image::Image::from_layer(layer)
        .write()
        .to_buffered(Cursor::new(&mut out))
        .map_err(|e| e.to_string())?;
    Ok(out)
}
