//! Radiance .hdr pixels, decoded and encoded a row per task. The image crate reads the header
//! (and stays the reader of anything this path does not take, for its error messages), but it
//! works one scanline at a time through an RGB f32 copy, with a log2 and divisions per texel
//! when writing: at 4K, half of a conversion's decode time and 100 MB of memory, and the
//! slowest encoder of all. Here the scanlines' starts are found first (a large file walked in
//! pieces in parallel, see `line_starts`), then rows decode in parallel, to the crate's values
//! bit for bit; rows encode in parallel to the same run-length scanlines any Radiance reader
//! takes.
//!
//! Split by stage, so each part can be read with what it depends on: `lines` finds and walks
//! the scanlines, `texels` turns their bytes into light, `write` and `runs` make a file.

#![warn(missing_docs)]

mod lines;
mod runs;
pub mod stream;
mod texels;
mod write;

#[cfg(test)]
mod encode_tests;
#[cfg(test)]
mod tests;

pub use write::encode;

use super::{FileFormat, Meta, ReadOptions};
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use ::image::codecs::hdr::HdrDecoder;
use ::image::ImageDecoder;
use glam::Vec4;
use lines::{line_starts, scanline};
use rayon::prelude::*;
use std::io::Cursor;
use std::path::Path;
use texels::texels;

/// The image, or None when the image crate should read this file instead (a header it
/// rejects, with its error message, or an empty image).
pub fn decode(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Option<Result<(Image, Meta)>> {
    let (w, h, first) = header(bytes)?;
    if let Err(e) = opts.limits.check(path, w as u64, h as u64) {
        return Some(Err(e));
    }
    // Said here, before any pixel memory: the crate's reader would allocate the whole
    // image first.
    let starts = match starts(bytes, first, (w, h), path) {
        Ok(starts) => starts,
        Err(e) => return Some(Err(e)),
    };
    let mut img = Image::new(w, h);
    img.pixels
        .par_chunks_mut(w)
        .zip(starts.par_iter())
        .for_each_init(
            || vec![0u8; 4 * w],
            |planes, (row, &start)| decode_row(bytes, start, planes, row),
        );
    Some(Ok((img, meta())))
}

/// Width, height and where the pixels start, from the header as the image crate reads it;
/// None where it rejects it (any orientation but -Y +X among them), or panics (caught), or the
/// image is empty: the image crate's path then says why.
fn header(bytes: &[u8]) -> Option<(usize, usize, usize)> {
    let mut cursor = Cursor::new(bytes);
    let (w, h) = super::guard::caught(|| HdrDecoder::new(&mut cursor).ok().map(|d| d.dimensions()))
        .ok()??;
    // The header reader stops right after the dimensions line: the pixels start there.
    Some((w as usize, h as usize, cursor.position() as usize))
}

/// Where each scanline starts, or the error line naming the first bad one.
fn starts(bytes: &[u8], first: usize, (w, h): (usize, usize), path: &Path) -> Result<Vec<usize>> {
    line_starts(bytes, first, w, h).map_err(|y| {
        Error::file(
            path,
            format!(
                "cannot decode Radiance HDR: scanline {} of {h} is truncated or malformed",
                y + 1
            ),
        )
    })
}

/// The texels of the scanline at `start` (found by `line_starts`) into `row`, through
/// `planes` (4 bytes a texel).
fn decode_row(bytes: &[u8], start: usize, planes: &mut [u8], row: &mut [Vec4]) {
    let w = row.len();
    let done = scanline(bytes, start, w, Some(planes));
    debug_assert!(done.is_some(), "a scanned line decodes");
    let (r, rest) = planes.split_at(w);
    let (g, rest) = rest.split_at(w);
    let (b, e) = rest.split_at(w);
    texels(r, g, b, e, row);
}

/// What `io::read` says of a .hdr file.
pub(crate) fn meta() -> Meta {
    Meta {
        file_format: FileFormat::Hdr,
        pixel_format: super::raster::pixel_format_name(::image::ColorType::Rgb32F, FileFormat::Hdr),
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values: 0,
        stored_levels: 1,
        declared: None,
        undo: Default::default(),
        part: None,
    }
}
