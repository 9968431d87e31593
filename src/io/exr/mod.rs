//! OpenEXR through the `exr` crate: the first RGB(A) layer in, half-float RGBA out.
//!
//! Reading trusts nothing in the file: before the crate sees a byte, the headers, the chunk
//! table and every chunk are checked (each attribute and chunk inside the file, every block
//! of every part present exactly once, DWA section sizes within what the chunk and its block
//! allow), and every call into the crate runs behind `catch_unwind`, so a corrupt file is a
//! one-line error, never a panic or an abort on a huge allocation.

#![warn(missing_docs)]

use super::{Decoded, FileFormat, Limits, Meta};
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use exr::block::chunk::Chunk;
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::*;
use glam::Vec4;
use std::io::Cursor;
use std::path::Path;

mod checks;
use checks::{read_chunks, read_meta};

/// Decodes an OpenEXR file's first RGB(A) layer; `path` names it in errors, `limits` are checked before any pixel is allocated.
pub fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    let fail = |msg: String| Error::file(path, format!("cannot decode OpenEXR: {msg}"));
    let (meta, table_start) = read_meta(bytes).map_err(fail)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| Error::file(path, "OpenEXR file has no layers"))?;
    let size = header.layer_size;
    limits.check(path, size.0 as u64, size.1 as u64)?;
    let channel = |n: &str| header.channels.list.iter().find(|c| c.name.eq(n));
    if channel("R").is_none() || channel("G").is_none() || channel("B").is_none() {
        // Quoted with escapes (a corrupt name can hold a newline), at most eight of them.
        let list = &header.channels.list;
        let mut names: Vec<String> = list
            .iter()
            .take(8)
            .map(|c| format!("{:?}", c.name.to_string()))
            .collect();
        if list.len() > 8 {
            names.push(format!("and {} more", list.len() - 8));
        }
        return Err(Error::file(
            path,
            format!(
                "OpenEXR first layer has channels [{}], not R, G and B",
                names.join(", ")
            ),
        ));
    }
    if meta.headers.iter().any(|h| h.deep) {
        return Err(fail("deep data is not supported".into()));
    }
    // The samples decompressed: at most 16 four-byte channels per pixel the limit allows.
    let raw = (size.0 as u64)
        .saturating_mul(size.1 as u64)
        .saturating_mul(header.channels.bytes_per_pixel as u64);
    if raw > limits.max_pixels.saturating_mul(64) {
        return Err(fail(format!(
            "the first layer's {} channels hold {raw} bytes of samples, too many for {}x{} pixels",
            header.channels.list.len(),
            size.0,
            size.1
        )));
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
    let chunks = read_chunks(bytes, &meta, table_start).map_err(fail)?;
    let image = match fast_layout(&meta) {
        Some(layout) => decode_blocks(&meta, &layout, chunks),
        None => read_layer(&meta, chunks),
    }
    .map_err(fail)?;
    let meta = Meta {
        file_format: FileFormat::Exr,
        pixel_format,
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values: 0,
        stored_levels: 1,
    };
    Ok((Decoded::Image(image), meta))
}

/// Runs one call into the exr crate: its errors become messages, and so do its panics (see
/// [`super::guard::caught`]; none of these calls reaches rayon). `read_chunks` bounds the
/// sizes the crate allocates from before it sees them.
fn guarded<T>(f: impl FnOnce() -> exr::error::Result<T>) -> std::result::Result<T, String> {
    super::guard::caught(f)?.map_err(|e| super::guard::one_line(&e.to_string()))
}

/// Where each channel's samples go in a texel (None: skipped) and their type, and whether
/// there is alpha: for the common case that `decode_blocks` takes (one scan-line layer, R G
/// B and maybe A as half or full floats, no subsampling). None: leave it to `read_layer`.
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

/// The common case (see `Layout`), a block per task: each block is decompressed and
/// converted straight into its rows, in parallel. The crate's reader decompresses in
/// parallel too but places texels one by one on one thread, most of the time a 4K EXR took
/// to read. The chunks are those `read_chunks` checked: each block of the layer once.
fn decode_blocks(
    meta: &MetaData,
    (slots, alpha): &Layout,
    chunks: Vec<Chunk>,
) -> std::result::Result<Image, String> {
    use exr::block::UncompressedBlock;
    use rayon::prelude::*;

    let header = &meta.headers[0];
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    // Blocks in row order, each with its rows.
    let mut blocks: Vec<(usize, usize, Chunk)> = Vec::with_capacity(chunks.len());
    for chunk in chunks {
        let bounds = guarded(|| {
            let index = header.get_block_data_indices(&chunk.compressed_block)?;
            header.get_absolute_block_pixel_coordinates(index)
        })?;
        blocks.push((bounds.position.1 as usize, bounds.size.1, chunk));
    }
    blocks.sort_by_key(|b| b.0);
    let mut next = 0;
    for (y, lines, _) in &blocks {
        if *y != next {
            return Err(format!("scan lines {next} to {y} are missing"));
        }
        next += lines;
    }
    if next != h {
        return Err(format!("scan lines {next} to {h} are missing"));
    }
    let mut img = Image::new(w, h);
    let mut rest = img.pixels.as_mut_slice();
    let mut jobs = Vec::with_capacity(blocks.len());
    for (y, lines, chunk) in blocks {
        let (rows, tail) = rest.split_at_mut(lines * w);
        rest = tail;
        jobs.push((y, chunk, rows));
    }
    jobs.into_par_iter().try_for_each(|(y, chunk, rows)| {
        let block = guarded(|| UncompressedBlock::decompress_chunk(chunk, meta, false))?;
        if fill_rows(&block.data, slots, *alpha, w, rows) {
            Ok(())
        } else {
            Err(format!(
                "the block at line {y} decompresses to the wrong size"
            ))
        }
    })?;
    Ok(img)
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
fn read_layer(meta: &MetaData, chunks: Vec<Chunk>) -> std::result::Result<Image, String> {
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
    for chunk in chunks.into_iter().filter(|c| c.layer_index == 0) {
        let keep = guarded(|| {
            let tile = header.get_block_data_indices(&chunk.compressed_block)?;
            let bounds = header.get_absolute_block_pixel_coordinates(tile)?;
            let index = BlockIndex {
                layer: 0,
                pixel_position: bounds.position.to_usize("block position")?,
                pixel_size: bounds.size,
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
        let some: Vec<Chunk> = wanted.by_ref().take(batch).collect();
        if some.is_empty() {
            break;
        }
        let blocks: Vec<UncompressedBlock> = some
            .into_par_iter()
            .map(|chunk| guarded(|| UncompressedBlock::decompress_chunk(chunk, meta, false)))
            .collect::<std::result::Result<_, _>>()?;
        for block in blocks {
            guarded(|| layer.read_block(headers, block))?;
        }
    }
    let layer = guarded(|| Ok(layer.into_layers()))?;
    Ok(layer.channel_data.pixels)
}

/// Converts one decompressed block (per line, each channel's samples in native byte order)
/// into texels; false if its size is not what the header promised.
fn fill_rows(
    data: &[u8],
    slots: &[(Option<usize>, SampleType)],
    alpha: bool,
    w: usize,
    rows: &mut [Vec4],
) -> bool {
    use half::slice::HalfFloatSliceExt;
    let line_bytes: usize = slots.iter().map(|(_, t)| t.bytes_per_sample() * w).sum();
    if data.len() != line_bytes * (rows.len() / w) {
        return false;
    }
    let mut halves = vec![f16::ZERO; w];
    let mut floats = vec![0.0f32; w];
    for (line, row) in data.chunks_exact(line_bytes).zip(rows.chunks_exact_mut(w)) {
        let mut at = 0;
        for &(slot, kind) in slots {
            let size = kind.bytes_per_sample() * w;
            let samples = &line[at..at + size];
            at += size;
            let Some(k) = slot else { continue };
            if kind == SampleType::F16 {
                for (h, b) in halves.iter_mut().zip(samples.chunks_exact(2)) {
                    *h = f16::from_ne_bytes([b[0], b[1]]);
                }
                halves.convert_to_f32_slice(&mut floats);
            } else {
                for (f, b) in floats.iter_mut().zip(samples.chunks_exact(4)) {
                    *f = f32::from_ne_bytes([b[0], b[1], b[2], b[3]]);
                }
            }
            for (t, &v) in row.iter_mut().zip(&floats) {
                t[k] = v;
            }
        }
        if !alpha {
            for t in row.iter_mut() {
                t.w = 1.0;
            }
        }
    }
    true
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
                *f = super::finite(p[c], super::HALF_MAX);
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The fast path's texels, None where it declines the file.
    fn fast(bytes: &[u8]) -> Option<Image> {
        let (meta, start) = read_meta(bytes).unwrap();
        let layout = fast_layout(&meta)?;
        let chunks = read_chunks(bytes, &meta, start).unwrap();
        Some(decode_blocks(&meta, &layout, chunks).unwrap())
    }

    /// The crate's pixel reader on the checked chunks.
    fn slow(bytes: &[u8]) -> Image {
        let (meta, start) = read_meta(bytes).unwrap();
        read_layer(&meta, read_chunks(bytes, &meta, start).unwrap()).unwrap()
    }

    fn crate_reader(bytes: &[u8]) -> Image {
        super::crate_reader(bytes).unwrap()
    }

    fn both(bytes: &[u8], what: &str) {
        let fast = fast(bytes).unwrap_or_else(|| panic!("{what}: declined"));
        let slow = slow(bytes);
        assert_eq!(fast, slow, "{what}");
        assert_eq!(slow, crate_reader(bytes), "{what}");
    }

    /// The block-parallel reader gives the crate reader's texels bit for bit.
    #[test]
    fn blocks_match_the_crate_reader() {
        let img = Image::from_fn(37, 41, |x, y| {
            Vec4::new(
                x as f32 * 0.3,
                y as f32 * 7.0,
                (x * y) as f32 * 1e-3,
                (x % 5) as f32 / 4.0,
            )
        });
        both(&encode(&img).unwrap(), "ours, RGBA half");
        let opaque = Image::from_fn(37, 41, |x, y| img.get(x, y).truncate().extend(1.0));
        both(&encode(&opaque).unwrap(), "ours, RGB half");
        // Full floats, another compression, written by the crate itself.
        let channels = SpecificChannels::rgba(|Vec2(x, y)| {
            let p = img.get(x, y);
            (p.x, p.y, p.z, p.w)
        });
        for compression in [
            Compression::PIZ,
            Compression::Uncompressed,
            Compression::RLE,
        ] {
            let layer = Layer::new(
                (37, 41),
                LayerAttributes::default(),
                Encoding {
                    compression,
                    ..Encoding::SMALL_LOSSLESS
                },
                channels.clone(),
            );
            let mut out = Vec::new();
            exr::image::Image::from_layer(layer)
                .write()
                .to_buffered(Cursor::new(&mut out))
                .unwrap();
            both(&out, &format!("f32 {compression:?}"));
        }
        let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/fixtures/real");
        for sub in ["zip", "dwab", "ball", "faces/city"] {
            let Ok(dir) = std::fs::read_dir(real.join(sub)) else {
                continue;
            };
            for f in dir.flatten() {
                if f.path().extension().is_some_and(|e| e == "exr") {
                    both(
                        &std::fs::read(f.path()).unwrap(),
                        &f.path().display().to_string(),
                    );
                }
            }
        }
    }

    /// Tiled files go to the crate's pixel reader.
    #[test]
    fn tiles_are_left_to_the_crate() {
        let channels = SpecificChannels::rgb(|Vec2(x, y)| (x as f32, y as f32, 0.5f32));
        let layer = Layer::new(
            (40, 30),
            LayerAttributes::default(),
            Encoding {
                blocks: Blocks::Tiles(Vec2(16, 16)),
                ..Encoding::SMALL_LOSSLESS
            },
            channels,
        );
        let mut out = Vec::new();
        exr::image::Image::from_layer(layer)
            .write()
            .to_buffered(Cursor::new(&mut out))
            .unwrap();
        assert!(fast(&out).is_none());
        let img = slow(&out);
        assert_eq!(img.get(39, 29), Vec4::new(39.0, 29.0, 0.5, 1.0));
        assert_eq!(img, crate_reader(&out));
    }

    /// A panic inside a guarded call is a message, not an unwinding thread.
    #[test]
    fn panics_become_messages() {
        let e = guarded::<()>(|| panic!("capacity overflow")).unwrap_err();
        assert!(e.contains("capacity overflow"), "{e}");
        let e = guarded::<()>(|| Err(exr::error::Error::Invalid("thing".into()))).unwrap_err();
        assert!(e.contains("thing"), "{e}");
    }
}
