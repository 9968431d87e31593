//! OpenEXR through the `exr` crate: the first RGB(A) layer in, half-float RGBA out.
//!
//! Reading trusts nothing in the file: before the crate sees a byte, the headers, the chunk
//! table and every chunk are checked (each attribute and chunk inside the file, every block
//! of every part present exactly once, DWA section sizes within what the chunk and its block
//! allow), and every call into the crate runs behind `catch_unwind`, so a corrupt file is a
//! one-line error, never a panic or an abort on a huge allocation. The common layout (one
//! scan-line part of half or full floats) decodes a block per task straight into the image,
//! its ZIP and RLE blocks unpacked here (see `blocks`).

#![warn(missing_docs)]

use super::{Decoded, FileFormat, Limits, Meta};
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::*;
use glam::Vec4;
use std::io::Cursor;
use std::path::Path;

mod blocks;
mod checks;
mod piz;
use checks::{read_chunks, read_meta, RawChunk};

/// Decodes an OpenEXR file's first RGB(A) layer; `path` names it in errors, `limits` are checked before any pixel is allocated.
pub fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    decode_with(bytes, path, limits, false)
}

/// `decode`, and with `sanitize` the texels sanitized as [`crate::image::Image::sanitize`]
/// does, counted in `Meta::replaced_values`: the common layout does it a line at a time as
/// it decodes, rather than in another pass over a 128 MB panorama.
pub(crate) fn decode_with(
    bytes: &[u8],
    path: &Path,
    limits: &Limits,
    sanitize: bool,
) -> Result<(Decoded, Meta)> {
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
    let (image, replaced_values) = match fast_layout(&meta) {
        Some(layout) => blocks::decode_blocks(&meta, &layout, chunks, sanitize),
        None => read_layer(&meta, chunks).map(|mut img| {
            let n = if sanitize { img.sanitize() } else { 0 };
            (img, n)
        }),
    }
    .map_err(fail)?;
    let meta = Meta {
        file_format: FileFormat::Exr,
        pixel_format,
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values,
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
fn read_layer(meta: &MetaData, chunks: Vec<RawChunk>) -> std::result::Result<Image, String> {
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
                let chunk = raw.to_chunk();
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
        .map_init(ZipRoom::new, |room, b| {
            zip_block(img, b * ZIP_LINES, order, room)
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
    packed.resize(deflate.zlib_compress_bound(n), 0);
    match deflate.zlib_compress(split, packed) {
        // The block keeps only its bytes.
        Ok(len) if len < n => packed[..len].to_vec(),
        _ => samples.iter().flat_map(|h| h.to_le_bytes()).collect(),
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
        Some(
            blocks::decode_blocks(&meta, &layout, chunks, false)
                .unwrap()
                .0,
        )
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

    /// A `w` x `h` file the crate writes with `compression`, channels R G B (A) of the sample
    /// types `types` names (h half, f float; "+zu" adds a float Z and an integer id channel),
    /// holding negative, small, large and fractional values.
    fn written(size: (usize, usize), compression: Compression, types: &str) -> Vec<u8> {
        let (w, h) = size;
        let value = |i: usize, c: usize| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            match c {
                0 => x * 0.37 - 3.0,
                1 => (y * 0.61).sin() * 1000.0,
                2 => (x * y + 1.0).recip(),
                _ => 0.25 + x / 64.0,
            }
        };
        let samples = |c: usize, t: u8| match t {
            b'h' => FlatSamples::F16((0..w * h).map(|i| f16::from_f32(value(i, c))).collect()),
            b'f' => FlatSamples::F32((0..w * h).map(|i| value(i, c)).collect()),
            _ => FlatSamples::U32((0..w * h).map(|i| i as u32 * 7919).collect()),
        };
        let (colours, extra) = types.split_once('+').unwrap_or((types, ""));
        let mut list: Vec<AnyChannel<FlatSamples>> = colours
            .bytes()
            .enumerate()
            .map(|(c, t)| AnyChannel::new(["R", "G", "B", "A"][c], samples(c, t)))
            .collect();
        if !extra.is_empty() {
            list.push(AnyChannel::new("Z", samples(0, b'f')));
            list.push(AnyChannel::new("id", samples(0, b'u')));
        }
        let layer = Layer::new(
            size,
            LayerAttributes::default(),
            Encoding {
                compression,
                ..Encoding::SMALL_LOSSLESS
            },
            AnyChannels::sort(SmallVec::from_vec(list)),
        );
        let mut out = Vec::new();
        exr::image::Image::from_layer(layer)
            .write()
            .to_buffered(Cursor::new(&mut out))
            .unwrap();
        out
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
        // Noise that does not shrink: its blocks are stored as they are.
        let noisy = |x: usize, y: usize, c: usize| {
            let mut h = (((x * 131 + y) * 4 + c) as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            h ^= h >> 29;
            h = h.wrapping_mul(0xbf58_476d_1ce4_e5b9);
            h ^= h >> 32;
            f16::from_bits(h as u16 & 0x7bff).to_f32()
        };
        let noise = Image::from_fn(33, 17, |x, y| {
            Vec4::new(
                noisy(x, y, 0),
                noisy(x, y, 1),
                noisy(x, y, 2),
                noisy(x, y, 3),
            )
        });
        let bytes = encode(&noise).unwrap();
        assert!(bytes.len() > 33 * 17 * 8, "stored, not compressed");
        both(&bytes, "ours, noise");
        assert_eq!(crate_reader(&bytes), noise);
        // Every compression the crate writes, of half and full floats (and both in one file,
        // with channels that are skipped), in sizes whose last block is partial.
        for (w, h) in [(37, 41), (1, 19), (300, 5)] {
            for compression in [
                Compression::Uncompressed,
                Compression::RLE,
                Compression::ZIP1,
                Compression::ZIP16,
                Compression::PIZ,
                Compression::PXR24,
                Compression::B44,
                Compression::B44A,
                Compression::DWAA(None),
                Compression::DWAB(None),
            ] {
                for types in ["hhhh", "fff", "hfhf", "hhh+zu"] {
                    let out = written((w, h), compression, types);
                    both(&out, &format!("{w}x{h} {types} {compression:?}"));
                }
            }
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

    /// Sanitizing while decoding replaces what `Image::sanitize` replaces, and counts as many.
    #[test]
    fn sanitized_as_it_decodes() {
        let odd = [
            f32::NAN,
            f32::INFINITY,
            -2.0,
            3e30,
            -0.0,
            1e28,
            0.5,
            f32::NEG_INFINITY,
        ];
        let channels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
            let at = |c: usize| odd[(x * 3 + y * 5 + c) % odd.len()];
            (at(0), at(1), at(2), at(3))
        });
        for (blocks, compression) in [
            (Blocks::ScanLines, Compression::ZIP16),
            (Blocks::ScanLines, Compression::RLE),
            (Blocks::ScanLines, Compression::PIZ),
            (Blocks::Tiles(Vec2(16, 16)), Compression::ZIP16),
        ] {
            let layer = Layer::new(
                (37, 21),
                LayerAttributes::default(),
                Encoding {
                    compression,
                    blocks,
                    ..Encoding::SMALL_LOSSLESS
                },
                channels.clone(),
            );
            let mut out = Vec::new();
            exr::image::Image::from_layer(layer)
                .write()
                .to_buffered(Cursor::new(&mut out))
                .unwrap();
            let mut want = crate_reader(&out);
            let count = want.sanitize();
            let (Decoded::Image(got), meta) =
                decode_with(&out, Path::new("t.exr"), &Limits::default(), true).unwrap()
            else {
                unreachable!()
            };
            let what = format!("{blocks:?} {compression:?}");
            assert!(count > 0, "{what}");
            assert_eq!(meta.replaced_values, count, "{what}");
            let bits = |img: &Image| -> Vec<[u32; 4]> {
                img.pixels
                    .iter()
                    .map(|p| p.to_array().map(f32::to_bits))
                    .collect()
            };
            assert_eq!(bits(&got), bits(&want), "{what}");
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

    /// Corrupt PIZ blocks (the headers and code table changed byte by byte, every 7th byte
    /// after; cut short at as many lengths) give an image or an error, never a panic; intact
    /// ones read as the crate reads them.
    #[test]
    fn corrupt_piz_blocks_are_errors() {
        let limits = Limits::default();
        for types in ["fff", "hhhh"] {
            let good = written((64, 33), Compression::PIZ, types);
            both(&good, types);
            let (meta, start) = read_meta(&good).unwrap();
            let chunks = read_chunks(&good, &meta, start).unwrap();
            let data = chunks[0].data;
            let stored = 64 * 32 * if types == "fff" { 12 } else { 8 };
            assert!(
                data.len() < stored,
                "{types}: a PIZ block, not a stored one"
            );
            let at = data.as_ptr() as usize - good.as_ptr() as usize;
            let path = Path::new("t.exr");
            // Every byte of the headers (bitmap, lengths, code table), every 7th after.
            let picked = (0..data.len()).filter(|&i| i < 160 || i % 7 == 0);
            for i in picked.clone().map(|i| at + i) {
                for v in [0u8, 0xff, good[i] ^ 0x10, good[i].wrapping_add(1)] {
                    let mut bad = good.clone();
                    bad[i] = v;
                    let _ = decode(&bad, path, &limits);
                }
            }
            for n in picked {
                // The chunk's size field keeps its length: the file is cut inside the block.
                let _ = decode(&good[..at + n], path, &limits);
            }
        }
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
