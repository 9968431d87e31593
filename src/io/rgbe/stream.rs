//! A Radiance .hdr decoded in bands of rows (issue 47), for `io::bands`: the file is read and
//! its scanlines found as the whole read finds them (`line_starts`), then each band's rows are
//! decoded on every thread to the whole read's values, bit for bit, and handed to a fold. A
//! file the whole read would not take this way (a header the image crate rejects, any
//! orientation but -Y +X, a pipe, a name that says another format) is not offered.

use super::{decode_row, header, starts};
use crate::error::{Error, Result};
use crate::io::band_shape::Shape;
use crate::io::{FileFormat, ReadOptions};
use glam::Vec4;
use rayon::prelude::*;
use std::path::Path;

/// A .hdr file read whole, its scanlines found.
pub struct Bands<'a> {
    bytes: &'a [u8],
    starts: Vec<usize>,
    width: usize,
}

impl Bands<'_> {
    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.starts.len())
    }

    /// The bands of `lines` rows that `pick` keeps, decoded in parallel, each handed to
    /// `fold(first row, rows)`: the folds in band order (None where not picked).
    pub fn map<T: Send>(
        &self,
        lines: usize,
        pick: &(dyn Fn(usize) -> bool + Sync),
        fold: &(dyn Fn(usize, &[Vec4]) -> T + Sync),
    ) -> Vec<Option<T>> {
        let (w, h) = self.size();
        let lines = lines.max(1);
        (0..h.div_ceil(lines))
            .into_par_iter()
            .map_init(
                || (vec![0u8; 4 * w], Vec::new()),
                |(planes, buf), i| {
                    if !pick(i) {
                        return None;
                    }
                    let y0 = i * lines;
                    let n = h.min(y0 + lines) - y0;
                    buf.resize(n * w, Vec4::ZERO);
                    for (row, &start) in buf.chunks_exact_mut(w).zip(&self.starts[y0..y0 + n]) {
                        decode_row(self.bytes, start, planes, row);
                    }
                    Some(fold(y0, &buf[..n * w]))
                },
            )
            .collect()
    }
}

/// Whether `opts` read `path` as a streamed job may: a regular file (a pipe would block the
/// read of its magic number) whose first bytes say Radiance and whose name says nothing else.
fn offered(path: &Path, opts: &ReadOptions) -> bool {
    use std::io::Read;
    let regular = std::fs::metadata(path).is_ok_and(|m| m.is_file());
    if path == Path::new("-") || !opts.usual() || !regular {
        return false;
    }
    let mut magic = [0u8; 16];
    let read = std::fs::File::open(path).and_then(|mut f| f.read(&mut magic));
    let by_name = FileFormat::from_extension(path);
    read.is_ok_and(|n| FileFormat::from_magic(&magic[..n]) == Some(FileFormat::Hdr))
        && matches!(by_name, None | Some(FileFormat::Hdr))
}

/// The shape of `path` when `with_bands` would take it, from its header (the first 64 KiB);
/// None otherwise. Checks the size limits, not the memory.
pub fn shape(path: &Path, opts: &ReadOptions) -> Result<Option<Shape>> {
    use std::io::Read;
    if !offered(path, opts) {
        return Ok(None);
    }
    let file_bytes = crate::io::regular_file(path)?.len();
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(1 << 16).read_to_end(&mut head))
        .map_err(|e| Error::io(path, e))?;
    let Some((width, height, _)) = header(&head).filter(|&(w, h, _)| w > 0 && h > 0) else {
        return Ok(None); // the whole read says why
    };
    opts.limits
        .check_pixels(path, width as u64, height as u64)?;
    Ok(Some(Shape {
        width,
        height,
        block_lines: 1,
        // The scanlines' starts are held beside the file.
        file_bytes: file_bytes.saturating_add(height as u64 * 8),
    }))
}

/// Reads `path` (noted in the session) and hands its bands to `work` when [`shape`] takes
/// it; None otherwise (the caller decodes it whole). A truncated or malformed scanline is the
/// whole read's error, said before any pixel memory.
pub fn with_bands<R>(
    path: &Path,
    opts: &ReadOptions,
    work: impl FnOnce(&Bands) -> Result<R>,
) -> Result<Option<R>> {
    if !offered(path, opts) {
        return Ok(None);
    }
    opts.limits.session.note(path);
    let bytes = crate::io::read_file(path)?;
    let Some((w, h, first)) = header(&bytes).filter(|&(w, h, _)| w > 0 && h > 0) else {
        return Ok(None);
    };
    opts.limits.check_pixels(path, w as u64, h as u64)?;
    let bands = Bands {
        bytes: &bytes,
        starts: starts(&bytes, first, (w, h), path)?,
        width: w,
    };
    work(&bands).map(Some)
}
