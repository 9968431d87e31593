//! OpenEXR's ZSTD compression (method 13, OpenEXR 3.5): a chunk of one scan line (or one
//! tile) is a 24-byte prefix (the magic "zstd-exr", a format version, flags, the zstd frame's
//! size) and a zstd frame. The frame inflates to one or two segments, each a length and then
//! bytes split into byte planes (Blosc's shuffle): first every 16-bit channel row of the
//! chunk, then every 32-bit one ("sorted"). Format 2 with flag 1 also stores each channel row
//! as differences of consecutive samples (as integers, wrapping). Undone here back into the
//! layout an uncompressed chunk has (for each line, each channel's row in header order), so
//! the rest of the reader takes the chunk as uncompressed. A chunk that would not shrink is
//! stored as it is, as for every compression.

use exr::meta::attribute::IntegerBounds;
use exr::meta::header::Header;

/// OpenEXR's number for ZSTD in the header's `compression` attribute.
pub(super) const METHOD: u8 = 13;

const MAGIC: &[u8; 8] = b"zstd-exr";
const PREFIX: usize = 24;
/// Format 2's flag: each sorted channel row is stored as differences.
const DELTA: u32 = 1;

/// Each (line, channel) row of a chunk, line by line: its sample count and bytes per sample,
/// as OpenEXR packs them (a subsampled channel has samples only on lines its y sampling
/// keeps). Shared with `planes`, which scatters the rows this layout holds.
pub(super) fn rows(header: &Header, bounds: &IntegerBounds) -> Vec<(usize, usize)> {
    let (w, h) = (bounds.size.0, bounds.size.1);
    let mut rows = Vec::with_capacity(h * header.channels.list.len());
    for line in 0..h {
        let y = bounds.position.1 as i64 + line as i64;
        for c in &header.channels.list {
            let (sx, sy) = (c.sampling.0.max(1), c.sampling.1.max(1));
            let n = if y.rem_euclid(sy as i64) == 0 {
                w / sx
            } else {
                0
            };
            rows.push((n, c.sample_type.bytes_per_sample()));
        }
    }
    rows
}

/// The error for a corrupt chunk, saying `why`.
fn corrupt(why: &str) -> String {
    format!("the ZSTD chunk is corrupt ({why})")
}

/// A ZSTD chunk's bytes as an uncompressed chunk holds them, into `out` (`inner` is scratch
/// for the inflated frame, `inflate` a reused decompressor).
pub(super) fn unpack(
    data: &[u8],
    header: &Header,
    bounds: &IntegerBounds,
    inflate: &mut Option<zstd::bulk::Decompressor<'static>>,
    inner: &mut Vec<u8>,
    out: &mut Vec<u8>,
) -> Result<(), String> {
    let rows = rows(header, bounds);
    let expected: usize = rows.iter().map(|(n, b)| n * b).sum();
    out.clear();
    if data.len() == expected {
        out.extend_from_slice(data);
        return Ok(());
    }
    let (delta, frame) = prefix(data)?;
    // Two length fields at most, then the samples.
    inner.resize(expected + 16, 0);
    let decompressor = match inflate {
        Some(d) => d,
        None => inflate.insert(zstd::bulk::Decompressor::new().map_err(|e| e.to_string())?),
    };
    let n = decompressor
        .decompress_to_buffer(frame, &mut inner[..])
        .map_err(|e| corrupt(&format!("zstd: {e}")))?;
    let mut sorted = unshuffle(&inner[..n], &rows, expected)?;
    // Where each (line, channel) row sits in the sorted layout.
    let mut place = vec![0usize; rows.len()];
    let mut next = 0;
    for k in [2, 4] {
        for (i, &(n, b)) in rows.iter().enumerate() {
            if b == k {
                place[i] = next;
                next += n * b;
            }
        }
    }
    if delta {
        for (i, &(n, b)) in rows.iter().enumerate() {
            undo_delta(&mut sorted[place[i]..place[i] + n * b], b);
        }
    }
    out.reserve(expected);
    for (i, &(n, b)) in rows.iter().enumerate() {
        out.extend_from_slice(&sorted[place[i]..place[i] + n * b]);
    }
    Ok(())
}

/// The 24-byte prefix checked: whether rows are stored as differences (format 2, flag 1),
/// and the zstd frame it sizes.
fn prefix(data: &[u8]) -> Result<(bool, &[u8]), String> {
    if data.len() < PREFIX || &data[..8] != MAGIC {
        return Err(corrupt("no zstd-exr prefix"));
    }
    let word = |at: usize| u32::from_le_bytes(data[at..at + 4].try_into().unwrap());
    let (format, flags) = (word(8), word(12));
    let size = u64::from_le_bytes(data[16..24].try_into().unwrap());
    if !(1..=2).contains(&format) || flags & !DELTA != 0 || (format == 1 && flags != 0) {
        return Err(format!(
            "the ZSTD chunk has format {format} with flags {flags}, which this reader does not know"
        ));
    }
    let frame = usize::try_from(size)
        .ok()
        .and_then(|s| data.get(PREFIX..PREFIX.checked_add(s)?))
        .ok_or_else(|| corrupt("its frame is larger than the chunk"))?;
    Ok((format == 2 && flags & DELTA != 0, frame))
}

/// The inflated frame's segments (a length, then byte planes) into the sorted layout: 16-bit
/// rows first, then 32-bit rows, each in (line, channel) order.
fn unshuffle(inner: &[u8], rows: &[(usize, usize)], expected: usize) -> Result<Vec<u8>, String> {
    let halves: usize = rows.iter().filter(|r| r.1 == 2).map(|(n, _)| n * 2).sum();
    let mut sorted = vec![0u8; expected];
    let mut at = 0;
    for (from, len, k) in [(0, halves, 2), (halves, expected - halves, 4)] {
        if len == 0 {
            continue;
        }
        let stated = inner
            .get(at..at + 8)
            .map(|b| u64::from_le_bytes(b.try_into().unwrap()));
        if stated != Some(len as u64) {
            return Err(corrupt("a segment's length is not its channels' size"));
        }
        let planes = inner
            .get(at + 8..at + 8 + len)
            .ok_or_else(|| corrupt("a segment is cut short"))?;
        at += 8 + len;
        let count = len / k;
        let dst = &mut sorted[from..from + len];
        for (plane, bytes) in planes.chunks_exact(count).enumerate() {
            for (i, &b) in bytes.iter().enumerate() {
                dst[i * k + plane] = b;
            }
        }
    }
    if at != inner.len() {
        return Err(corrupt("bytes after its segments"));
    }
    Ok(sorted)
}

/// A row of `b`-byte samples stored as differences of consecutive samples, summed back
/// (as integers, wrapping).
fn undo_delta(row: &mut [u8], b: usize) {
    if b == 2 {
        let mut sum = 0u16;
        for v in row.chunks_exact_mut(2) {
            sum = sum.wrapping_add(u16::from_le_bytes([v[0], v[1]]));
            v.copy_from_slice(&sum.to_le_bytes());
        }
    } else {
        let mut sum = 0u32;
        for v in row.chunks_exact_mut(4) {
            sum = sum.wrapping_add(u32::from_le_bytes(v.try_into().unwrap()));
            v.copy_from_slice(&sum.to_le_bytes());
        }
    }
}
