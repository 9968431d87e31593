//! KTX2 cube maps with every mip level, in any [`GpuFormat`] (RGBA16F, RGBA32F, RGBA8 sRGB or
//! UNORM, BC6H, BC7, E5B9G9R9, B10G11R11), written and read by hand after the Khronos KTX 2.0
//! specification, optionally with Zstandard supercompression (scheme 2). 2D textures with a mip
//! chain (faceCount 1, for control maps) are written by [`encode_2d`] the same way.
//!
//! File layout as written: the 80-byte header, the level index (one entry per level, level 0
//! first), a Data Format Descriptor with one basic block, one key/value pair (`KTXwriter`), then
//! the levels, smallest first, each holding its six faces in order +X -X +Y -Y +Z -Z and starting
//! on a multiple of lcm(texel block size, 4). With Zstandard each level is one zstd frame of
//! those bytes (byteLength its compressed size, uncompressedByteLength the plain one), levels are
//! byte-aligned, there is no supercompression global data, and the DFD is the plain format's, as
//! the specification asks. Nothing in the output depends on the time, the machine's thread count
//! or the order work finishes in, so the same cube map always gives the same bytes.
//!
//! The reader takes both: a cube map with its levels, a 2D texture as its level 0 image. It
//! checks every header field and index entry against the file's length with checked arithmetic,
//! and the declared shape against [`Limits`] ([`super::container::Shape`], shared with DDS),
//! before it allocates any texels.

#![warn(missing_docs)]

mod format;
mod levels;

use super::container::Shape;
use super::{Decoded, FileFormat, GpuFormat, Limits, Meta};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::image::Image;
use format::*;
use levels::{check_blocks, inflate, level_spans};
use std::path::Path;

/// The 12 bytes every KTX2 file starts with ("«KTX 20»\r\n\x1A\n").
pub const IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// Header (identifier, nine UInt32 fields) plus the index (four UInt32, two UInt64).
const HEADER_LEN: usize = 80;
/// One level-index entry: byteOffset, byteLength, uncompressedByteLength (UInt64 each).
const LEVEL_ENTRY_LEN: usize = 24;

const WRITER_KEY: &str = "KTXwriter";

/// Alignment of every level's data: lcm(texel block size, 4), or 1 when supercompressed.
fn level_alignment(format: GpuFormat, supercompressed: bool) -> u64 {
    if supercompressed {
        return 1;
    }
    let t = format.block_bytes() as u64;
    t / gcd(t, 4) * 4
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

fn align_up(v: usize, a: usize) -> usize {
    v.div_ceil(a) * a
}

/// The KTX2 spec's key for how rows are stored: "rd" (the default) top first, "ru" bottom.
pub const ORIENTATION_KEY: &str = "KTXorientation";

/// Key of the levels description a prefiltered chain carries (JSON, NUL-terminated).
pub const LEVELS_KEY: &str = "cubeforge.levels";

/// Key of the edge fixup a cube map was written with (`warp` or `stretch`; absent: none):
/// its texel centres are not where seamless samplers expect them.
pub const EDGE_FIXUP_KEY: &str = "cubeforge.edgeFixup";

/// Key/value data: the `KTXwriter` entry and any `extra` ones, sorted by key as the spec asks,
/// each padded to 4 bytes. Values are written NUL-terminated.
fn key_value_data(extra: &[(&str, &[u8])]) -> Vec<u8> {
    let writer = format!("cubeforge {}", env!("CARGO_PKG_VERSION"));
    let mut entries: Vec<(&str, &[u8])> = vec![(WRITER_KEY, writer.as_bytes())];
    entries.extend_from_slice(extra);
    entries.sort_by(|a, b| a.0.as_bytes().cmp(b.0.as_bytes()));
    let mut out = Vec::new();
    for (key, value) in entries {
        let mut kv = Vec::with_capacity(key.len() + value.len() + 2);
        kv.extend_from_slice(key.as_bytes());
        kv.push(0);
        kv.extend_from_slice(value);
        kv.push(0);
        out.extend_from_slice(&(kv.len() as u32).to_le_bytes());
        out.extend_from_slice(&kv);
        out.resize(align_up(out.len(), 4), 0);
    }
    out
}

/// Reads just the start of a KTX2 file, up to the end of its key/value data (at most 16 MiB),
/// and returns its pairs: enough to describe a file without decoding its levels.
pub(crate) fn metadata_from_file(path: &Path) -> Vec<(String, Vec<u8>)> {
    use std::io::Read;
    if super::regular_file(path).is_err() {
        return Vec::new();
    }
    let Ok(mut f) = std::fs::File::open(path) else {
        return Vec::new();
    };
    let mut head = vec![0u8; 80];
    if f.read_exact(&mut head).is_err() {
        return Vec::new();
    }
    let word =
        |i: usize| u32::from_le_bytes([head[i], head[i + 1], head[i + 2], head[i + 3]]) as u64;
    let end = (word(12 + 4 * 11) + word(12 + 4 * 12)).min(16 << 20) as usize;
    if end > 80 {
        let mut rest = vec![0u8; end - 80];
        if f.read_exact(&mut rest).is_err() {
            return Vec::new();
        }
        head.extend_from_slice(&rest);
    }
    metadata(&head)
}

/// Reads the key/value pairs of a KTX2 file (values without their terminating NUL), or
/// nothing when the file is not KTX2 or the data does not fit.
pub fn metadata(bytes: &[u8]) -> Vec<(String, Vec<u8>)> {
    let field = |i: usize| -> Option<usize> {
        let b = bytes.get(12 + 4 * i..16 + 4 * i)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let (Some(offset), Some(len)) = (field(11), field(12)) else {
        return Vec::new();
    };
    if !bytes.starts_with(&IDENTIFIER) {
        return Vec::new();
    }
    let Some(data) = offset
        .checked_add(len)
        .and_then(|end| bytes.get(offset..end))
    else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut at = 0usize;
    while at + 4 <= data.len() {
        let n = u32::from_le_bytes([data[at], data[at + 1], data[at + 2], data[at + 3]]) as usize;
        let Some(kv) = at.checked_add(4 + n).and_then(|end| data.get(at + 4..end)) else {
            break;
        };
        if let Some(nul) = kv.iter().position(|&b| b == 0) {
            let key = String::from_utf8_lossy(&kv[..nul]).into_owned();
            let mut value = kv[nul + 1..].to_vec();
            if value.last() == Some(&0) {
                value.pop();
            }
            out.push((key, value));
        }
        at = align_up(at + 4 + n, 4);
    }
    out
}

/// Encodes every level of `cube` as a KTX2 cube map in `format`, which this build must
/// have ([`GpuFormat::check_built`]; otherwise the result is empty: use [`encode_cube_with`]
/// to be told why).
pub fn encode(cube: &CubeMap, format: GpuFormat) -> Vec<u8> {
    encode_with_metadata(cube, format, &[])
}

/// Encodes a cube map with extra key/value entries (e.g. [`LEVELS_KEY`]).
pub fn encode_with_metadata(cube: &CubeMap, format: GpuFormat, extra: &[(&str, &[u8])]) -> Vec<u8> {
    // Without supercompression only a format missing from this build fails (see `encode`).
    encode_cube_with(cube, format, None, extra).unwrap_or_default()
}

/// Encodes a cube map in `format`, each level Zstandard-supercompressed at level `zstd` when
/// given (1 to 22), with extra key/value entries; fails only on a level zstd refuses.
pub fn encode_cube_with(
    cube: &CubeMap,
    format: GpuFormat,
    zstd: Option<i32>,
    extra: &[(&str, &[u8])],
) -> std::result::Result<Vec<u8>, String> {
    let levels: Vec<&[Image]> = cube.levels.iter().map(|faces| &faces[..]).collect();
    encode_levels(&levels, format, zstd, extra)
}

/// Encodes a 2D texture (faceCount 1) with its mip chain, `levels[0]` the full size and each
/// further level the next smaller one (what [`Image::downsample_2x`] makes), in `format`.
/// Used for control maps, which hold data: pass [`GpuFormat::Rgba8`] (UNORM), BC7, or a
/// float format.
pub fn encode_2d(levels: &[Image], format: GpuFormat) -> Vec<u8> {
    encode_2d_with(levels, format, None, &[]).unwrap_or_default()
}

/// [`encode_2d`] with optional Zstandard supercompression (level 1 to 22).
pub fn encode_2d_with(
    levels: &[Image],
    format: GpuFormat,
    zstd: Option<i32>,
    extra: &[(&str, &[u8])],
) -> std::result::Result<Vec<u8>, String> {
    let levels: Vec<&[Image]> = levels.iter().map(std::slice::from_ref).collect();
    encode_levels(&levels, format, zstd, extra)
}

/// Each level's bytes: its faces encoded in parallel (every face of every level at once),
/// then joined in order, then supercompressed level by level when asked. Every image and
/// every zstd frame is made on its own, so the result does not depend on the thread count.
fn level_data(
    levels: &[&[Image]],
    format: GpuFormat,
    zstd: Option<i32>,
) -> std::result::Result<Vec<(Vec<u8>, u64)>, String> {
    use rayon::prelude::*;
    let images: Vec<(usize, &Image)> = levels
        .iter()
        .enumerate()
        .flat_map(|(l, faces)| faces.iter().map(move |f| (l, f)))
        .collect();
    let encoded: Vec<Vec<u8>> = images
        .par_iter()
        .map(|(_, img)| format.encode_image(img))
        .collect::<std::result::Result<_, String>>()?;
    let mut plain: Vec<Vec<u8>> = vec![Vec::new(); levels.len()];
    for ((l, _), bytes) in images.iter().zip(encoded) {
        plain[*l].extend_from_slice(&bytes);
    }
    plain
        .into_par_iter()
        .map(|bytes| {
            let len = bytes.len() as u64;
            match zstd {
                None => Ok((bytes, len)),
                Some(level) => zstd::bulk::compress(&bytes, level)
                    .map(|z| (z, len))
                    .map_err(|e| format!("Zstandard level {level} failed: {e}")),
            }
        })
        .collect()
}

/// Writes the file: `levels[l]` holds the faces of level `l` (six for a cube map, one for a 2D
/// texture), all of one size.
fn encode_levels(
    levels: &[&[Image]],
    format: GpuFormat,
    zstd: Option<i32>,
    extra: &[(&str, &[u8])],
) -> std::result::Result<Vec<u8>, String> {
    let (width, height) = levels
        .first()
        .and_then(|faces| faces.first())
        .map_or((0, 0), |f| (f.width, f.height));
    let face_count = levels.first().map_or(1, |faces| faces.len());
    let level_count = levels.len();
    let data = level_data(levels, format, zstd)?;

    let dfd = data_format_descriptor(format);
    let kvd = key_value_data(extra);
    let dfd_offset = HEADER_LEN + level_count * LEVEL_ENTRY_LEN;
    let kvd_offset = dfd_offset + dfd.len();
    let align = level_alignment(format, zstd.is_some()) as usize;

    // Levels go into the file smallest first; each starts on the alignment.
    let mut offsets = vec![0usize; level_count];
    let mut end = kvd_offset + kvd.len();
    for l in (0..level_count).rev() {
        offsets[l] = align_up(end, align);
        end = offsets[l] + data[l].0.len();
    }

    let mut out = Vec::with_capacity(end);
    out.extend_from_slice(&IDENTIFIER);
    for v in [
        vk_format(format),
        type_size(format),
        width as u32,  // pixelWidth
        height as u32, // pixelHeight
        0,             // pixelDepth
        0,             // layerCount
        face_count as u32,
        level_count as u32,
        if zstd.is_some() { SCHEME_ZSTD } else { 0 },
        dfd_offset as u32,
        dfd.len() as u32,
        kvd_offset as u32,
        kvd.len() as u32,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteOffset
    out.extend_from_slice(&0u64.to_le_bytes()); // sgdByteLength: none for Zstandard either
    for (l, &offset) in offsets.iter().enumerate() {
        out.extend_from_slice(&(offset as u64).to_le_bytes());
        out.extend_from_slice(&(data[l].0.len() as u64).to_le_bytes()); // byteLength
        out.extend_from_slice(&data[l].1.to_le_bytes()); // uncompressedByteLength
    }
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);
    let mut data = data;
    for l in (0..level_count).rev() {
        out.resize(offsets[l], 0); // mipPadding
        out.extend_from_slice(&std::mem::take(&mut data[l].0));
    }
    debug_assert_eq!(out.len(), end);
    Ok(out)
}

fn le_u32(bytes: &[u8], offset: usize) -> Option<u32> {
    let b = bytes.get(offset..offset.checked_add(4)?)?;
    Some(u32::from_le_bytes(b.try_into().ok()?))
}

fn le_u64(bytes: &[u8], offset: usize) -> Option<u64> {
    let b = bytes.get(offset..offset.checked_add(8)?)?;
    Some(u64::from_le_bytes(b.try_into().ok()?))
}

/// Checks that `len` bytes from `offset` lie inside a file of `file_len` bytes.
fn in_file(offset: u64, len: u64, file_len: usize) -> bool {
    offset
        .checked_add(len)
        .is_some_and(|end| end <= file_len as u64)
}

/// Whether the header describes a cube map (or a 2D texture, a control map, whose level 0 is
/// read as an image); what cubeforge does not read is refused: arrays, 3D and 1D textures,
/// supercompression other than Zstandard.
fn texture_kind(
    path: &Path,
    face_count: u32,
    layer_count: u32,
    depth: u32,
    height: u32,
    scheme: u32,
) -> Result<bool> {
    let err = |msg: String| Error::file(path, msg);
    // A cube map, or a 2D texture (a control map): level 0 of the latter is read as an image.
    let cube = match face_count {
        6 => true,
        1 => false,
        _ => {
            return Err(err(format!(
                "invalid header: faceCount is {face_count}, but a 2D texture has 1 and a cube map 6"
            )))
        }
    };
    if layer_count > 0 {
        return Err(err(format!(
            "texture arrays are not supported (layerCount {layer_count})"
        )));
    }
    if depth != 0 {
        return Err(err(format!(
            "a 3D texture (pixelDepth {depth}) is not supported: cubeforge reads 2D textures and cube maps"
        )));
    }
    if !cube && height == 0 {
        return Err(err(
            "a 1D texture (pixelHeight 0) is not supported: cubeforge reads 2D textures and cube maps".into(),
        ));
    }
    if scheme != 0 && scheme != SCHEME_ZSTD {
        let name = match scheme {
            1 => "BasisLZ",
            3 => "ZLIB",
            _ => "unknown",
        };
        return Err(err(format!(
            "supercompressed KTX2 (scheme {scheme}, {name}) is not supported: cubeforge reads plain and Zstandard (scheme 2) levels"
        )));
    }
    Ok(cube)
}

/// The texel format of the header's vkFormat, with its typeSize checked.
fn format_of(
    bytes: &[u8],
    vk: u32,
    type_size_field: u32,
    (dfd_offset, dfd_len): (u32, u32),
    path: &Path,
) -> Result<GpuFormat> {
    let err = |msg: String| Error::file(path, msg);
    // The colour model of the DFD's basic block (its fourth word), where the DFD is that long:
    // it tells UASTC HDR 4x4 from plain ASTC 4x4 (their bounds are checked below).
    let color_model = (dfd_len >= 16)
        .then(|| le_u32(bytes, dfd_offset as usize + 12))
        .flatten()
        .map(|word| word & 0xFF);
    let format = from_vk_format(vk, color_model)
        .ok_or_else(|| err(format!("unsupported vkFormat {vk} ({SUPPORTED})")))?;
    if type_size_field != type_size(format) {
        return Err(err(format!(
            "invalid header: typeSize is {type_size_field}, but {} needs {}",
            format.name(),
            type_size(format)
        )));
    }
    Ok(format)
}

/// Reads a KTX2 cube map with all its levels, or level 0 of a 2D texture (what `cubeforge
/// control` writes) as an image; every level's index entry is checked either way.
pub fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    let err = |msg: String| Error::file(path, msg);
    let file_len = bytes.len();
    if !bytes.starts_with(&IDENTIFIER) && !IDENTIFIER.starts_with(bytes) {
        return Err(err("not a KTX2 file (its identifier is missing)".into()));
    }
    if file_len < HEADER_LEN {
        return Err(err(format!(
            "truncated KTX2 file: {file_len} bytes, shorter than the {HEADER_LEN}-byte header"
        )));
    }
    let field = |i: usize| le_u32(bytes, 12 + 4 * i).unwrap_or(0);
    let vk = field(0);
    let type_size_field = field(1);
    let width = field(2);
    let height = field(3);
    let depth = field(4);
    let layer_count = field(5);
    let face_count = field(6);
    let level_count_field = field(7);
    let scheme = field(8);
    let dfd_offset = field(9);
    let dfd_len = field(10);
    let kvd_offset = field(11);
    let kvd_len = field(12);
    let sgd_offset = le_u64(bytes, 64).unwrap_or(0);
    let sgd_len = le_u64(bytes, 72).unwrap_or(0);

    let cube = texture_kind(path, face_count, layer_count, depth, height, scheme)?;
    let format = format_of(bytes, vk, type_size_field, (dfd_offset, dfd_len), path)?;
    // levelCount 0 asks the loader to make the mips; the file then holds level 0 only.
    let shape = Shape::check(
        path,
        limits,
        format,
        cube,
        width,
        height,
        level_count_field,
        "levelCount",
    )?;
    let level_count = shape.levels;
    let index_end = HEADER_LEN + level_count * LEVEL_ENTRY_LEN;
    if index_end > file_len {
        return Err(err(format!(
            "truncated KTX2 file: {file_len} bytes, but its level index ends at byte {index_end}"
        )));
    }

    check_blocks(
        bytes,
        path,
        (dfd_offset as u64, dfd_len as u64),
        (kvd_offset as u64, kvd_len as u64),
        (sgd_offset, sgd_len),
    )?;
    let zstd = scheme == SCHEME_ZSTD;
    let spans = level_spans(bytes, &shape, zstd, path)?;
    // A cube map's every level, a 2D texture's level 0 (its mips are that image made smaller).
    let wanted = if cube { level_count } else { 1 };
    let inflated = inflate(bytes, &spans[..wanted], &shape, zstd, path)?;
    let image = |l: usize, face: usize| {
        let (w, h) = shape.level_size(l);
        let len = shape.face_bytes(l);
        format
            .decode_image(&inflated[l][face * len..(face + 1) * len], w, h)
            .map_err(err)
    };
    let decoded = if cube {
        Decoded::Cube(CubeMap {
            levels: (0..level_count)
                .map(|l| crate::cube::try_faces(|f| image(l, f)))
                .collect::<Result<_>>()?,
        })
    } else {
        // Stored bottom row first ("ru", as three.js uploads rows): turned back to top first.
        let ru = |(k, v): &(String, Vec<u8>)| k == ORIENTATION_KEY && v.starts_with(b"ru");
        let img = image(0, 0)?;
        Decoded::Image(if metadata(bytes).iter().any(ru) {
            img.flipped_rows()
        } else {
            img
        })
    };

    let mut meta = Meta::for_gpu(FileFormat::Ktx2, format, level_count);
    if zstd {
        meta.pixel_format.push_str(", Zstandard supercompressed");
    }
    Ok((decoded, meta))
}

#[cfg(test)]
mod tests;
