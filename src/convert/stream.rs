//! A large panorama folded into a reduced copy as it is decoded (issue 47): a job whose
//! outputs are much coarser than its input (a 16K panorama to 512 px faces) never holds the
//! full float image (16 bytes a texel, 2 GB at 16K), and reads each of its texels once.
//!
//! Each band of rows is decoded into a thread's buffer and box-reduced there by 2^m per axis,
//! each 2 x 2 step weighted by the rows' solid angles as the lookup pyramid's are (the flux is
//! kept), while every full row's sums and maximum are taken for the peaks. Once the mean is
//! known, the few bands with texels above the peak ceiling are decoded again: their peaks are
//! kept at full resolution (splatted into each output, as from a whole image) and their
//! reduced rows made again below the ceiling. m is the largest that keeps a reduced texel no
//! wider than half the finest output texel, so the exact resampler still takes two taps or
//! more per axis of every texel: on the real panoramas, cubes of 8 and 16 from the reduced
//! copy differ from the whole image's by at most 1.6% of the map's mean texel (esplanade;
//! 5.2% with reduced texels as wide as the finest output texel), the flux by under 0.01%
//! (`tests/it/streamed.rs` prints them).

use super::{Loaded, Source};
use crate::error::Result;
use crate::flux::{Grid, Peaks, RowStats};
use crate::image::Image;
use crate::io::bands::{self, BandSource, Shape};
use crate::io::ReadOptions;
use crate::layout::{equirect, Kind, Projection};
use glam::Vec4;
use std::path::Path;
use std::sync::Mutex;

/// A panorama reduced as it was decoded, with its peaks at full resolution.
pub struct Reduced {
    /// The panorama box-reduced by 2^m per axis, below the peaks' ceiling.
    pub image: Image,
    /// The full-resolution texels above the ceiling (None: no peaks).
    pub peaks: Option<Peaks>,
    /// The full panorama's width and height.
    pub full: (usize, usize),
}

/// Fewest rows a band holds: enough work per task to keep the threads busy.
const MIN_BAND: usize = 32;

/// Times (a power of two) a panorama of `w` x `h` may be reduced for outputs whose finest
/// texel spans `min_footprint` radians: a reduced texel (its row's angle, pi / height) no
/// wider than half that texel, at least 8 rows left, both sides divisible. 1: not worth it.
pub fn factor(w: usize, h: usize, min_footprint: f32) -> usize {
    let angle = std::f32::consts::PI / h.max(1) as f32;
    let mut f = 1;
    while 4.0 * f as f32 * angle <= min_footprint
        && h / (2 * f) >= 8
        && w.is_multiple_of(2 * f)
        && h.is_multiple_of(2 * f)
    {
        f *= 2;
    }
    f
}

/// What loading a panorama reduced takes, from its header alone: jobs plan their memory
/// with it before the file is read.
#[derive(Clone, Copy, Debug)]
pub struct Plan {
    /// The file's shape.
    pub shape: Shape,
    /// Times the panorama is reduced per axis ([`factor`]).
    pub factor: usize,
}

impl Plan {
    /// The face edge that keeps the full panorama's resolution.
    pub fn face_size(&self) -> usize {
        Kind::Equirect.face_size(self.shape.width, self.shape.height)
    }

    /// The rows each band holds.
    fn lines(&self) -> usize {
        self.shape.band_lines(self.factor.max(MIN_BAND))
    }

    /// Bytes in use while a job works from it: the file and each thread's band while it is
    /// decoded, the reduced copy, and its lookup pyramid (half as many again, as
    /// [`super::InputPlan::working_bytes`] counts a whole image's). Peaks are left out: at
    /// most a few texels in a thousand on real panoramas.
    pub fn working_bytes(&self) -> u64 {
        let (w, h) = (self.shape.width, self.shape.height);
        let reduced = ((w / self.factor) * (h / self.factor)) as u64 * 16;
        self.shape
            .decode_bytes(self.lines())
            .saturating_add(reduced + reduced / 2)
    }
}

/// How `path` would be loaded reduced, when it is an equirect `io::bands` decodes in bands
/// (OpenEXR of the common layout, Radiance .hdr) that reduces for outputs whose finest texel
/// spans `min_footprint(face size)` radians; None where it is not (the caller loads it whole). The size limits are checked, not the memory.
pub fn plan(
    path: &Path,
    opts: &ReadOptions,
    min_footprint: impl FnOnce(usize) -> f32,
) -> Result<Option<Plan>> {
    let Some(shape) = bands::shape(path, opts)? else {
        return Ok(None);
    };
    let (w, h) = (shape.width, shape.height);
    if w != 2 * h {
        return Ok(None);
    }
    let factor = factor(w, h, min_footprint(Kind::Equirect.face_size(w, h)));
    Ok((factor >= 2).then_some(Plan { shape, factor }))
}

/// Loads `path` as a reduced panorama when it is an equirect `io::bands` decodes in bands
/// that reduces by `factor` for outputs whose finest texel spans `min_footprint` radians;
/// None where it is not (the caller loads it whole).
pub fn load(path: &Path, opts: &ReadOptions, min_footprint: f32) -> Result<Option<Loaded>> {
    match plan(path, opts, |_| min_footprint)? {
        Some(p) => load_planned(path, opts, &p),
        None => Ok(None),
    }
}

/// [`load`] as `plan` planned it; None where the file no longer fits the plan.
pub(crate) fn load_planned(path: &Path, opts: &ReadOptions, plan: &Plan) -> Result<Option<Loaded>> {
    let loaded = bands::with_bands(path, opts, |b| {
        if b.size() != (plan.shape.width, plan.shape.height) {
            return Ok(None);
        }
        reduce(b, path, plan.factor).map(Some)
    })?;
    Ok(loaded.flatten())
}

/// The two passes over the bands (see the module's text).
fn reduce(b: &BandSource, path: &Path, f: usize) -> Result<Loaded> {
    let (w, h) = b.size();
    let grid = Grid::Projection(Projection::Equirect, w, h);
    let lines = b.block_lines().next_power_of_two().max(f).max(MIN_BAND);
    let weights = level_weights(w, h, f);
    // The reduced image, one slot of rows a band.
    let mut image = Image::new(w / f, h / f);
    let slots: Vec<Mutex<&mut [Vec4]>> = image
        .pixels
        .chunks_mut(lines / f * (w / f))
        .map(Mutex::new)
        .collect();
    // Each band's reduced rows written into their place in the reduced image: straight
    // there when one 2 x 2 step makes them, else through the band's own smaller copy.
    // `seen` hears each full row just before its pair is reduced (still in cache).
    let shrink = |y0: usize, rows: &[Vec4], ceiling: Vec4, seen: &mut dyn FnMut(usize, &[Vec4])| {
        let mut slot = slots[y0 / lines].lock().unwrap_or_else(|e| e.into_inner());
        if weights.len() == 1 {
            reduce_rows(rows, w, y0, &weights[0], ceiling, &mut slot, seen);
        } else {
            let mut first = Image::new(w / 2, rows.len() / w / 2);
            reduce_rows(rows, w, y0, &weights[0], ceiling, &mut first.pixels, seen);
            slot.copy_from_slice(&further(first, y0, &weights).pixels);
        }
    };
    let all = |_: usize| true;
    let first = |y0: usize, rows: &[Vec4]| {
        let mut stats = Vec::with_capacity(rows.len() / w);
        shrink(y0, rows, Vec4::INFINITY, &mut |y, r| {
            stats.push(RowStats::of_row(grid, r, y))
        });
        stats
    };
    let (bands, replaced) = b.map(path, lines, &all, &first)?;
    let bands: Vec<Vec<RowStats>> = bands.into_iter().flatten().collect();
    let rows: Vec<RowStats> = bands.iter().flatten().copied().collect();
    let mut peaks = None;
    if let Some(ceiling) = Peaks::ceiling_of(&rows) {
        let hot: Vec<bool> = bands
            .iter()
            .map(|b| b.iter().any(|r| r.above(ceiling)))
            .collect();
        let pick = |i: usize| hot[i];
        let again = |y0: usize, rows: &[Vec4]| {
            let mut peaks = Vec::with_capacity(rows.len() / w);
            shrink(y0, rows, ceiling.extend(f32::INFINITY), &mut |y, r| {
                peaks.push(Peaks::of_row(grid, y, r, ceiling))
            });
            peaks
        };
        let (redone, _) = b.map(path, lines, &pick, &again)?;
        peaks = Peaks::from_streamed(
            grid,
            ceiling,
            redone.into_iter().flatten().flatten().collect(),
        );
    }
    drop(slots);
    Ok(Loaded {
        source: Source::Reduced(Box::new(Reduced {
            image,
            peaks,
            full: (w, h),
        })),
        kind: Kind::Equirect.into(),
        hdr: true,
        meta: b.meta(replaced),
        files: vec![path.to_path_buf()],
    })
}

/// Each 2 x 2 step's row weights for reducing a `w` x `h` panorama by `f` (a power of two):
/// level k is (w, h) / 2^k. [`reduce_band`] takes them.
pub fn level_weights(w: usize, h: usize, f: usize) -> Vec<Vec<f32>> {
    (0..f.trailing_zeros())
        .map(|k| equirect::row_weights(w >> k, h >> k))
        .collect()
}

/// One band (rows `y0..` of a panorama `w` wide) reduced by 2^`weights.len()` per axis: the
/// first 2 x 2 step straight from the decoded rows, clamped to `ceiling` (the same sums as
/// `Image::reduce_row_by_rows`), the others on the band's reduced copy. `info` reduces its
/// bands with it too, for the sun (`info::stream`).
pub fn reduce_band(
    rows: &[Vec4],
    w: usize,
    y0: usize,
    weights: &[Vec<f32>],
    ceiling: Vec4,
) -> Image {
    let mut img = Image::new(w / 2, rows.len() / w / 2);
    reduce_rows(
        rows,
        w,
        y0,
        &weights[0],
        ceiling,
        &mut img.pixels,
        &mut |_, _| {},
    );
    further(img, y0, weights)
}

/// The steps of [`reduce_band`] after the first, on the band's reduced copy `img`.
fn further(mut img: Image, y0: usize, weights: &[Vec<f32>]) -> Image {
    for (k, row_weight) in weights.iter().enumerate().skip(1) {
        let y = y0 >> k;
        img = img.downsample_2x_rows(&row_weight[y..y + img.height], Vec4::INFINITY);
    }
    img
}

/// The first 2 x 2 step of [`reduce_band`] into `out` (half the rows and columns), each
/// full row handed to `seen(its row in the panorama, its texels)` just before its pair is
/// reduced, while it is in cache.
fn reduce_rows(
    rows: &[Vec4],
    w: usize,
    y0: usize,
    row_weight: &[f32],
    ceiling: Vec4,
    out: &mut [Vec4],
    seen: &mut dyn FnMut(usize, &[Vec4]),
) {
    for (j, out) in out.chunks_exact_mut(w / 2).enumerate() {
        let (a, b) = (2 * j, 2 * j + 1);
        let ra = &rows[a * w..(a + 1) * w];
        let rb = &rows[b * w..(b + 1) * w];
        seen(y0 + a, ra);
        seen(y0 + b, rb);
        let (wa, wb) = (row_weight[y0 + a], row_weight[y0 + b]);
        let total = 2.0 * (wa + wb);
        if total <= 0.0 {
            out.fill(Vec4::ZERO);
            continue;
        }
        let (fa, fb) = (wa / total, wb / total);
        for ((o, pa), pb) in out
            .iter_mut()
            .zip(ra.chunks_exact(2))
            .zip(rb.chunks_exact(2))
        {
            *o = (pa[0].min(ceiling) + pa[1].min(ceiling)) * fa
                + (pb[0].min(ceiling) + pb[1].min(ceiling)) * fb;
        }
    }
}
