//! The common layout decoded in bands of rows, for jobs that fold a large panorama into
//! something much smaller as it is decoded (`convert::stream`): the whole float image, 16
//! bytes a texel, is never held. Files outside the common layout are not offered.

use super::checks::{read_chunks, read_meta, RawChunk};
use super::{fast_layout, rows, select, undecodable, Layout};
use crate::error::{Error, Result};
use crate::image::ColorSpace;
use crate::io::band_shape::Rows;
use crate::io::band_shape::Shape;
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
    sanitize: bool,
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
    /// decoded (and sanitized, unless read as stored) in parallel, each handed to
    /// `fold(first row, rows)`: the folds in band order (None where not picked) and the count
    /// of values replaced.
    pub fn map<T: Send>(
        &self,
        path: &Path,
        lines: usize,
        pick: &(dyn Fn(usize) -> bool + Sync),
        fold: &(dyn Fn(usize, &[Vec4]) -> T + Sync),
    ) -> Result<(Vec<Option<T>>, usize)> {
        rows::map_bands(
            &self.meta,
            &self.layout,
            &self.chunks,
            self.how(lines),
            pick,
            fold,
        )
        .map_err(undecodable(path))
    }

    /// `map` with each band handed to `fold(first row, rows, its rows)` a row at a time, as
    /// planes ([`Rows`]).
    pub fn map_rows<T: Send>(
        &self,
        path: &Path,
        lines: usize,
        pick: &(dyn Fn(usize) -> bool + Sync),
        fold: &(dyn Fn(usize, usize, &mut dyn Rows) -> T + Sync),
    ) -> Result<(Vec<Option<T>>, usize)> {
        rows::map_rows(
            &self.meta,
            &self.layout,
            &self.chunks,
            self.how(lines),
            pick,
            fold,
        )
        .map_err(undecodable(path))
    }

    fn how(&self, lines: usize) -> rows::BandRead {
        rows::BandRead {
            zstd: self.zstd,
            sanitize: self.sanitize,
            lines,
        }
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
            undo: Default::default(),
            part: None,
        }
    }
}

/// Whether `opts` read `path` as a streamed job may: an OpenEXR file's usual image. Anything
/// but a regular file (a pipe would block its magic number's read) is left to the whole
/// read, which says why it is refused.
fn offered(path: &Path, opts: &ReadOptions) -> bool {
    let regular = std::fs::metadata(path).is_ok_and(|m| m.is_file());
    path != Path::new("-") && opts.usual() && regular && super::super::is_exr(path)
}

/// The common layout's slots where `meta` is a file of it with no more than its image: RGB
/// at full resolution, no envmap, one level.
fn common(meta: &MetaData) -> Option<Layout> {
    let layout = fast_layout(meta)?;
    let header = &meta.headers[0];
    let has = |n: &str| header.channels.list.iter().any(|c| c.name.eq(n));
    let plain = header
        .channels
        .list
        .iter()
        .all(|c| c.sampling == exr::math::Vec2(1, 1));
    let one_level = select::level_count(header) == 1;
    (has("R") && has("G") && has("B") && plain)
        .then_some(layout)
        .filter(|_| header.own_attributes.environment_map.is_none() && one_level)
}

/// The shape of `path` when `with_bands` would take it (read as `opts` say), from its
/// header (the first MiB, or the whole file where the header is longer); None otherwise.
/// Checks the size limits; the memory is the caller's to check ([`Shape::decode_bytes`]).
pub fn shape(path: &Path, opts: &ReadOptions) -> Result<Option<Shape>> {
    if !offered(path, opts) {
        return Ok(None);
    }
    use std::io::Read;
    const HEAD: u64 = 1 << 20;
    let file_bytes = super::super::regular_file(path)?.len();
    let mut head = Vec::new();
    std::fs::File::open(path)
        .and_then(|f| f.take(HEAD).read_to_end(&mut head))
        .map_err(|e| Error::io(path, e))?;
    let meta = match read_meta(&head) {
        Ok((meta, ..)) => meta,
        Err(_) if file_bytes > HEAD => {
            let whole = super::super::read_file(path)?;
            let Ok((meta, ..)) = read_meta(&whole) else {
                return Ok(None); // the whole read says why
            };
            meta
        }
        Err(_) => return Ok(None),
    };
    if common(&meta).is_none() {
        return Ok(None);
    }
    let header = &meta.headers[0];
    let (width, height) = (header.layer_size.0, header.layer_size.1);
    opts.limits
        .check_pixels(path, width as u64, height as u64)?;
    Ok(Some(Shape {
        width,
        height,
        block_lines: header.compression.scan_lines_per_block(),
        file_bytes,
    }))
}

/// Reads `path` (noted in the session) and hands its bands to `work` when it is an OpenEXR
/// file of the common layout, read as `io::read` would read it with `opts` (sanitized, or as
/// stored); None otherwise (the caller decodes it whole). The size limits are checked here,
/// the memory is the caller's to check ([`shape`]).
pub fn with_bands<R>(
    path: &Path,
    opts: &ReadOptions,
    work: impl FnOnce(&Bands) -> Result<R>,
) -> Result<Option<R>> {
    if !offered(path, opts) {
        return Ok(None);
    }
    opts.limits.session.note(path);
    let bytes = super::super::read_file(path)?;
    let fail = undecodable(path);
    let (meta, table_start, zstd) = read_meta(&bytes).map_err(fail)?;
    let Some(layout) = common(&meta) else {
        return Ok(None);
    };
    let header = &meta.headers[0];
    let (w, h) = (header.layer_size.0, header.layer_size.1);
    opts.limits.check_pixels(path, w as u64, h as u64)?;
    let has_alpha = header.channels.list.iter().any(|c| c.name.eq("A"));
    let pixel_format = super::pixel_format(header, has_alpha, zstd.first() == Some(&true));
    let chunks = read_chunks(&bytes, &meta, table_start).map_err(fail)?;
    let zstd = zstd.first() == Some(&true);
    let bands = Bands {
        meta,
        layout,
        chunks,
        zstd,
        sanitize: !opts.as_stored,
        pixel_format,
    };
    work(&bands).map(Some)
}
