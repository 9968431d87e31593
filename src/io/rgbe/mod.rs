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
use lines::{line_starts, scanline};
use rayon::prelude::*;
use std::io::Cursor;
use std::path::Path;
use texels::texels;

/// The image, or None when the image crate should read this file instead (a header it
/// rejects, with its error message, or an empty image).
pub fn decode(bytes: &[u8], path: &Path, opts: &ReadOptions) -> Option<Result<(Image, Meta)>> {
    let mut cursor = Cursor::new(bytes);
    // A header that panics the crate's reader (caught) goes to the image crate's path too,
    // which says why, caught likewise.
    let (w, h) = super::guard::caught(|| HdrDecoder::new(&mut cursor).ok().map(|d| d.dimensions()))
        .ok()??;
    let (w, h) = (w as usize, h as usize);
    if let Err(e) = opts.limits.check(path, w as u64, h as u64) {
        return Some(Err(e));
    }
    // The header reader stops right after the dimensions line: the pixels start there.
    let starts = match line_starts(bytes, cursor.position() as usize, w, h) {
        Ok(starts) => starts,
        // Said here, before any pixel memory: the crate's reader would allocate the whole
        // image first.
        Err(y) => {
            return Some(Err(Error::file(
                path,
                format!(
                    "cannot decode Radiance HDR: scanline {} of {h} is truncated or malformed",
                    y + 1
                ),
            )))
        }
    };
    let mut img = Image::new(w, h);
    img.pixels
        .par_chunks_mut(w)
        .zip(starts.par_iter())
        .for_each_init(
            || vec![0u8; 4 * w],
            |planes, (row, &start)| {
                let done = scanline(bytes, start, w, Some(planes));
                debug_assert!(done.is_some(), "a scanned line decodes");
                let (r, rest) = planes.split_at(w);
                let (g, rest) = rest.split_at(w);
                let (b, e) = rest.split_at(w);
                texels(r, g, b, e, row);
            },
        );
    let meta = Meta {
        file_format: FileFormat::Hdr,
        pixel_format: super::raster::pixel_format_name(::image::ColorType::Rgb32F, FileFormat::Hdr),
        color_space: ColorSpace::Linear,
        hdr: true,
        replaced_values: 0,
        stored_levels: 1,
        declared: None,
        undo: Default::default(),
        part: None,
    };
    Some(Ok((img, meta)))
}
