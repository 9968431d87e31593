//! The common layout decoded in bands of rows, for jobs that fold a large panorama into
//! something much smaller as it is decoded (`convert::stream`): the whole float image, 16
//! bytes a texel, is never held. Files outside the common layout are not offered.

use super::checks::{read_chunks, read_meta, RawChunk};
use super::{blocks, fast_layout, select, Layout};
use crate::error::{Error, Result};
use crate::image::ColorSpace;
use crate::io::{FileFormat, Meta, ReadOptions};
use exr::meta::MetaData;
use glam::Vec4;
use std::path::Path;

/// A checked OpenEXR file of the common layout (one scan-line part of R G B (A) half or full
/// floats, no envmap attribute), ready to be decoded band by band.
pub struct Bands<'a> {
    meta: MetaData,
    layout: Layout,
    chunks: Vec<RawChunk<'a>>,
    zstd: bool,
    pixel_format: String,
}

impl Bands<'_> {
    /// Width and height in texels.
    pub fn size(&self) -> (usize, usize) {
        let s = self.meta.headers[0].layer_size;
        (s.0, s.1)
    }

    /// The most lines one block holds: bands are a multiple of it.
    pub fn block_lines(&self) -> usize {
        self.chunks
            .iter()
            .map(|c| c.bounds.size.1)
            .max()
            .unwrap_or(1)
    }

    /// The bands of `lines` rows (a power of two, at least `block_lines`) that `pick` keeps,
    /// decoded and sanitized in parallel, each handed to `fold(first row, rows)`: the folds in
    /// band order (None where not picked) and the count of values replaced.
    pub fn map<T: Send>(
        &self,
        path: &Path,
        lines: usize,
        pick: &(dyn Fn(usize) -> bool + Sync),
        fold: &(dyn Fn(usize, &[Vec4]) -> T + Sync),
    ) -> Result<(Vec<Option<T>>, usize)> {
        blocks::map_bands(
            &self.meta,
            &self.layout,
            &self.chunks,
            self.zstd,
            lines,
            pick,
            fold,
        )
        .map_err(|e| Error::file(path, format!("cannot decode OpenEXR: {e}")))
    }

    /// What `io::read` says of the file, with `replaced` values sanitized.
    pub fn meta(&self, replaced: usize) -> Meta {
        Meta {
            file_format: FileFormat::Exr,
            pixel_format: self.pixel_format.clone(),
            color_space: ColorSpace::Linear,
            hdr: true,
            replaced_values: replaced,
            stored_levels: 1,
            declared: None,
            part: None,
        }
    }
}

/// Reads `path` (noted in the session) and hands its bands to `work` when it is an OpenEXR
/// file of the common layout, read as `io::read` would read it with `opts`; None otherwise
/// (the caller decodes it whole).
pub fn with_bands<R>(
    path: &Path,
    opts: &ReadOptions,
    work: impl FnOnce(&Bands) -> Result<R>,
) -> Result<Option<R>> {
    if path == Path::new("-") || !opts.usual() || opts.as_stored || !super::super::is_exr(path) {
        return Ok(None);
    }
    opts.limits.session.note(path);
    let bytes = super::super::read_file(path)?;
    let fail = |msg: String| Error::file(path, format!("cannot decode OpenEXR: {msg}"));
    let (meta, table_start, zstd) = read_meta(&bytes).map_err(fail)?;
    let Some(layout) = fast_layout(&meta) else {
        return Ok(None);
    };
    let header = &meta.headers[0];
    let has = |n: &str| header.channels.list.iter().any(|c| c.name.eq(n));
    let plain = header
        .channels
        .list
        .iter()
        .all(|c| c.sampling == exr::math::Vec2(1, 1));
    if !(has("R") && has("G") && has("B") && plain)
        || header.own_attributes.environment_map.is_some()
        || select::level_count(header) != 1
    {
        return Ok(None);
    }
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    opts.limits.check(path, w as u64, h as u64)?;
    let pixel_format = super::pixel_format(header, has("A"), zstd.first() == Some(&true));
    let chunks = read_chunks(&bytes, &meta, table_start).map_err(fail)?;
    let zstd = zstd.first() == Some(&true);
    let bands = Bands {
        meta,
        layout,
        chunks,
        zstd,
        pixel_format,
    };
    work(&bands).map(Some)
}
