//! OpenEXR through the `exr` crate: the first RGB(A) layer in, half-float RGBA out.
//!
//! Reading trusts nothing in the file: before the crate sees a byte, the headers, the chunk
//! table and every chunk are checked (each attribute and chunk inside the file, every block
//! of every part present exactly once, DWA section sizes within what the chunk and its block
//! allow), and every call into the crate runs behind `catch_unwind`, so a corrupt file is a
//! one-line error, never a panic or an abort on a huge allocation. The common layout (one
//! scan-line part of half or full floats) decodes a block per task straight into the image,
//! its ZIP and RLE blocks unpacked here (see `blocks`). A file whose `envmap` attribute
//! declares OpenEXR's latlong or cube layout is read by that layout's definition (`envmap`).

#![warn(missing_docs)]

use super::{Decoded, FileFormat, Limits, Meta, Undo};
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::*;
use glam::Vec4;
use std::io::Cursor;
use std::path::Path;

mod blocks;
mod checks;
mod names;
mod piz;
mod planes;
mod rows;
mod select;
pub mod stream;
mod zstd;
use checks::{read_chunks, read_meta, RawChunk};
use names::{compression_name, envmap_of, pixel_format};

/// Decodes an OpenEXR file's first RGB(A) layer; `path` names it in errors, `limits` are checked before any pixel is allocated.
pub fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    let opts = super::ReadOptions {
        limits: *limits,
        ..Default::default()
    };
    decode_with(bytes, path, &opts, false)
}

/// The parts of an OpenEXR file as messages name them ("0", or "1 \"diffuse\"" where a
/// part has a name), and the index of the one named `name` if given: how `--part NAME` is
/// turned into an index.
pub fn part_index(bytes: &[u8], path: &Path, name: &str) -> Result<usize> {
    let fail = |msg: String| Error::file(path, msg);
    let (meta, _, _) = read_meta(bytes).map_err(|e| fail(format!("cannot decode OpenEXR: {e}")))?;
    select::part_named(&meta, name).map_err(fail)
}

/// The error of `path` whose bytes say `msg` where they cannot be decoded.
fn undecodable(path: &Path) -> impl Fn(String) -> Error + Copy + '_ {
    move |msg| Error::file(path, format!("cannot decode OpenEXR: {msg}"))
}

/// `decode`, with the part and level `opts` choose, and with `sanitize` the texels sanitized
/// as [`crate::image::Image::sanitize`] does, counted in `Meta::replaced_values`: the common
/// layout does it a line at a time as it decodes, rather than in another pass over a 128 MB
/// panorama.
pub(crate) fn decode_with(
    bytes: &[u8],
    path: &Path,
    opts: &super::ReadOptions,
    sanitize: bool,
) -> Result<(Decoded, Meta)> {
    let fail = undecodable(path);
    let (meta, table_start, zstd) = read_meta(bytes).map_err(fail)?;
    if meta.headers.is_empty() {
        return Err(Error::file(path, "OpenEXR file has no layers"));
    }
    let part = select::part(&meta, opts.exr_part).map_err(|e| Error::file(path, e))?;
    let header = &meta.headers[part];
    let zstd = zstd.get(part) == Some(&true);
    let level = opts.exr_level;
    let levels = select::level_count(header);
    if level >= levels {
        return Err(Error::file(
            path,
            format!(
                "no level {level}: it holds {levels} level{}",
                if levels == 1 { "" } else { "s" }
            ),
        ));
    }
    let size = planes::level_size(header, (level, level));
    opts.limits.check(path, size.0 as u64, size.1 as u64)?;
    let channel = |n: &str| header.channels.list.iter().find(|c| c.name.eq(n));
    let rgb = channel("R").is_some() && channel("G").is_some() && channel("B").is_some();
    if !rgb && channel("Y").is_none() {
        return Err(Error::file(path, select::no_colour(header, part)));
    }
    if meta.headers.iter().any(|h| h.deep) {
        return Err(fail("deep data is not supported".into()));
    }
    // The samples decompressed: at most 16 four-byte channels per pixel the limit allows.
    let raw = (header.layer_size.0 as u64)
        .saturating_mul(header.layer_size.1 as u64)
        .saturating_mul(header.channels.bytes_per_pixel as u64);
    if raw > opts.limits.max_pixels.saturating_mul(64) {
        return Err(fail(format!(
            "part {part}'s {} channels hold {raw} bytes of samples, too many for {}x{} pixels",
            header.channels.list.len(),
            header.layer_size.0,
            header.layer_size.1
        )));
    }
    let pixel_format = pixel_format(header, channel("A").is_some(), zstd);
    let chunks = read_chunks(bytes, &meta, table_start).map_err(fail)?;
    let subsampled = header
        .channels
        .list
        .iter()
        .any(|c| c.sampling != Vec2(1, 1));
    let common = part == 0 && level == 0 && rgb && !subsampled;
    let (image, replaced_values) = match fast_layout(&meta) {
        Some(layout) if common => blocks::decode_blocks(&meta, &layout, chunks, sanitize, zstd),
        _ => {
            let read = if common {
                read_layer(&meta, chunks, zstd)
            } else {
                select::image(&meta, part, level, &chunks, zstd, rgb)
            };
            read.map(|mut img| {
                let n = if sanitize { img.sanitize() } else { 0 };
                (img, n)
            })
        }
    }
    .map_err(fail)?;
    let (envmap, declared) = envmap_of(header);
    let decoded = Decoded::Image(image);
    let meta = Meta {
        file_format: FileFormat::Exr,
        pixel_format,
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values,
        stored_levels: levels,
        declared,
        part: select::part_note(&meta, part, opts.exr_part.is_some()),
        undo: Undo {
            envmap,
            ..Undo::default()
        },
    };
    Ok((decoded, meta))
}

/// Runs one call into the exr crate: its errors become messages, and so do its panics (see
/// [`super::guard::caught`]; none of these calls reaches rayon). `read_chunks` bounds the
/// sizes the crate allocates from before it sees them.
fn guarded<T>(f: impl FnOnce() -> exr::error::Result<T>) -> std::result::Result<T, String> {
    super::guard::caught(f)?.map_err(|e| super::guard::one_line(&e.to_string()))
}

/// Where each channel's samples go in a texel (None: skipped) and their type, and whether
/// there is alpha: for the common case that `blocks::decode_blocks` takes (one scan-line
/// layer, R G B and maybe A as half or full floats, no subsampling). None: leave it to
/// `read_layer`.
type Layout = (Vec<(Option<usize>, SampleType)>, bool);

fn fast_layout(meta: &MetaData) -> Option<Layout> {
    let [header] = meta.headers.as_slice() else {
        return None;
    };
    if header.deep || header.blocks != BlockDescription::ScanLines {
        return None;
    }
    let mut slots = Vec::new();
    let mut found = [false; 4];
    for c in &header.channels.list {
        if c.sampling != Vec2(1, 1) {
            return None;
        }
        let slot = ["R", "G", "B", "A"].iter().position(|n| c.name.eq(n));
        if let Some(k) = slot {
            if c.sample_type == SampleType::U32 || found[k] {
                return None;
            }
            found[k] = true;
        }
        slots.push((slot, c.sample_type));
    }
    (found[0] && found[1] && found[2]).then_some((slots, found[3]))
}

/// The exr crate's own reader, start to end, unguarded: the reference the tests compare the
/// checked decoder with (never for untrusted files: it can abort on them).
#[doc(hidden)]
pub fn crate_reader(bytes: &[u8]) -> exr::error::Result<Image> {
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
        .from_buffered(Cursor::new(bytes))?;
    Ok(image.layer_data.channel_data.pixels)
}

/// The first layer, when it is R G B (A) by name, through the exr crate's pixel reader (any
/// layout: tiles, mip levels, subsampling, integer samples), texel by texel on one thread.
/// The chunks are those `read_chunks` checked, decompressed here in parallel batches with
/// rayon, rather than by the crate's own thread pool, where a panic would abort the process.
/// `zstd`: the chunks are ZSTD, inflated here (the header given to the crate says uncompressed).
fn read_layer(
    meta: &MetaData,
    chunks: Vec<RawChunk>,
    zstd: bool,
) -> std::result::Result<Image, String> {
    use exr::block::{BlockIndex, UncompressedBlock};
    use exr::image::read::image::{LayersReader, ReadLayers};
    use rayon::prelude::*;

    let spec = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |res, _| Image::new(res.0, res.1),
            |img: &mut Image, pos, (r, g, b, a): (f32, f32, f32, f32)| {
                img.set(pos.0, pos.1, Vec4::new(r, g, b, a))
            },
        )
        .first_valid_layer();
    // The first header only: the one whose size was checked against the limits.
    let headers = &meta.headers[..1];
    let header = &headers[0];
    let mut layer = guarded(|| spec.create_layers_reader(headers))?;
    let mut wanted = Vec::new();
    for chunk in chunks.into_iter().filter(|c| c.part == 0) {
        let tile = chunk.tile(header)?;
        let keep = guarded(|| {
            let index = BlockIndex {
                layer: 0,
                pixel_position: chunk.bounds.position.to_usize("block position")?,
                pixel_size: chunk.bounds.size,
                level: tile.level_index,
            };
            Ok(layer.filter_block(meta, tile, index))
        })?;
        if keep {
            wanted.push(chunk);
        }
    }
    // Batches bound the decompressed blocks held at once; blocks go in in file order.
    let batch = 4 * rayon::current_num_threads();
    let mut wanted = wanted.into_iter();
    loop {
        let some: Vec<RawChunk> = wanted.by_ref().take(batch).collect();
        if some.is_empty() {
            break;
        }
        let blocks: Vec<UncompressedBlock> = some
            .into_par_iter()
            .map(|raw| {
                let chunk = if zstd {
                    let mut data = Vec::new();
                    let (mut inflate, mut inner) = (None, Vec::new());
                    zstd::unpack(
                        raw.data,
                        header,
                        &raw.bounds,
                        &mut inflate,
                        &mut inner,
                        &mut data,
                    )?;
                    raw.with_data(data)
                } else {
                    raw.to_chunk()
                };
                guarded(|| UncompressedBlock::decompress_chunk(chunk, meta, false))
            })
            .collect::<std::result::Result<_, _>>()?;
        for block in blocks {
            guarded(|| layer.read_block(headers, block))?;
        }
    }
    let layer = guarded(|| Ok(layer.into_layers()))?;
    Ok(layer.channel_data.pixels)
}

/// Scan lines per ZIP block (OpenEXR's ZIP16).
const ZIP_LINES: usize = 16;

/// Half-float RGB(A), ZIP-compressed in 16-line blocks: what most tools read and write. Alpha
/// is left out when every texel is opaque (readers take a missing A as 1), a quarter less data.
/// `full_float` stores 32-bit floats instead, for radiance beyond half's 65504 (a sun).
/// The exr crate writes the file (header, offset table, chunks); the blocks are compressed
/// here, in parallel, with libdeflate: about 2x faster than the crate's deflate for files no
/// larger, and ZIP encoding was the largest stage of converting a panorama to faces.
pub fn encode(img: &Image, full_float: bool) -> std::result::Result<Vec<u8>, String> {
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
        .map(|&c| {
            let sample = if full_float {
                SampleType::F32
            } else {
                SampleType::F16
            };
            ChannelDescription::new(names[c], sample, c == 3)
        })
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
        .map_init(ZipRoom::new, |room, b| {
            if full_float {
                zip_block_f32(img, b * ZIP_LINES, order, room)
            } else {
                zip_block(img, b * ZIP_LINES, order, room)
            }
        })
        .collect();
    // The blocks, their offset table and line headers, and room for the header: one
    // allocation, not a doubling chain of copies.
    let size = blocks.iter().map(|b| b.len() + 16).sum::<usize>() + 4096;
    let mut out: Vec<u8> = Vec::with_capacity(size);
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

/// Working memory for ZIP blocks, one for each piece of the block range that rayon hands a
/// worker (`map_init`), reused from block to block: fresh buffers for each block (some
/// 500 KB, zeroed) grew every worker's heap a few pages at a time, and each growth takes the
/// address-space lock the other threads' page faults need.
struct ZipRoom {
    deflate: libdeflater::Compressor,
    floats: Vec<f32>,
    halves: Vec<f16>,
    samples: Vec<u16>,
    split: Vec<u8>,
    packed: Vec<u8>,
    raw: Vec<u8>,
}

impl ZipRoom {
    fn new() -> Self {
        let level = libdeflater::CompressionLvl::new(4).expect("valid level");
        ZipRoom {
            deflate: libdeflater::Compressor::new(level),
            floats: Vec::new(),
            halves: Vec::new(),
            samples: Vec::new(),
            split: Vec::new(),
            packed: Vec::new(),
            raw: Vec::new(),
        }
    }
}

/// One ZIP block as OpenEXR stores it: for each line, each channel's half-float samples
/// (little-endian); then the bytes split into even and odd halves, each byte replaced by its
/// difference from the previous one, and zlib-compressed. A block that does not shrink is
/// stored as it is, which readers recognise by its size. The halves and their differences
/// are made in one pass over the samples (vectorised), not byte by byte.
fn zip_block(img: &Image, y0: usize, order: &[usize], room: &mut ZipRoom) -> Vec<u8> {
    use half::slice::HalfFloatSliceExt;
    let w = img.width;
    let lines = ZIP_LINES.min(img.height - y0);
    let ZipRoom {
        deflate,
        floats,
        halves,
        samples,
        split,
        packed,
        ..
    } = room;
    floats.resize(w, 0.0);
    halves.resize(w, f16::ZERO);
    samples.clear();
    for y in y0..y0 + lines {
        let row = &img.pixels[y * w..(y + 1) * w];
        for &c in order {
            for (f, p) in floats.iter_mut().zip(row) {
                *f = super::finite(p[c], super::HALF_MAX);
            }
            // Slice conversion uses the CPU's F16C instructions where present.
            halves.convert_from_f32_slice(floats);
            samples.extend(halves.iter().map(|h| h.to_bits()));
        }
    }
    // Byte i of the stored form is the low byte of sample i / 2 (even i) or its high byte.
    // Every byte of `split` is written below.
    let m = samples.len();
    let n = 2 * m;
    split.resize(n, 0);
    let (even, odd) = split.split_at_mut(m);
    let (lo, hi) = (|h: u16| h as u8, |h: u16| (h >> 8) as u8);
    let delta = |a: u8, b: u8| a.wrapping_sub(b).wrapping_add(128);
    even[0] = lo(samples[0]);
    for ((e, &a), &b) in even[1..]
        .iter_mut()
        .zip(&samples[1..])
        .zip(&samples[..m - 1])
    {
        *e = delta(lo(a), lo(b));
    }
    odd[0] = delta(hi(samples[0]), lo(samples[m - 1]));
    for ((o, &a), &b) in odd[1..]
        .iter_mut()
        .zip(&samples[1..])
        .zip(&samples[..m - 1])
    {
        *o = delta(hi(a), hi(b));
    }
    compressed_or(deflate, split, packed, || {
        samples.iter().flat_map(|h| h.to_le_bytes()).collect()
    })
}

/// The zlib-compressed `split` bytes, or the block as stored (`stored`) when compressing does
/// not shrink it: readers tell the two apart by the size.
fn compressed_or(
    deflate: &mut libdeflater::Compressor,
    split: &[u8],
    packed: &mut Vec<u8>,
    stored: impl FnOnce() -> Vec<u8>,
) -> Vec<u8> {
    let n = split.len();
    packed.resize(deflate.zlib_compress_bound(n), 0);
    match deflate.zlib_compress(split, packed) {
        // The block keeps only its bytes.
        Ok(len) if len < n => packed[..len].to_vec(),
        _ => stored(),
    }
}

/// [`zip_block`] for 32-bit float samples: each line's channels as little-endian floats, the
/// bytes split into even and odd positions, differenced and compressed the same way.
fn zip_block_f32(img: &Image, y0: usize, order: &[usize], room: &mut ZipRoom) -> Vec<u8> {
    let w = img.width;
    let lines = ZIP_LINES.min(img.height - y0);
    let ZipRoom {
        deflate,
        split,
        packed,
        raw,
        ..
    } = room;
    raw.clear();
    for y in y0..y0 + lines {
        let row = &img.pixels[y * w..(y + 1) * w];
        for &c in order {
            for p in row {
                raw.extend_from_slice(&super::finite(p[c], f32::MAX).to_le_bytes());
            }
        }
    }
    let n = raw.len();
    split.resize(n, 0);
    let half = n.div_ceil(2);
    for (i, &b) in raw.iter().enumerate() {
        split[if i % 2 == 0 { i / 2 } else { half + i / 2 }] = b;
    }
    let mut prev = split[0];
    for b in split[1..].iter_mut() {
        let here = *b;
        *b = here.wrapping_sub(prev).wrapping_add(128);
        prev = here;
    }
    compressed_or(deflate, split, packed, || raw.clone())
}

#[cfg(test)]
mod tests;
