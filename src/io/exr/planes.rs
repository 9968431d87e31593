//! Any part and any stored level of an OpenEXR file, channel by channel: what the common
//! decoders (`blocks`, and the crate's RGBA reader, which always takes part 0 at its largest
//! level and knows no subsampled channel) leave out. Each chunk of the part's level is
//! decompressed to the uncompressed layout (for each line, each channel's samples in header
//! order; a channel sampled every k-th line or texel has samples only there) and its samples
//! are scattered into one plane of floats per channel wanted. ZIP, RLE and ZSTD blocks are
//! unpacked here, so their subsampled channels are read; the other compressions go through
//! the crate, which sizes blocks without subsampling.

use super::checks::RawChunk;
use super::guarded;
use exr::block::UncompressedBlock;
use exr::meta::header::Header;
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::*;

/// One channel's samples at its own resolution (the level's size over its sampling).
pub(super) struct Plane {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub samples: Vec<f32>,
}

/// The size of stored level `level` (mip or rip indices) of `header`'s layer.
pub(super) fn level_size(header: &Header, level: (usize, usize)) -> (usize, usize) {
    let size = header.layer_size;
    match header.blocks {
        BlockDescription::Tiles(t) => (
            exr::meta::compute_level_size(t.rounding_mode, size.0, level.0),
            exr::meta::compute_level_size(t.rounding_mode, size.1, level.1),
        ),
        BlockDescription::ScanLines => (size.0, size.1),
    }
}

/// The planes of the channels named in `wanted` (those the part has), of part `part` at
/// level `level`, from `chunks` (those `read_chunks` checked: each block once).
pub(super) fn read_planes(
    meta: &MetaData,
    part: usize,
    level: (usize, usize),
    chunks: &[RawChunk],
    zstd: bool,
    wanted: &[&str],
) -> std::result::Result<Vec<Plane>, String> {
    let header = &meta.headers[part];
    let channels = &header.channels.list;
    let mut planes = empty_planes(header, level, wanted)?;
    let subsampled = channels.iter().any(|c| c.sampling != Vec2(1, 1));
    let (mut inflate, mut inner, mut bytes) = (None, Vec::new(), Vec::new());
    let mut zlib = libdeflater::Decompressor::new();
    for chunk in chunks.iter().filter(|c| c.part == part) {
        if chunk.tile(header)?.level_index != Vec2(level.0, level.1) {
            continue;
        }
        let b = &chunk.bounds;
        // The crate's block bounds are relative to the data window.
        let (x0, y0) = (b.position.0 as usize, b.position.1 as usize);
        let bh = b.size.1;
        // Samples and their bytes per (line, channel), as OpenEXR packs them.
        let rows = super::zstd::rows(header, b);
        let expected: usize = rows.iter().map(|(n, bytes)| n * bytes).sum();
        let data = chunk.data;
        let owned;
        let plain: &[u8] = if zstd {
            super::zstd::unpack(data, header, b, &mut inflate, &mut inner, &mut bytes)?;
            &bytes
        } else if data.len() == expected {
            data
        } else {
            match header.compression {
                Compression::ZIP1 | Compression::ZIP16 | Compression::RLE => {
                    inner.resize(expected, 0);
                    if header.compression == Compression::RLE {
                        super::blocks::unpack_rle(data, &mut inner)
                            .map_err(|e| format!("an RLE block {e}"))?;
                    } else if zlib.zlib_decompress(data, &mut inner) != Ok(expected) {
                        return Err(format!("the ZIP block at line {} is corrupt", b.position.1));
                    }
                    super::blocks::undo_differences(&mut inner);
                    // The even-offset bytes were stored first, then the odd-offset ones.
                    let (even, odd) = inner.split_at(expected.div_ceil(2));
                    bytes.clear();
                    for i in 0..expected {
                        bytes.push(if i % 2 == 0 { even[i / 2] } else { odd[i / 2] });
                    }
                    &bytes
                }
                _ if subsampled => {
                    return Err(format!(
                        "subsampled channels with {} compression are not read (save it with \
                         ZIP: oiiotool IN --compression zip -o OUT)",
                        super::compression_name(header.compression)
                    ))
                }
                _ => {
                    owned = guarded(|| {
                        UncompressedBlock::decompress_chunk(chunk.to_chunk(), meta, false)
                    })?;
                    &owned.data
                }
            }
        };
        if plain.len() != expected {
            return Err(format!(
                "the block at line {} decompresses to the wrong size",
                b.position.1
            ));
        }
        scatter(plain, &rows, channels, &mut planes, (x0, y0, bh));
    }
    Ok(planes.into_iter().flatten().collect())
}

/// A plane of zeros, at its channel's resolution, for each channel of `header` that is
/// `wanted` (None for the others): an error where a subsampled channel's grid does not
/// divide the level's data window.
fn empty_planes(
    header: &Header,
    level: (usize, usize),
    wanted: &[&str],
) -> std::result::Result<Vec<Option<Plane>>, String> {
    let (lw, lh) = level_size(header, level);
    let origin = header.own_attributes.layer_position;
    let channels = &header.channels.list;
    let mut planes: Vec<Option<Plane>> = Vec::with_capacity(channels.len());
    for c in channels {
        let (sx, sy) = (c.sampling.0.max(1), c.sampling.1.max(1));
        // OpenEXR's rule: a subsampled channel's grid divides the data window.
        if origin.0.rem_euclid(sx as i32) != 0
            || origin.1.rem_euclid(sy as i32) != 0
            || lw % sx != 0
            || lh % sy != 0
        {
            return Err(format!(
                "channel {:?} is sampled every {sx} x {sy} texels, which does not divide the \
                 data window",
                super::select::text(&c.name)
            ));
        }
        let name = super::select::text(&c.name);
        planes.push(wanted.contains(&name.as_str()).then(|| Plane {
            name,
            width: lw / sx,
            height: lh / sy,
            samples: vec![0.0; (lw / sx) * (lh / sy)],
        }));
    }
    Ok(planes)
}

/// Scatters one decompressed block (`plain`, its samples per line and channel as `rows`
/// say) of `bh` lines from (`x0`, `y0`) into the planes wanted.
fn scatter(
    plain: &[u8],
    rows: &[(usize, usize)],
    channels: &[ChannelDescription],
    planes: &mut [Option<Plane>],
    (x0, y0, bh): (usize, usize, usize),
) {
    let mut at = 0;
    for line in 0..bh {
        for (i, c) in channels.iter().enumerate() {
            let (n, bytes_per_sample) = rows[line * channels.len() + i];
            let size = n * bytes_per_sample;
            let row = &plain[at..at + size];
            at += size;
            let Some(p) = planes[i].as_mut().filter(|_| n > 0) else {
                continue;
            };
            let (sx, sy) = (c.sampling.0.max(1), c.sampling.1.max(1));
            let py = (y0 + line) / sy;
            let start = py * p.width + x0 / sx;
            let dst = &mut p.samples[start..start + n];
            match c.sample_type {
                SampleType::F16 => {
                    for (d, s) in dst.iter_mut().zip(row.chunks_exact(2)) {
                        *d = f16::from_le_bytes([s[0], s[1]]).to_f32();
                    }
                }
                SampleType::F32 => {
                    for (d, s) in dst.iter_mut().zip(row.chunks_exact(4)) {
                        *d = f32::from_le_bytes(s.try_into().unwrap());
                    }
                }
                SampleType::U32 => {
                    for (d, s) in dst.iter_mut().zip(row.chunks_exact(4)) {
                        *d = u32::from_le_bytes(s.try_into().unwrap()) as f32;
                    }
                }
            }
        }
    }
}
