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

/// Scan lines per ZIP block (OpenEXR's ZIP16).
const ZIP_LINES: usize = 16;

/// Half-float RGB(A), ZIP-compressed in 16-line blocks: what most tools read and write. Alpha
/// is left out when every texel is opaque (readers take a missing A as 1), a quarter less data.
/// The exr crate writes the file (header, offset table, chunks); the blocks are compressed
/// here, in parallel, with libdeflate: about 2x faster than the crate's deflate for files no
/// larger, and ZIP encoding was the largest stage of converting a panorama to faces.
pub fn encode(img: &Image) -> std::result::Result<Vec<u8>, String> {
    use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
    use exr::block::writer::ChunksWriter;
    use exr::meta::attribute::{ChannelDescription, LineOrder};
    use exr::meta::header::Header;
    use exr::meta::BlockDescription;
    use rayon::prelude::*;

    let alpha = img.pixels.par_iter().any(|p| p.w != 1.0);
    // Channels in the file's (alphabetical) order, as indices into a texel.
    let order: &[usize] = if alpha { &[3, 2, 1, 0] } else { &[2, 1, 0] };
    let names = ["R", "G", "B", "A"];
    let list = order
        .iter()
        .map(|&c| ChannelDescription::new(names[c], SampleType::F16, c == 3))
        .collect();
    let header = Header::new(Text::from(""), (img.width, img.height), list)
        .with_attributes(LayerAttributes::default())
        .with_encoding(
            Compression::ZIP16,
            BlockDescription::ScanLines,
            LineOrder::Increasing,
        );
    let blocks: Vec<Vec<u8>> = (0..img.height.div_ceil(ZIP_LINES))
        .into_par_iter()
        .map_init(
            || {
                let level = libdeflater::CompressionLvl::new(4).expect("valid level");
                libdeflater::Compressor::new(level)
            },
            |deflate, b| zip_block(img, b * ZIP_LINES, order, deflate),
        )
        .collect();
    let mut out = Vec::new();
    exr::block::write(
        Cursor::new(&mut out),
        SmallVec::from_vec(vec![header]),
        true,
        |_, writer| {
            for (i, data) in blocks.into_iter().enumerate() {
                let block = CompressedScanLineBlock {
                    y_coordinate: (i * ZIP_LINES) as i32,
                    compressed_pixels_le: data,
                };
                writer.write_chunk(
                    i,
                    Chunk {
                        layer_index: 0,
                        compressed_block: CompressedBlock::ScanLine(block),
                    },
                )?;
            }
            Ok(())
        },
    )
    .map_err(|e| e.to_string())?;
    Ok(out)
}

/// One ZIP block as OpenEXR stores it: for each line, each channel's half-float samples
/// (little-endian); then the bytes split into even and odd halves, each byte replaced by its
/// difference from the previous one, and zlib-compressed. A block that does not shrink is
/// stored as it is, which readers recognise by its size.
fn zip_block(
    img: &Image,
    y0: usize,
    order: &[usize],
    deflate: &mut libdeflater::Compressor,
) -> Vec<u8> {
    use half::slice::HalfFloatSliceExt;
    let w = img.width;
    let lines = ZIP_LINES.min(img.height - y0);
    let mut raw = Vec::with_capacity(lines * order.len() * w * 2);
    let mut floats = vec![0.0f32; w];
    let mut halves = vec![f16::ZERO; w];
    for y in y0..y0 + lines {
        let row = &img.pixels[y * w..(y + 1) * w];
        for &c in order {
            for (f, p) in floats.iter_mut().zip(row) {
                *f = p[c];
            }
            // Slice conversion uses the CPU's F16C instructions where present.
            halves.convert_from_f32_slice(&floats);
            for h in &halves {
                raw.extend_from_slice(&h.to_le_bytes());
            }
        }
    }
    let n = raw.len();
    let mut split = vec![0u8; n];
    let (even, odd) = split.split_at_mut(n.div_ceil(2));
    for (i, pair) in raw.chunks(2).enumerate() {
        even[i] = pair[0];
        if let Some(&b) = pair.get(1) {
            odd[i] = b;
        }
    }
    let mut prev = split[0];
    for v in &mut split[1..] {
        let cur = *v;
        *v = cur.wrapping_sub(prev).wrapping_add(128);
        prev = cur;
    }
    let mut packed = vec![0u8; deflate.zlib_compress_bound(n)];
    match deflate.zlib_compress(&split, &mut packed) {
        Ok(len) if len < n => {
            packed.truncate(len);
            packed
        }
        _ => raw,
    }
}
