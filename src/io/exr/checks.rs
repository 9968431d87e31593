//! What the exr crate is never trusted with: the headers, the chunk table and every chunk
//! checked against the file's bytes (each attribute and chunk inside the file, every block of
//! every part present exactly once, DWA section sizes within what the chunk and its block
//! allow) before any of it reaches the crate.

use super::guarded;
use exr::block::chunk::{
    Chunk, CompressedBlock, CompressedScanLineBlock, CompressedTileBlock, TileCoordinates,
};
use exr::meta::attribute::IntegerBounds;
use exr::meta::header::Header;
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::*;
use std::collections::HashMap;
use std::io::Cursor;

fn u32_at(bytes: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(
        bytes.get(at..at.checked_add(4)?)?.try_into().ok()?,
    ))
}

fn u64_at(bytes: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(
        bytes.get(at..at.checked_add(8)?)?.try_into().ok()?,
    ))
}

/// The last compression method the exr crate decodes: DWAB (9).
const LAST_KNOWN_COMPRESSION: u8 = 9;

/// The message for a compression method past DWAB that is not decoded: named as OpenEXR 3.5
/// numbers them.
fn unsupported_compression(method: u8) -> String {
    let name = match method {
        10 => "HTJ2K256",
        11 => "HTJ2K32",
        12 => "LJ2K",
        _ => "unknown",
    };
    format!(
        "unsupported compression ({name}, method {method}): save it with ZIP, PIZ or DWAB \
         (oiiotool IN --compression zip -o OUT)"
    )
}

/// The headers through the crate, after checking that each attribute lies inside the file
/// (and that its compression is one the crate knows, or ZSTD); where the chunk table starts
/// (after the headers); and which parts are ZSTD-compressed. The crate does not know ZSTD:
/// it is given those headers as uncompressed (ZSTD's blocks are single lines, as uncompressed
/// ones are), and each chunk is inflated by [`super::zstd::unpack`] before it reaches the crate.
pub(super) fn read_meta(bytes: &[u8]) -> std::result::Result<(MetaData, usize, Vec<bool>), String> {
    if bytes.get(..4) != Some(&[0x76, 0x2f, 0x31, 0x01]) || bytes.len() < 8 {
        return Err("not an OpenEXR file (no magic number)".into());
    }
    let multipart = u32_at(bytes, 4).is_some_and(|v| v & 0x1000 != 0);
    let truncated = || "the header is truncated".to_string();
    let mut at = 8;
    let mut zstd = Vec::new();
    loop {
        let mut zstd_at = None;
        // One header: attributes (name, type name, size, value) up to an empty name.
        let mut attributes = 0;
        loop {
            let zero = |from: usize| {
                bytes
                    .get(from..)
                    .and_then(|rest| rest.iter().position(|&b| b == 0))
                    .map(|i| from + i)
            };
            let name_end = zero(at).ok_or_else(truncated)?;
            if name_end == at {
                at += 1;
                break;
            }
            let type_end = zero(name_end + 1).ok_or_else(truncated)?;
            let size = u32_at(bytes, type_end + 1).ok_or_else(truncated)? as i32;
            let value = type_end + 5;
            if size < 0 || size as usize > bytes.len() - value.min(bytes.len()) {
                let name = String::from_utf8_lossy(&bytes[at..name_end]);
                return Err(format!(
                    "attribute {name:?} claims {size} bytes, more than the file holds"
                ));
            }
            // A compression newer than the exr crate knows is named, not called invalid.
            if &bytes[at..name_end] == b"compression" && size == 1 {
                match bytes.get(value) {
                    Some(&super::zstd::METHOD) => zstd_at = Some(value),
                    Some(&method) if method > LAST_KNOWN_COMPRESSION => {
                        return Err(unsupported_compression(method))
                    }
                    _ => {}
                }
            }
            at = value + size as usize;
            attributes += 1;
        }
        if attributes > 0 {
            zstd.push(zstd_at);
        }
        // A multi-part file ends its list of headers with an empty one.
        if !multipart || attributes == 0 {
            break;
        }
    }
    let meta = if zstd.iter().any(Option::is_some) {
        let mut headers = bytes[..at].to_vec();
        for &place in zstd.iter().flatten() {
            headers[place] = 0;
        }
        guarded(|| MetaData::read_from_buffered(Cursor::new(&headers), false))?
    } else {
        guarded(|| MetaData::read_from_buffered(Cursor::new(bytes), false))?
    };
    Ok((meta, at, zstd.iter().map(Option::is_some).collect()))
}

/// A checked chunk, its bytes left in the file (a 4K float panorama's are 70 MB, copied
/// once more for nothing before): its part, its block's place, its compressed bytes.
pub(super) struct RawChunk<'a> {
    /// The part (layer) it belongs to.
    pub part: usize,
    /// The block as the crate describes it, with no bytes.
    block: CompressedBlock,
    /// The block's pixels, relative to the part's data window (the crate's "absolute" block
    /// coordinates).
    pub bounds: IntegerBounds,
    /// The compressed bytes.
    pub data: &'a [u8],
}

impl RawChunk<'_> {
    /// The chunk as the exr crate reads it, its bytes copied.
    pub fn to_chunk(&self) -> Chunk {
        self.with_data(self.data.to_vec())
    }

    /// The chunk as the exr crate reads it, holding `data` (its bytes, inflated).
    pub fn with_data(&self, data: Vec<u8>) -> Chunk {
        let compressed_block = match &self.block {
            CompressedBlock::ScanLine(b) => CompressedBlock::ScanLine(CompressedScanLineBlock {
                y_coordinate: b.y_coordinate,
                compressed_pixels_le: data,
            }),
            CompressedBlock::Tile(b) => CompressedBlock::Tile(CompressedTileBlock {
                coordinates: b.coordinates,
                compressed_pixels_le: data,
            }),
            _ => unreachable!("read_chunks makes flat blocks only"),
        };
        Chunk {
            layer_index: self.part,
            compressed_block,
        }
    }

    /// The block's coordinates (tile and level indices) as the crate computes them.
    pub fn tile(&self, header: &Header) -> std::result::Result<TileCoordinates, String> {
        guarded(|| header.get_block_data_indices(&self.block))
    }
}

/// Every chunk of the file, where the chunk table points, after checking that each lies
/// inside the file, that every block of every part is there exactly once (two chunks
/// claiming one position made the image depend on which thread finished last), and that a
/// DWA chunk's section sizes fit the chunk and its block. In table order; the chunks' fields
/// are read here (what the crate's `Chunk::read` checks, checked likewise), their bytes are
/// not copied.
pub(super) fn read_chunks<'a>(
    bytes: &'a [u8],
    meta: &MetaData,
    table_start: usize,
) -> std::result::Result<Vec<RawChunk<'a>>, String> {
    let counts: Vec<usize> = meta.headers.iter().map(|h| h.chunk_count).collect();
    let total = counts
        .iter()
        .try_fold(0usize, |sum, &n| sum.checked_add(n))
        .filter(|&n| n <= (bytes.len() - table_start.min(bytes.len())) / 8)
        .ok_or_else(|| "the chunk table is larger than the file".to_string())?;
    let table_end = table_start + total * 8;
    let multipart = meta.requirements.is_multilayer();
    let mut chunks = Vec::with_capacity(total);
    let mut ranges = Vec::with_capacity(total);
    let mut entry = table_start;
    for (part, header) in meta.headers.iter().enumerate() {
        if header.deep {
            return Err("deep data is not supported".into());
        }
        let largest = guarded(|| Ok(header.max_block_byte_size()))?;
        // Each block position of the part, and whether a chunk has claimed it yet.
        let mut unclaimed: HashMap<(usize, usize, usize, usize), bool> = guarded(|| {
            Ok(header
                .blocks_increasing_y_order()
                .take(counts[part] + 1)
                .map(|t| {
                    let (i, l) = (t.location.tile_index, t.location.level_index);
                    ((i.0, i.1, l.0, l.1), true)
                })
                .collect())
        })?;
        if unclaimed.len() != counts[part] {
            return Err(format!(
                "part {part} has {} blocks but its chunk table lists {} (blocks missing)",
                unclaimed.len(),
                counts[part]
            ));
        }
        let tiled = matches!(header.blocks, BlockDescription::Tiles(_));
        let what = if tiled { "tile" } else { "scan-line block" };
        for index in 0..counts[part] {
            let offset = u64_at(bytes, entry).unwrap_or(0);
            entry += 8;
            let at = usize::try_from(offset)
                .ok()
                .filter(|&at| at >= table_end && at < bytes.len())
                .ok_or_else(|| {
                    format!(
                        "{what} {index} of part {part} is missing (its chunk offset {offset} \
                         is outside the pixel data)"
                    )
                })?;
            let at_chunk = TableEntry {
                bytes,
                at,
                part,
                multipart,
                tiled,
            };
            let (data, end) = at_chunk.data(largest)?;
            ranges.push((at, end));
            let block = at_chunk.block(header)?;
            let (tile, bounds) = guarded(|| {
                let tile = header.get_block_data_indices(&block)?;
                Ok((tile, header.get_absolute_block_pixel_coordinates(tile)?))
            })?;
            claim(&mut unclaimed, tile, what, part)?;
            if matches!(
                header.compression,
                Compression::DWAA(_) | Compression::DWAB(_)
            ) {
                check_dwa(data, header, bounds.size)
                    .map_err(|e| format!("DWA chunk at offset {at}: {e}"))?;
            }
            chunks.push(RawChunk {
                part,
                block,
                bounds,
                data,
            });
        }
    }
    // Chunks follow one another: none reaches into the next.
    ranges.sort_unstable();
    if let Some(pair) = ranges.windows(2).find(|p| p[0].1 > p[1].0) {
        return Err(format!(
            "the chunks at offsets {} and {} overlap",
            pair[0].0, pair[1].0
        ));
    }
    Ok(chunks)
}

/// Marks the block `tile` of `part` as held by a chunk: an error where another chunk holds it
/// already or the part has no such block.
fn claim(
    unclaimed: &mut HashMap<(usize, usize, usize, usize), bool>,
    tile: TileCoordinates,
    what: &str,
    part: usize,
) -> std::result::Result<(), String> {
    let (i, l) = (tile.tile_index, tile.level_index);
    match unclaimed.get_mut(&(i.0, i.1, l.0, l.1)) {
        Some(open) if *open => {
            *open = false;
            Ok(())
        }
        Some(_) => Err(format!(
            "two chunks hold {what} ({}, {}) at level ({}, {}) of part {part}: \
             duplicate (overlapping) {what}s, so others are missing",
            i.0, i.1, l.0, l.1
        )),
        None => Err(format!(
            "a chunk holds {what} ({}, {}) at level ({}, {}), which part {part} \
             does not have",
            i.0, i.1, l.0, l.1
        )),
    }
}

/// One chunk of a file's chunk table: its offset `at` in `bytes`, its part, and how the
/// file lays chunks out (a part number first in multipart files, tiles' four coordinates).
struct TableEntry<'a> {
    bytes: &'a [u8],
    at: usize,
    part: usize,
    multipart: bool,
    tiled: bool,
}

impl<'a> TableEntry<'a> {
    /// Its data and where it ends, the byte count checked before the crate reads that many
    /// bytes: positive, within the file and no more than the part's `largest` block.
    fn data(&self, largest: usize) -> std::result::Result<(&'a [u8], usize), String> {
        let (bytes, at, part) = (self.bytes, self.at, self.part);
        let mut field = at + if self.multipart { 4 } else { 0 } + if self.tiled { 16 } else { 4 };
        if self.multipart && u32_at(bytes, at) != Some(part as u32) {
            return Err(format!(
                "part {part}'s chunk table points at offset {at}, a chunk of another part"
            ));
        }
        let declared = u32_at(bytes, field).map_or(-1, |v| v as i32);
        field += 4;
        if declared <= 0 {
            return Err(format!(
                "chunk at offset {at} claims {declared} bytes of data"
            ));
        }
        if declared as usize > bytes.len() - field.min(bytes.len()) {
            return Err(format!(
                "chunk at offset {at} claims {declared} bytes, more than the file holds"
            ));
        }
        if declared as usize > largest {
            return Err(format!(
                "chunk at offset {at} claims {declared} bytes, more than a block of part \
                 {part} holds ({largest})"
            ));
        }
        let end = field + declared as usize;
        Ok((&bytes[field..end], end))
    }

    /// The block it says it holds, from the fields before its byte count: the tile's four
    /// coordinates, or the first line (on a block boundary of `header`'s).
    fn block(&self, header: &Header) -> std::result::Result<CompressedBlock, String> {
        let at = self.at;
        let head = at + if self.multipart { 4 } else { 0 };
        let int = |i: usize| u32_at(self.bytes, head + 4 * i).map_or(-1, |v| v as i32);
        if !self.tiled {
            let lines = header.compression.scan_lines_per_block() as i64;
            let first = int(0);
            if (first as i64 - header.own_attributes.layer_position.1 as i64) % lines != 0 {
                return Err(format!(
                    "scan-line block at offset {at} starts at line {first}, not a block boundary"
                ));
            }
            return Ok(CompressedBlock::ScanLine(CompressedScanLineBlock {
                y_coordinate: first,
                compressed_pixels_le: Vec::new(),
            }));
        }
        let [x, y, lx, ly] = [0, 1, 2, 3].map(int);
        if x < 0 || y < 0 || !(0..=31).contains(&lx) || !(0..=31).contains(&ly) {
            return Err(format!(
                "tile at offset {at} claims tile ({x}, {y}) at level ({lx}, {ly})"
            ));
        }
        Ok(CompressedBlock::Tile(CompressedTileBlock {
            coordinates: TileCoordinates {
                tile_index: Vec2(x as usize, y as usize),
                level_index: Vec2(lx as usize, ly as usize),
            },
            compressed_pixels_le: Vec::new(),
        }))
    }
}

/// The 11 counters that open a DWA chunk (after OpenEXR's `DataSizesSingle`): version,
/// UNKNOWN raw and packed sizes, AC packed, DC packed, RLE packed, RLE token and raw sizes,
/// AC and DC value counts, AC coder. The crate allocates from the sizes and counts before
/// it can find them wrong (the abort on a 50 PB allocation), and takes some that are too
/// large without a word, so each must be what the block holds: the packed sections within
/// the chunk, the UNKNOWN and RLE raw sizes those of the block's channels of each scheme, a
/// DC value per 8x8 block of each lossy channel and at most 63 AC values, and RLE tokens at
/// most twice the bytes they expand to.
pub(super) fn check_dwa(
    data: &[u8],
    header: &Header,
    size: Vec2<usize>,
) -> std::result::Result<(), String> {
    let block_bytes = size.area() * header.channels.bytes_per_pixel;
    if data.is_empty() || data.len() == block_bytes {
        return Ok(()); // stored as it is
    }
    let field = |i: usize| u64_at(data, i * 8).ok_or("the chunk is shorter than its DWA header");
    let (version, unknown_raw, unknown_packed) = (field(0)?, field(1)?, field(2)?);
    let (ac_packed, dc_packed, rle_packed) = (field(3)?, field(4)?, field(5)?);
    let (rle_tokens, rle_raw) = (field(6)?, field(7)?);
    let (ac_count, dc_count, _coder) = (field(8)?, field(9)?, field(10)?);
    if version > 2 {
        return Err(format!("unknown DWA version {version}"));
    }
    let mut body = 88;
    let rules = if version == 2 {
        let size = data
            .get(88..90)
            .map(|b| u16::from_le_bytes([b[0], b[1]]) as usize)
            .filter(|&n| n >= 2 && 88 + n <= data.len())
            .ok_or("its channel rules overrun the chunk")?;
        body += size;
        dwa_rules(&data[90..88 + size])?
    } else {
        legacy_dwa_rules()
    };
    let body = (data.len() - body) as u64;
    let packed = [unknown_packed, ac_packed, dc_packed, rle_packed]
        .iter()
        .try_fold(0u64, |sum, &n| sum.checked_add(n));
    if packed != Some(body) {
        return Err(format!(
            "its sections claim {unknown_packed} + {ac_packed} + {dc_packed} + {rle_packed} \
             bytes, not its {body}"
        ));
    }
    // Bytes of UNKNOWN and RLE channels, 8x8 blocks of lossy ones.
    let (mut unknown, mut rle, mut blocks) = (0u64, 0u64, 0u64);
    for c in &header.channels.list {
        let name = super::select::text(&c.name);
        let suffix = name.rsplit('.').next().unwrap_or_default();
        let scheme = rules
            .iter()
            .rfind(|r| {
                r.2 == c.sample_type
                    && if r.3 {
                        suffix.eq_ignore_ascii_case(&r.0)
                    } else {
                        suffix == r.0
                    }
            })
            .map_or(DwaScheme::Unknown, |r| r.1);
        let (w, h) = (
            size.0.div_ceil(c.sampling.0.max(1)),
            size.1.div_ceil(c.sampling.1.max(1)),
        );
        let bytes = (w * h * c.sample_type.bytes_per_sample()) as u64;
        match scheme {
            DwaScheme::Unknown => unknown += bytes,
            DwaScheme::Rle => rle += bytes,
            DwaScheme::Lossy => blocks += (w.div_ceil(8) * h.div_ceil(8)) as u64,
        }
    }
    let wrong = |name: &str, value: u64, want: u64| {
        (value != want).then(|| format!("it claims {value} {name}, its block holds {want}"))
    };
    let problem = wrong("UNKNOWN bytes", unknown_raw, unknown)
        .or_else(|| wrong("RLE bytes", rle_raw, rle))
        .or_else(|| wrong("DC values", dc_count, blocks))
        .or_else(|| {
            (ac_count > 63 * blocks).then(|| {
                format!(
                    "it claims {ac_count} AC values, more than its block holds ({})",
                    63 * blocks
                )
            })
        })
        .or_else(|| {
            (rle_tokens > 2 * rle + 16)
                .then(|| format!("it claims {rle_tokens} RLE token bytes for {rle} bytes"))
        })
        .or_else(|| {
            // A section with nothing in it has nothing packed either.
            [
                ("UNKNOWN", unknown_raw, unknown_packed),
                ("AC", ac_count, ac_packed),
                ("DC", dc_count, dc_packed),
                ("RLE", rle_raw, rle_packed.max(rle_tokens)),
            ]
            .iter()
            .find(|s| s.1 == 0 && s.2 != 0)
            .map(|s| format!("its empty {} section claims {} bytes", s.0, s.2))
        });
    problem.map_or(Ok(()), Err)
}

#[derive(Clone, Copy, PartialEq)]
enum DwaScheme {
    Unknown,
    Lossy,
    Rle,
}

/// A DWA channel rule: name suffix, scheme, sample type, case-insensitive.
type DwaRule = (String, DwaScheme, SampleType, bool);

/// The rules of a version-2 DWA chunk: each a NUL-terminated suffix (at most 128 bytes), a
/// flags byte (CSC index + 1 in the high nibble, scheme in bits 2-3, case-insensitive in
/// bit 0) and a sample type byte.
fn dwa_rules(mut data: &[u8]) -> std::result::Result<Vec<DwaRule>, String> {
    let corrupt = || "a corrupt DWA channel rule".to_string();
    let mut rules = Vec::new();
    while !data.is_empty() {
        let end = data.iter().position(|&b| b == 0).filter(|&n| n <= 128);
        let end = end.ok_or_else(corrupt)?;
        let suffix = String::from_utf8_lossy(&data[..end]).into_owned();
        let [flags, kind] = *data.get(end + 1..end + 3).ok_or_else(corrupt)? else {
            return Err(corrupt());
        };
        data = &data[end + 3..];
        let scheme = match (flags >> 2) & 3 {
            0 => DwaScheme::Unknown,
            1 => DwaScheme::Lossy,
            2 => DwaScheme::Rle,
            _ => return Err(corrupt()),
        };
        let kind = match kind {
            0 => SampleType::U32,
            1 => SampleType::F16,
            2 => SampleType::F32,
            _ => return Err(corrupt()),
        };
        if flags >> 4 > 3 {
            return Err(corrupt());
        }
        rules.push((suffix, scheme, kind, flags & 1 != 0));
    }
    Ok(rules)
}

/// The rules that DWA chunks before version 2 imply.
fn legacy_dwa_rules() -> Vec<DwaRule> {
    let mut rules = Vec::new();
    for suffix in [
        "r", "red", "g", "grn", "green", "b", "blu", "blue", "y", "by", "ry",
    ] {
        for kind in [SampleType::F16, SampleType::F32] {
            rules.push((suffix.to_string(), DwaScheme::Lossy, kind, true));
        }
    }
    for kind in [SampleType::U32, SampleType::F16, SampleType::F32] {
        rules.push(("a".to_string(), DwaScheme::Rle, kind, true));
    }
    rules
}
