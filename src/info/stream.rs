//! `info` of a large OpenEXR panorama in one streamed pass (issue 47): its bands decoded as
//! stored on every thread and folded into each row's statistics and flux sums as they come,
//! the whole float image (16 bytes a texel, 2 GB at 16K) never held. The rows are added in
//! order, as the whole image's are, so the report is the same to the bit.

use super::{Report, Tally};
use crate::convert::MapKind;
use crate::error::Result;
use crate::flux::{self, Grid};
use crate::io::{exr, ReadOptions};
use crate::layout::{self, Kind};
use glam::Vec4;
use std::path::Path;

/// Images of at least this many texels (16 bytes each: 256 MB) are streamed whatever the
/// budget; smaller ones only where the whole image would not fit it. The environment's
/// `CUBEFORGE_STREAM_TEXELS` sets another bound: the tests read small files both ways.
fn stream_texels() -> u64 {
    std::env::var("CUBEFORGE_STREAM_TEXELS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1 << 24)
}

/// Rows a band holds at least: enough work per task to keep the threads busy.
const MIN_BAND: usize = 32;

/// One row's statistics and flux sums.
type Row = (Tally, ([f64; 3], f64));

/// The report of `path` read in bands, when it is an OpenEXR panorama, ball, angular or
/// octahedral map of the common layout (`from`, or a shape that says which) that is large or
/// does not fit the memory budget whole; None otherwise (the caller reads it whole).
pub(super) fn describe(
    path: &Path,
    from: Option<Kind>,
    opts: &ReadOptions,
) -> Result<Option<Report>> {
    let Some(shape) = exr::stream::shape(path, opts)? else {
        return Ok(None);
    };
    let (w, h) = (shape.width, shape.height);
    let texels = (w as u64).saturating_mul(h as u64);
    let whole = texels.saturating_mul(32).saturating_add(shape.file_bytes);
    if texels < stream_texels() && whole <= opts.limits.max_memory {
        return Ok(None);
    }
    // A square image with no `from` is the whole read's to describe (its note, a table).
    let kind = match from {
        Some(k) => k,
        None if w == h => return Ok(None),
        None => match layout::detect(w, h) {
            Ok(k) => k,
            Err(_) => return Ok(None),
        },
    };
    let Some(projection) = kind.projection().filter(|_| kind.fits(w, h)) else {
        return Ok(None);
    };
    let lines = shape.band_lines(MIN_BAND);
    let rows_bytes = (h * std::mem::size_of::<Row>()) as u64;
    opts.limits.check_memory(
        format_args!("reading {} in bands of {lines} rows", path.display()),
        shape.decode_bytes(lines).saturating_add(rows_bytes),
    )?;
    let grid = Grid::Projection(projection, w, h);
    let fold = |y0: usize, rows: &[Vec4]| -> Vec<Row> {
        rows.chunks_exact(w)
            .enumerate()
            .map(|(i, row)| {
                let y = y0 + i;
                let tally = Tally::of_row(Some(projection), (w, h), y, row);
                (tally, flux::projection_row(grid, y, row))
            })
            .collect()
    };
    let read = exr::stream::with_bands(path, opts, |b| {
        if b.size() != (w, h) {
            return Ok(None); // changed since its header was read: read whole
        }
        let (bands, _) = b.map(path, lines, &|_| true, &fold)?;
        Ok(Some((bands, b.meta(0))))
    })?;
    let Some((bands, meta)) = read.flatten() else {
        return Ok(None);
    };
    let mut tally = Tally::default();
    let mut sums = Vec::with_capacity(h);
    for (t, s) in bands.into_iter().flatten().flatten() {
        tally.add(&t);
        sums.push(s);
    }
    let (sun, lights) = sun(path, kind, opts)?;
    Ok(Some(Report {
        file: path.display().to_string(),
        file_format: meta.file_format,
        kind: Some(MapKind::Layout(kind)),
        kind_note: None,
        declared: None,
        part: None,
        texture: None,
        width: w,
        height: h,
        face_size: Some(kind.face_size(w, h)),
        mip_levels: meta.stored_levels,
        pixel_format: meta.pixel_format,
        color_space: meta.color_space,
        stats: tally.stats(),
        bad_levels: Vec::new(),
        flux: Some(flux::mean_of_rows(sums)),
        levels: None,
        sun,
        lights,
    }))
}

/// Face edge of the cube a streamed panorama's sun is found in.
const SUN_FACE: usize = 512;

/// The lights of a panorama too large to hold whole, from a cube of [`SUN_FACE`]: the
/// panorama reduced as it is decoded (`convert::stream`, the reduction `ibl` takes for
/// faces of 128) with its peaks at full resolution splatted in, so the sun's light and
/// direction are kept and only its size is measured on the cube's texels (esplanade at 16K:
/// 0.71 degrees across against 0.66 read whole). The finder needs the sky's median before it
/// knows which texels are the sun, a second look at every texel the bands' single pass does
/// not give: a second decode (16K on 2 cores: 2.0 s and 340 MB for `info`, against 0.85 s and
/// 126 MB without the sun; a cube of 1024 from the reduction for faces of 256 took 3.0 s and
/// 500 MB). A layout the reduction does not take (balls, angular maps) is read whole when
/// that fits the budget, its sun found on its own texels; else no sun is reported.
fn sun(
    path: &Path,
    kind: Kind,
    opts: &ReadOptions,
) -> Result<(Option<super::LightInfo>, Vec<super::LightInfo>)> {
    use crate::convert;
    let opts = ReadOptions {
        as_stored: false,
        ..*opts
    };
    // The finest texel of a 128 px face (at its corners).
    let footprint = 2.0 * std::f32::consts::SQRT_2 / 3.0 / 128.0;
    let loaded = match convert::stream::load(path, &opts, footprint)? {
        Some(l) => l,
        None => match convert::load_planned(&[path.to_path_buf()], Some(kind), &opts) {
            Ok(l) => l,
            Err(crate::Error::Limit { .. }) => return Ok((None, Vec::new())),
            Err(e) => return Err(e),
        },
    };
    // Read whole: found on its own texels, as the whole read's report finds it.
    if let convert::Source::Projection(p, img) = &loaded.source {
        let grid = Grid::Projection(*p, img.width, img.height);
        return Ok(super::sun::of_grid(grid, &[img]));
    }
    let face = SUN_FACE.min(loaded.face_size().next_power_of_two());
    let cube = convert::to_cube(&loaded, face, &crate::resample::Resampler::default());
    Ok(super::sun::of_faces(&cube.levels[0]))
}
