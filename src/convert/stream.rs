//! A large panorama folded into a reduced copy as it is decoded (issue 47): a job whose
//! outputs are much coarser than its input (a 16K panorama to 512 px faces) never holds the
//! full float image (16 bytes a texel, 2 GB at 16K), and inflates each block once.
//!
//! Each band's rows come from `io::bands` a row at a time as planes and are reduced 2 x 2
//! while in cache, each pair of rows weighted by their solid angles as the lookup pyramid's
//! are (the flux is kept); nothing of the full image is held beyond two rows a thread. The
//! peaks' ceiling (`PEAK_RATIO` times the mean) is needed before the first row is reduced,
//! so it is guessed from 16 evenly spaced bands read first (their mean with each value
//! clamped to their plain mean's ceiling: a sun in the sample weighs 16 times its share
//! there, and one outside it is missed; and no more than `SAMPLE_MARGIN` of that plain
//! ceiling, for a sample with nothing to clamp: so the guess lands below the mean's own).
//! Every reduced row is clamped to the guess and the full texels above it kept as peaks;
//! once the pass has the mean, the ceiling is raised to it, what the peaks held between the
//! two goes back into the reduced texels, and each 2 x 2 block of peak texels whose flux is
//! centred becomes one peak of the copy's size (`Peaks::settle`: the splat lands it as the
//! four). A guess above the mean's ceiling, or one so low that more than a texel in 16
//! would be a peak, reads the bands again below the mean's own. The copy is always half the
//! panorama's size: the resampler takes the levels it needs from its pyramid, as from a
//! whole image's. Cubes of 8 and 16 from it differ from the whole image's by at most 1.5%
//! of the map's mean texel (esplanade), the flux by under 0.01% (`tests/it/streamed.rs`
//! prints them).

use super::{Loaded, Source};
use crate::error::Result;
use crate::flux::{Grid, PeakRow, Peaks, RowStats};
use crate::image::Image;
use crate::io::bands::{self, BandSource, Rows, Shape};
use crate::io::ReadOptions;
use crate::layout::{equirect, Kind, Projection};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::marker::PhantomData;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// A panorama reduced 2 x 2 as it was decoded, with its peaks at full resolution.
pub struct Reduced {
    /// The panorama box-reduced 2 x 2, below the peaks' ceiling.
    pub image: Image,
    /// The full-resolution texels above the ceiling (None: no peaks).
    pub peaks: Option<Peaks>,
    /// The full panorama's width and height.
    pub full: (usize, usize),
}

/// Fewest rows a band holds: enough work per task to keep the threads busy.
const MIN_BAND: usize = 32;

/// Times a panorama of `w` x `h` is reduced for outputs whose finest texel spans
/// `min_footprint` radians: 2 where a reduced texel (its row's angle, pi / height) is no
/// wider than half that texel, at least 8 rows are left and both sides are even; 1 (not
/// worth it) otherwise. Never more: the resampler reads coarser levels from the copy's
/// pyramid (esplanade's cube of 8: 0.39% of the mean texel off the whole image's, where a
/// copy reduced as far as the output allowed was 1.64% off).
pub fn factor(w: usize, h: usize, min_footprint: f32) -> usize {
    let angle = std::f32::consts::PI / h.max(1) as f32;
    let halve =
        4.0 * angle <= min_footprint && h / 2 >= 8 && w.is_multiple_of(2) && h.is_multiple_of(2);
    if halve {
        2
    } else {
        1
    }
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
    /// [`super::InputPlan::working_bytes`] counts a whole image's), and the peaks (16 bytes
    /// each as rows, and their settled 24 twice while they are gathered, as many as a guessed
    /// ceiling may keep: one texel in `MOST_PEAKS`; 2.2% of the 16K esplanade's are above its
    /// mean's). The sample the ceiling is guessed from (16 x 32 rows) is freed before the
    /// copy is made, and is smaller.
    pub fn working_bytes(&self) -> u64 {
        let (w, h) = (self.shape.width, self.shape.height);
        let reduced = ((w / self.factor) * (h / self.factor)) as u64 * 16;
        let peaks = (w * h / MOST_PEAKS) as u64 * 48;
        self.shape
            .decode_bytes(self.lines())
            .saturating_add(reduced + reduced / 2)
            .saturating_add(peaks)
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
        reduce(b, path).map(Some)
    })?;
    Ok(loaded.flatten())
}

/// Bands read first, at most, for the ceiling (every band of a panorama that has no more).
const SAMPLE_BANDS: usize = 16;

/// The passes over the bands (see the module's text).
fn reduce(b: &BandSource, path: &Path) -> Result<Loaded> {
    let lines = b.block_lines().next_power_of_two().max(MIN_BAND);
    let guess = guess_ceiling(b, path, lines)?;
    reduce_from(b, path, lines, guess)
}

/// [`reduce`] with the ceiling guessed: `lines` rows a band.
fn reduce_from(b: &BandSource, path: &Path, lines: usize, guess: Vec3) -> Result<Loaded> {
    let (w, h) = b.size();
    let weights = equirect::row_weights(w, h);
    let mut image = Image::new(w / 2, h / 2);
    let most = w * h / MOST_PEAKS;
    let pass = |ceiling, most, image: &mut Image| {
        reduce_below(b, path, (lines, most), (ceiling, &weights), image)
    };
    let (mut rows, mut found, replaced) = pass(guess, most, &mut image)?;
    let exact = Peaks::ceiling_of(&rows).unwrap_or(Vec3::INFINITY);
    // The guess below the mean's own ceiling (as it is meant to be) keeps the pass; one
    // far from the whole reads the bands again below the mean's own ceiling.
    let from = match found {
        Some(_) if guess.cmple(exact).all() => guess,
        _ => {
            (rows, found, _) = pass(exact, usize::MAX, &mut image)?;
            exact
        }
    };
    drop(rows);
    let share = |y: usize| {
        let pair = y & !1;
        weights[y] / (2.0 * (weights[pair] + weights[pair + 1]))
    };
    let grid = Grid::Projection(Projection::Equirect, w, h);
    let rows = found.unwrap_or_default();
    let peaks = Peaks::settle(grid, (from, exact), rows, &mut image, share);
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

/// The guess is kept this far below the sample's plain mean's ceiling. Where a panorama has
/// no bright part to clamp (night, venice), the sample's mean is the whole's, give or take
/// a few percent, and a guess above the mean's ceiling reads the whole file twice: without
/// the margin, 16K copies of five of the eighteen real panoramas did. With it, the guess is
/// 0.22 to 0.91 of the mean's ceiling on all of them (`tests.rs` prints each).
const SAMPLE_MARGIN: f32 = 0.8;

/// The ceiling guessed from evenly spaced bands: `PEAK_RATIO` times their mean with each
/// value clamped to the ceiling of their plain mean, so a sun that falls in the sample
/// (whose weight there is many times its own) does not lift it, and no higher than
/// `SAMPLE_MARGIN` times their plain mean's ceiling (where nothing is clamped the two are
/// one, and the sample's mean is the whole's give or take a few percent).
fn guess_ceiling(b: &BandSource, path: &Path, lines: usize) -> Result<Vec3> {
    let (w, h) = b.size();
    let grid = Grid::Projection(Projection::Equirect, w, h);
    let every = (h.div_ceil(lines) / SAMPLE_BANDS).max(1);
    let sampled = |i: usize| i % every == every / 2;
    // A band's first rows (no more than the fewest a band holds: a file of tall blocks
    // would otherwise keep half its rows), the rest not decoded.
    let keep = |y0: usize, n: usize, rows: &mut dyn Rows| {
        let mut planes = vec![0.0f32; 4 * w * n.min(MIN_BAND)];
        planes
            .chunks_exact_mut(4 * w)
            .for_each(|r| rows.next_into(r));
        (y0, planes)
    };
    let (sample, _) = b.map_rows(path, lines, &sampled, &keep)?;
    let sample: Vec<(usize, Vec<f32>)> = sample.into_iter().flatten().collect();
    let stats = |clamp: Vec3| -> Vec<RowStats> {
        sample
            .par_iter()
            .flat_map_iter(|(y0, planes)| {
                (*y0..)
                    .zip(planes.chunks_exact(4 * w))
                    .map(move |(y, row)| RowStats::sums_of_planes(grid, row, y, clamp))
            })
            .collect()
    };
    let plain = Peaks::ceiling_of(&stats(Vec3::INFINITY)).unwrap_or(Vec3::INFINITY);
    let clamped = Peaks::ceiling_of(&stats(plain)).unwrap_or(Vec3::INFINITY);
    Ok(clamped.min(SAMPLE_MARGIN * plain))
}

/// Every row's weighted sums, the rows' peaks (None: more than asked for) and the count of
/// values replaced.
type Found = (Vec<RowStats>, Option<Vec<PeakRow>>, usize);

/// One in this many texels may be peaks below a guessed ceiling before the pass gives up on
/// it (and reads the bands again below the mean's own): a guess far below it. Forest, with
/// 6% of its texels above its mean's ceiling, keeps 7.8% above its guess and is read twice;
/// one in 8 would double the peaks' share of the memory plan.
const MOST_PEAKS: usize = 16;

/// One pass over the bands of `lines` rows: each band's rows reduced below `ceiling` (each
/// row weighed by `weights`, its solid angle) into its slot of the reduced `image`, their
/// peaks above it kept (unless there are more than `most`) and every row's sums taken.
fn reduce_below(
    b: &BandSource,
    path: &Path,
    (lines, most): (usize, usize),
    (ceiling, weights): (Vec3, &[f32]),
    image: &mut Image,
) -> Result<Found> {
    let (w, h) = b.size();
    let grid = Grid::Projection(Projection::Equirect, w, h);
    let slots: Vec<Mutex<&mut [Vec4]>> = image
        .pixels
        .chunks_mut(lines / 2 * (w / 2))
        .map(Mutex::new)
        .collect();
    let count = AtomicUsize::new(0);
    let shrink = |y0: usize, n: usize, rows: &mut dyn Rows| {
        let mut slot = slots[y0 / lines].lock().unwrap_or_else(|e| e.into_inner());
        let (mut sums, mut peaks) = (Vec::with_capacity(n), Vec::new());
        let pairs = Pairs { rows, w, y0 };
        pairs.reduce(n, weights, ceiling, &mut slot, &mut |y, planes| {
            sums.push(RowStats::sums_of_planes(grid, planes, y, Vec3::INFINITY));
            let (r, g, b) = (&planes[..w], &planes[w..2 * w], &planes[2 * w..3 * w]);
            let above = |p: &[f32], c: f32| p.iter().fold(false, |a, &v| a | (v > c));
            let hot = above(r, ceiling.x) || above(g, ceiling.y) || above(b, ceiling.z);
            if hot && count.load(Ordering::Relaxed) <= most {
                let row = Peaks::of_planes(grid, y, planes, ceiling);
                count.fetch_add(row.len(), Ordering::Relaxed);
                peaks.push(row);
            }
        });
        (sums, peaks)
    };
    let (bands, replaced) = b.map_rows(path, lines, &|_| true, &shrink)?;
    let (mut rows, mut found) = (Vec::with_capacity(h), Vec::new());
    for (sums, peaks) in bands.into_iter().flatten() {
        rows.extend(sums);
        found.extend(peaks);
    }
    let whole = count.into_inner() <= most;
    Ok((rows, whole.then_some(found), replaced))
}

/// A band's rows (the first `y0` of a panorama `w` wide), reduced a pair at a time.
struct Pairs<'a> {
    rows: &'a mut dyn Rows,
    w: usize,
    y0: usize,
}

impl Pairs<'_> {
    /// The first 2 x 2 step of the band's `n` rows into `out` (half the rows and columns),
    /// each value clamped to its channel's `ceiling`, the same sums as [`reduce_rows`]; each
    /// full row handed to `seen(its row in the panorama, its planes)` while it is in cache.
    fn reduce(
        self,
        n: usize,
        row_weight: &[f32],
        ceiling: Vec3,
        out: &mut [Vec4],
        seen: &mut dyn FnMut(usize, &[f32]),
    ) {
        let Pairs { rows, w, y0 } = self;
        let mut a = vec![0.0f32; 4 * w];
        let mut b = vec![0.0f32; 4 * w];
        let mut sums = vec![0.0f32; 2 * w];
        for (j, out) in out.chunks_exact_mut(w / 2).take(n / 2).enumerate() {
            let (ya, yb) = (y0 + 2 * j, y0 + 2 * j + 1);
            rows.next_into(&mut a);
            rows.next_into(&mut b);
            seen(ya, &a);
            seen(yb, &b);
            let (wa, wb) = (row_weight[ya], row_weight[yb]);
            let total = 2.0 * (wa + wb);
            if total <= 0.0 {
                out.fill(Vec4::ZERO);
                continue;
            }
            let how = (wa / total, wb / total, ceiling.extend(f32::INFINITY));
            crate::simd::fast(PairRow((&a, &b, how, &mut sums, out), PhantomData));
        }
    }
}

/// Two rows' planes, their weights and the ceiling, the sums' planes and the reduced row.
type PairArgs<'k> = (
    &'k [f32],
    &'k [f32],
    (f32, f32, Vec4),
    &'k mut [f32],
    &'k mut [Vec4],
);

crate::simd::kernel!(PairRow(PairArgs<'k>) -> () = pair_row);

/// One reduced row from the planes of rows `a` and `b` (weighed `fa` and `fb`, each value
/// clamped to its channel's `ceiling`), each channel into its plane of `sums` first, then
/// into the texels of `out`.
#[inline(always)]
fn pair_row((a, b, (fa, fb, ceiling), sums, out): PairArgs) {
    let w = a.len() / 4;
    let half = w / 2;
    // As `Vec4::min` on x86 (`minps`: the ceiling where a value is NaN).
    let lo = |v: f32, c: f32| if v < c { v } else { c };
    for c in 0..4 {
        let cc = ceiling[c];
        let (pa, pb) = (&a[c * w..(c + 1) * w], &b[c * w..(c + 1) * w]);
        let plane = &mut sums[c * half..(c + 1) * half];
        for ((s, qa), qb) in plane
            .iter_mut()
            .zip(pa.chunks_exact(2))
            .zip(pb.chunks_exact(2))
        {
            *s = (lo(qa[0], cc) + lo(qa[1], cc)) * fa + (lo(qb[0], cc) + lo(qb[1], cc)) * fb;
        }
    }
    let (r, rest) = sums.split_at(half);
    let (g, rest) = rest.split_at(half);
    let (bl, al) = rest.split_at(half);
    for ((((t, &r), &g), &b), &a) in out.iter_mut().zip(r).zip(g).zip(bl).zip(al) {
        *t = Vec4::new(r, g, b, a);
    }
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
    reduce_rows(rows, (w, y0), &weights[0], ceiling, &mut img.pixels);
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

/// The first 2 x 2 step of [`reduce_band`] (rows `y0..` of a panorama `w` wide) into `out`
/// (half the rows and columns).
fn reduce_rows(
    rows: &[Vec4],
    (w, y0): (usize, usize),
    row_weight: &[f32],
    ceiling: Vec4,
    out: &mut [Vec4],
) {
    for (j, out) in out.chunks_exact_mut(w / 2).enumerate() {
        let (a, b) = (2 * j, 2 * j + 1);
        let ra = &rows[a * w..(a + 1) * w];
        let rb = &rows[b * w..(b + 1) * w];
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

#[cfg(test)]
mod tests;
