//! A KTX2 file's blocks and levels, checked against the file before anything is allocated,
//! and the levels inflated (Zstandard) within their claimed size.

use super::{in_file, le_u32, le_u64, HEADER_LEN, LEVEL_ENTRY_LEN};
use crate::error::{Error, Result};
use crate::io::container::Shape;
use std::path::Path;

/// The bounds of the Data Format Descriptor, the key/value data and the supercompression
/// data, each `(offset, length)`: only their bounds matter to the reader, the vkFormat says
/// everything about the texels.
pub(super) fn check_blocks(
    bytes: &[u8],
    path: &Path,
    (dfd_offset, dfd_len): (u64, u64),
    (kvd_offset, kvd_len): (u64, u64),
    (sgd_offset, sgd_len): (u64, u64),
) -> Result<()> {
    let err = |msg: String| Error::file(path, msg);
    let file_len = bytes.len();
    // Data Format Descriptor and key/value data: only their bounds matter to this reader,
    // the vkFormat says everything about the texels.
    if dfd_len < 4 {
        return Err(err(
            "invalid KTX2 file: it has no data format descriptor".into()
        ));
    }
    if !in_file(dfd_offset, dfd_len, file_len) {
        return Err(err(format!(
            "invalid KTX2 file: its data format descriptor ({dfd_len} bytes at {dfd_offset}) does not fit in the file ({file_len} bytes)"
        )));
    }
    let dfd_total = le_u32(bytes, dfd_offset as usize).unwrap_or(0);
    if dfd_total as u64 != dfd_len {
        return Err(err(format!(
            "invalid KTX2 file: dfdTotalSize is {dfd_total} but dfdByteLength is {dfd_len}"
        )));
    }
    if !in_file(kvd_offset, kvd_len, file_len) {
        return Err(err(format!(
            "invalid KTX2 file: its key/value data ({kvd_len} bytes at {kvd_offset}) does not fit in the file ({file_len} bytes)"
        )));
    }
    if !in_file(sgd_offset, sgd_len, file_len) {
        return Err(err(format!(
            "invalid KTX2 file: its supercompression data ({sgd_len} bytes at {sgd_offset}) does not fit in the file ({file_len} bytes)"
        )));
    }
    Ok(())
}

/// Every level's place and size in the file (`(offset, length)` of its stored bytes, as the
/// level index says), checked before anything is allocated.
pub(super) fn level_spans(
    bytes: &[u8],
    shape: &Shape,
    zstd: bool,
    path: &Path,
) -> Result<Vec<(usize, usize)>> {
    let err = |msg: String| Error::file(path, msg);
    let file_len = bytes.len();
    // Every level's place and size, checked before anything is allocated.
    let mut spans = Vec::with_capacity(shape.levels);
    for l in 0..shape.levels {
        let entry = HEADER_LEN + l * LEVEL_ENTRY_LEN;
        let offset = le_u64(bytes, entry).unwrap_or(0);
        let len = le_u64(bytes, entry + 8).unwrap_or(0);
        let uncompressed = le_u64(bytes, entry + 16).unwrap_or(0);
        let expected = shape.level_bytes(l);
        if uncompressed != expected || (!zstd && len != expected) {
            let take = if shape.cube { "take" } else { "takes" };
            return Err(err(format!(
                "invalid level index: level {l} claims {len} bytes ({uncompressed} uncompressed), but {} {take} {expected}",
                shape.holds(l)
            )));
        }
        if !in_file(offset, len, file_len) {
            return Err(err(format!(
                "truncated KTX2 file: level {l} needs bytes {offset} to {}, but the file has {file_len}",
                offset.saturating_add(len)
            )));
        }
        // Both fit in the file, so in usize.
        spans.push((offset as usize, len as usize));
    }
    Ok(spans)
}

/// The levels of `spans` as stored, or inflated from Zstandard (never past their size).
pub(super) fn inflate<'a>(
    bytes: &'a [u8],
    spans: &[(usize, usize)],
    shape: &Shape,
    zstd: bool,
    path: &Path,
) -> Result<Vec<std::borrow::Cow<'a, [u8]>>> {
    let err = |msg: String| Error::file(path, msg);
    use rayon::prelude::*;
    spans
        .par_iter()
        .enumerate()
        .map(|(l, &(offset, len))| {
            let stored = &bytes[offset..offset + len];
            if !zstd {
                return Ok(std::borrow::Cow::Borrowed(stored));
            }
            // Streamed, so memory grows with what really inflates (a tiny file cannot make
            // us reserve its whole claimed size), and never past one byte over the claim.
            use std::io::Read;
            let expected = shape.level_bytes(l) as usize;
            let mut plain = Vec::new();
            zstd::stream::read::Decoder::with_buffer(stored)
                .and_then(|d| d.take(expected as u64 + 1).read_to_end(&mut plain))
                .map_err(|e| {
                    err(format!(
                        "level {l}: its Zstandard data does not decompress: {}",
                        crate::io::io_msg(&e)
                    ))
                })?;
            if plain.len() != expected {
                return Err(err(format!(
                    "level {l}: its Zstandard data holds {} bytes, but {} take {expected}",
                    plain.len(),
                    shape.holds(l)
                )));
            }
            Ok(std::borrow::Cow::Owned(plain))
        })
        .collect()
}
