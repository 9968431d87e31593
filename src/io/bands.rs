//! A panorama decoded in bands of rows, whatever its container (issue 47): the folds of
//! `convert::stream` and `info::stream` take an OpenEXR file of the common layout or a
//! Radiance .hdr of the usual orientation alike, so neither ever holds the whole float image.
//! Anything else is not offered here and goes to the whole read, which says why it fails.

use super::{exr, rgbe, Meta, ReadOptions};
use crate::error::Result;
use glam::Vec4;
use std::path::Path;

pub use super::band_shape::{Rows, Shape};

/// Rows already decoded as texels, handed out as planes.
struct TexelRows<'a> {
    rows: std::slice::ChunksExact<'a, Vec4>,
}

impl Rows for TexelRows<'_> {
    fn next_into(&mut self, planes: &mut [f32]) {
        let w = planes.len() / 4;
        let Some(row) = self.rows.next() else {
            planes.fill(0.0);
            return;
        };
        for (c, plane) in planes.chunks_exact_mut(w).enumerate() {
            for (v, p) in plane.iter_mut().zip(row) {
                *v = p[c];
            }
        }
    }
}

/// A checked file ready to be decoded band by band.
pub enum BandSource<'a> {
    /// An OpenEXR file of the common layout.
    Exr(&'a exr::stream::Bands<'a>),
    /// A Radiance .hdr, its scanlines found.
    Hdr(&'a rgbe::stream::Bands<'a>),
}

impl BandSource<'_> {
    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        match self {
            BandSource::Exr(b) => b.size(),
            BandSource::Hdr(b) => b.size(),
        }
    }

    /// The most lines one block holds: bands are a multiple of it.
    pub fn block_lines(&self) -> usize {
        match self {
            BandSource::Exr(b) => b.block_lines(),
            BandSource::Hdr(_) => 1,
        }
    }

    /// The bands of `lines` rows (a power of two, at least `block_lines`) that `pick` keeps,
    /// decoded in parallel as `io::read` decodes them, each handed to `fold(first row, rows)`:
    /// the folds in band order (None where not picked) and the count of values replaced.
    pub fn map<T: Send>(
        &self,
        path: &Path,
        lines: usize,
        pick: &(dyn Fn(usize) -> bool + Sync),
        fold: &(dyn Fn(usize, &[Vec4]) -> T + Sync),
    ) -> Result<(Vec<Option<T>>, usize)> {
        match self {
            BandSource::Exr(b) => b.map(path, lines, pick, fold),
            BandSource::Hdr(b) => Ok((b.map(lines, pick, fold), 0)),
        }
    }

    /// `map` with each band handed to `fold(first row, rows, its rows)` a row at a time, as
    /// planes: an OpenEXR file's straight from its blocks, never as texels.
    pub fn map_rows<T: Send>(
        &self,
        path: &Path,
        lines: usize,
        pick: &(dyn Fn(usize) -> bool + Sync),
        fold: &(dyn Fn(usize, usize, &mut dyn Rows) -> T + Sync),
    ) -> Result<(Vec<Option<T>>, usize)> {
        match self {
            BandSource::Exr(b) => b.map_rows(path, lines, pick, fold),
            BandSource::Hdr(b) => {
                let w = b.size().0;
                let texels = |y0: usize, rows: &[Vec4]| {
                    let n = rows.len() / w;
                    fold(
                        y0,
                        n,
                        &mut TexelRows {
                            rows: rows.chunks_exact(w),
                        },
                    )
                };
                Ok((b.map(lines, pick, &texels), 0))
            }
        }
    }

    /// What `io::read` says of the file, with `replaced` values sanitized.
    pub fn meta(&self, replaced: usize) -> Meta {
        match self {
            BandSource::Exr(b) => b.meta(replaced),
            BandSource::Hdr(_) => rgbe::meta(),
        }
    }
}

/// The shape of `path` when `with_bands` would take it (read as `opts` say), from its header;
/// None otherwise. Checks the size limits; the memory is the caller's to check
/// ([`Shape::decode_bytes`]).
pub fn shape(path: &Path, opts: &ReadOptions) -> Result<Option<Shape>> {
    match exr::stream::shape(path, opts)? {
        Some(s) => Ok(Some(s)),
        None => rgbe::stream::shape(path, opts),
    }
}

/// Reads `path` (noted in the session) and hands its bands to `work` when it is a file
/// [`shape`] takes; None otherwise (the caller decodes it whole).
pub fn with_bands<R>(
    path: &Path,
    opts: &ReadOptions,
    work: impl FnOnce(&BandSource) -> Result<R>,
) -> Result<Option<R>> {
    if super::is_exr(path) {
        return exr::stream::with_bands(path, opts, |b| work(&BandSource::Exr(b)));
    }
    rgbe::stream::with_bands(path, opts, |b| work(&BandSource::Hdr(b)))
}
