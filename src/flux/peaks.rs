//! The peaks of an input (texels above the ceiling): found in one pass, splatted into each
//! output so their flux arrives whole.

use super::{Grid, PEAK_RATIO};
use crate::image::Image;
use crate::layout::Projection;
use glam::{Mat3, Vec3, Vec4};
use rayon::prelude::*;

mod streamed;
pub(crate) use streamed::PeakRow;

/// One texel above the ceiling: where it is and by how much each channel exceeds it.
#[derive(Clone, Copy, Debug)]
struct Peak {
    face: u8,
    x: u32,
    y: u32,
    excess: Vec3,
}

/// The texels of row `y` of `face` above `ceiling`, with their excess.
fn row_peaks(
    grid: Grid,
    face: usize,
    y: usize,
    row: &[Vec4],
    ceiling: Vec3,
) -> impl Iterator<Item = Peak> + '_ {
    row.iter().enumerate().filter_map(move |(x, p)| {
        let excess = (p.truncate() - ceiling).max(Vec3::ZERO);
        let covers = || grid.solid_angle(x, y) > 0.0;
        (excess != Vec3::ZERO && covers()).then_some(Peak {
            face: face as u8,
            x: x as u32,
            y: y as u32,
            excess,
        })
    })
}

/// The part of an input above its ceiling, to be splatted into outputs.
#[derive(Clone, Debug)]
pub struct Peaks {
    /// Each colour channel of the bounded part is at most its entry here.
    pub ceiling: Vec3,
    grid: Grid,
    texels: Vec<Peak>,
    /// Peaks summed over 2 x 2 blocks of texels, on `block_grid` (see `settle`).
    blocks: Vec<Peak>,
}

/// One row's weighted sums (for the means) and maximum (to skip rows without peaks).
#[derive(Clone, Copy)]
pub(crate) struct RowStats {
    sum: [f64; 3],
    weight: f64,
    max: Vec3,
}

impl RowStats {
    fn of(grid: Grid, image: &Image, y: usize) -> RowStats {
        let w = grid.dims().0;
        Self::of_row(grid, &image.pixels[y * w..(y + 1) * w], y)
    }

    /// `of` for row `y` of face 0 given as its texels (a band of a panorama being decoded).
    pub(crate) fn of_row(grid: Grid, row: &[Vec4], y: usize) -> RowStats {
        let mut sum = [0.0f64; 3];
        let mut weight = 0.0f64;
        let mut max = Vec3::ZERO;
        // The weight at each texel's centre: close enough to choose a ceiling.
        let row_weight = matches!(grid, Grid::Projection(Projection::Equirect, ..))
            .then(|| grid.density(0.5, y as f32 + 0.5));
        if let Some(a) = row_weight {
            // One weight for the row: sum blocks in f32 (SIMD), the blocks in f64.
            let mut m = Vec4::ZERO;
            for block in row.chunks(256) {
                let mut s = Vec4::ZERO;
                for &p in block {
                    s += p;
                    m = m.max(p);
                }
                for (c, t) in sum.iter_mut().enumerate() {
                    *t += s[c] as f64 * a as f64;
                }
            }
            let weight = a as f64 * row.len() as f64;
            return RowStats {
                sum,
                weight,
                max: m.truncate(),
            };
        }
        for (x, p) in row.iter().enumerate() {
            let a = grid.density(x as f32 + 0.5, y as f32 + 0.5);
            if a > 0.0 {
                for (c, s) in sum.iter_mut().enumerate() {
                    *s += (p[c] * a) as f64;
                }
                weight += a as f64;
                max = max.max(p.truncate());
            }
        }
        RowStats { sum, weight, max }
    }
}

impl RowStats {
    /// [`RowStats::of_row`]'s sums of an equirect panorama's row `y` given as planes (R, G,
    /// B, A: see `io::bands::Rows`), each value clamped to its channel's `clamp`, in eight
    /// lanes at a time (they differ from `of_row`'s in the last bits); no maximum is taken.
    pub(crate) fn sums_of_planes(grid: Grid, planes: &[f32], y: usize, clamp: Vec3) -> RowStats {
        let w = planes.len() / 4;
        let a = grid.density(0.5, y as f32 + 0.5) as f64;
        let mut sum = [0.0f64; 3];
        for (c, plane) in planes.chunks_exact(w).take(3).enumerate() {
            let kernel = Sum((plane, clamp[c]), std::marker::PhantomData);
            sum[c] = crate::simd::fast(kernel) * a;
        }
        RowStats {
            sum,
            weight: a * w as f64,
            max: Vec3::ZERO,
        }
    }
}

crate::simd::kernel!(Sum((&'k [f32], f32)) -> f64 = sum_of);

/// The sum of `values`, each at most `clamp`: blocks of 256 in eight f32 lanes, the blocks
/// in f64.
#[inline(always)]
fn sum_of((values, clamp): (&[f32], f32)) -> f64 {
    let lo = |v: f32| if v < clamp { v } else { clamp };
    let mut sum = 0.0f64;
    for block in values.chunks(256) {
        let mut lanes = [0.0f32; 8];
        let mut eights = block.chunks_exact(8);
        for e in &mut eights {
            for i in 0..8 {
                lanes[i] += lo(e[i]);
            }
        }
        for (i, &v) in eights.remainder().iter().enumerate() {
            lanes[i] += lo(v);
        }
        sum += lanes.iter().sum::<f32>() as f64;
    }
    sum
}

impl Peaks {
    /// Finds the texels of `images` (laid out on `grid`) with a channel above `PEAK_RATIO`
    /// times that channel's mean, or None when there are none. One pass for the means and
    /// each row's maxima, then only the rows that hold a peak are read again.
    pub fn find(grid: Grid, images: &[&Image]) -> Option<Peaks> {
        let h = grid.dims().1;
        let rows: Vec<RowStats> = (0..grid.faces() * h)
            .into_par_iter()
            .map(|fy| RowStats::of(grid, images[fy / h], fy % h))
            .collect();
        Self::from_rows(grid, images, &rows)
    }

    /// `find` on a panorama, and in the same pass over it its 2x2 reduction below the
    /// ceiling (`Image::downsample_2x_rows(row_weight, ceiling)`, the same bytes): a large
    /// input is read once, not twice. Rows that hold a peak are reduced again with the ceiling.
    pub(crate) fn find_reducing(
        grid: Grid,
        image: &Image,
        row_weight: &[f32],
    ) -> (Option<Peaks>, Image) {
        let (w, h) = image.half_size();
        let mut half = Image::new(w, h);
        let stats: Vec<Vec<RowStats>> = half
            .pixels
            .par_chunks_mut(w)
            .enumerate()
            .map(|(y, row)| {
                image.reduce_row_by_rows(y, row, row_weight, Vec4::INFINITY);
                image
                    .half_rows(y)
                    .map(|sy| RowStats::of(grid, image, sy))
                    .collect()
            })
            .collect();
        let rows: Vec<RowStats> = stats.iter().flatten().copied().collect();
        let peaks = Self::from_rows(grid, &[image], &rows);
        if let Some(p) = &peaks {
            let ceiling = p.ceiling_vec();
            half.pixels
                .par_chunks_mut(w)
                .zip(&stats)
                .enumerate()
                .filter(|(_, (_, s))| s.iter().any(|r| r.max.cmpgt(p.ceiling).any()))
                .for_each(|(y, (row, _))| image.reduce_row_by_rows(y, row, row_weight, ceiling));
        }
        (peaks, half)
    }

    /// The ceiling from the rows' sums, and the peak texels of the rows whose maximum is above it.
    fn from_rows(grid: Grid, images: &[&Image], rows: &[RowStats]) -> Option<Peaks> {
        let (w, h) = grid.dims();
        let ceiling = Self::ceiling_of(rows)?;
        let texels: Vec<Peak> = rows
            .par_iter()
            .enumerate()
            .filter(|(_, r)| r.max.cmpgt(ceiling).any())
            .flat_map_iter(|(fy, _)| {
                let (face, y) = (fy / h, fy % h);
                row_peaks(
                    grid,
                    face,
                    y,
                    &images[face].pixels[y * w..(y + 1) * w],
                    ceiling,
                )
            })
            .collect();
        (!texels.is_empty()).then_some(Peaks {
            ceiling,
            grid,
            texels,
            blocks: Vec::new(),
        })
    }

    /// Scales the peaks' excess and ceiling by 2^`exposure` (`Loaded::expose`).
    pub(crate) fn expose(&mut self, exposure: f32) {
        let k = exposure.exp2();
        self.ceiling *= k;
        for t in self.texels.iter_mut().chain(&mut self.blocks) {
            t.excess *= k;
        }
    }

    /// The peaks' flux: excess radiance times solid angle, summed (per channel).
    pub(crate) fn flux(&self) -> [f64; 3] {
        let mut sum = [0.0f64; 3];
        let texels = self.texels.iter().map(|p| (self.grid, p));
        for (grid, p) in texels.chain(self.blocks.iter().map(|p| (self.block_grid(), p))) {
            let omega = grid.solid_angle(p.x as usize, p.y as usize);
            for (c, s) in sum.iter_mut().enumerate() {
                *s += p.excess[c] as f64 * omega;
            }
        }
        sum
    }

    /// Each channel's ceiling, `PEAK_RATIO` times its weighted mean over `rows`; None when
    /// the rows weigh nothing.
    pub(crate) fn ceiling_of(rows: &[RowStats]) -> Option<Vec3> {
        let (mut sum, mut weight) = ([0.0f64; 3], 0.0);
        for r in rows {
            for (s, v) in sum.iter_mut().zip(r.sum) {
                *s += v;
            }
            weight += r.weight;
        }
        if weight <= 0.0 {
            return None;
        }
        // A channel that is black everywhere has no peaks.
        Some(Vec3::from_array(sum.map(|s| {
            match (PEAK_RATIO as f64 * s / weight) as f32 {
                c if c > 0.0 => c,
                _ => f32::INFINITY,
            }
        })))
    }

    /// Number of peak texels.
    pub fn len(&self) -> usize {
        self.texels.len() + self.blocks.len()
    }

    /// Whether there are none (never, for a `Peaks` that `find` returned).
    pub fn is_empty(&self) -> bool {
        self.texels.is_empty() && self.blocks.is_empty()
    }

    /// Each colour channel clamped to the ceiling (alpha untouched): the bounded part.
    pub(crate) fn ceiling_vec(&self) -> Vec4 {
        self.ceiling.extend(f32::INFINITY)
    }

    /// Adds the peaks to `images`, an output laid out on `out`. `lookup` takes an output
    /// direction to the input direction shown there (the resampler's orientation), so input
    /// directions go back through its transpose. Sub-cells are a quarter of an output texel
    /// or finer; their shares are summed per output texel in the peaks' own order, so the
    /// result does not depend on thread count.
    pub fn splat(&self, out: Grid, lookup: Option<Mat3>, images: &mut [Image]) {
        let back = lookup.map(|m| m.transpose());
        let (ow, oh) = out.dims();
        let texels = self.texels.par_chunks(1024).map(|c| (self.grid, c));
        let blocks = self.blocks.par_chunks(1024).map(|c| (self.block_grid(), c));
        let shares: Vec<Vec<(u64, [f64; 3])>> = texels
            .chain(blocks)
            .map(|(grid, chunk)| Self::shares(grid, chunk, out, back))
            .collect();
        // Each texel once: its shares from every chunk, in the chunks' order, summed and
        // divided by its solid angle (atan2s), key ranges in parallel. Where a range ends
        // never changes a texel's order of summation.
        let bounds = key_bounds(&shares, 4 * rayon::current_num_threads());
        let adds: Vec<Vec<(usize, usize, usize, Vec3)>> = bounds
            .par_windows(2)
            .map(|w| {
                gather(&shares, w[0], w[1])
                    .into_iter()
                    .filter_map(|(k, sum)| {
                        let k = k as usize;
                        let (face, y, x) = (k / (ow * oh), (k / ow) % oh, k % ow);
                        let omega = out.solid_angle(x, y);
                        let add = Vec3::from_array(sum.map(|s| (s / omega) as f32));
                        (omega > 0.0).then_some((face, x, y, add))
                    })
                    .collect()
            })
            .collect();
        for (face, x, y, add) in adds.into_iter().flatten() {
            let img = &mut images[face];
            let p = img.get(x, y);
            img.set(x, y, (p.truncate() + add).extend(p.w));
        }
    }

    /// One chunk of peaks' shares of the output texels, each texel's key once, in order
    /// (see [`Peaks::splat`]).
    fn shares(grid: Grid, chunk: &[Peak], out: Grid, back: Option<Mat3>) -> Vec<(u64, [f64; 3])> {
        let (ow, oh) = out.dims();
        let key = |(f, x, y): (usize, usize, usize)| ((f * oh + y) * ow + x) as u64;
        let mut shares: Vec<(u64, Vec3)> = Vec::new();
        let mut cells: Vec<(Vec3, f32)> = Vec::new();
        // A panorama's texels of one row share a solid angle (two f64 sines).
        let mut row_omega: Option<(u32, f64)> = None;
        for p in chunk {
            let (face, x, y) = (p.face as usize, p.x as f32, p.y as f32);
            let Some(centre) = grid.dir(face, x + 0.5, y + 0.5) else {
                continue;
            };
            // Sub-cells per texel edge: two per output texel there (one where the
            // output texel spans two input texels or more).
            let (_, cx, cy) = out.locate(back.map_or(centre, |m| (m * centre).normalize()));
            let a_in = grid.density(x + 0.5, y + 0.5).sqrt();
            let a_out = out.density(cx as f32 + 0.5, cy as f32 + 0.5).sqrt();
            let k = (2.0 * a_in / a_out.max(1e-12)).ceil().clamp(1.0, 64.0) as usize;
            cells.clear();
            let total = grid.sub_cells(face, x, y, k, &mut cells);
            if let Some(m) = back {
                for c in &mut cells {
                    c.0 = (m * c.0).normalize();
                }
            }
            if total <= 0.0 {
                continue;
            }
            let omega = match (grid, row_omega) {
                (Grid::Projection(Projection::Equirect, ..), Some((y, a))) if y == p.y => a,
                (g @ Grid::Projection(Projection::Equirect, ..), _) => {
                    let a = g.solid_angle(0, p.y as usize);
                    row_omega = Some((p.y, a));
                    a
                }
                (g, _) => g.solid_angle(p.x as usize, p.y as usize),
            };
            let flux = p.excess * omega as f32 / total;
            // Each sub-cell covers a square of its own area around where it lands,
            // shared by overlap between the (at most 2 x 2) output texels under it,
            // so the peak arrives smooth; on a ball (whose outside covers nothing)
            // it goes whole to the texel it lands in.
            let side = if out.is_ball() {
                0.0
            } else {
                (a_in / a_out.max(1e-12) / k as f32).min(1.0)
            };
            // A peak's shares summed as they come (its sub-cells land on a few
            // texels, the last eight searched): fewer entries to sort.
            let start = shares.len();
            for &(d, wgt) in &cells {
                let (f, fx, fy) = out.position(d);
                let (xs, ys) = (out.spans(fx, side, ow), out.spans(fy, side, oh));
                for &(x, wx) in xs.iter().flatten() {
                    for &(y, wy) in ys.iter().flatten() {
                        let k = key((f, x, y));
                        let share = flux * (wgt * wx * wy);
                        let mine = &mut shares[start..];
                        let recent = mine.len().saturating_sub(8);
                        match mine[recent..].iter_mut().find(|s| s.0 == k) {
                            Some((_, s)) => *s += share,
                            None => shares.push((k, share)),
                        }
                    }
                }
            }
        }
        // Stable sorts: equal keys keep the peaks' order, so each texel's sum has one
        // order. Summed per chunk first: a small output gets few keys per chunk.
        shares.sort_by_key(|s| s.0);
        merge(
            shares
                .iter()
                .map(|&(k, v)| (k, v.to_array().map(f64::from))),
        )
    }
}

/// Bounds of about `pieces` key ranges holding similar numbers of shares, from a sample of
/// the (sorted) chunks' keys: 0 first, u64::MAX last, increasing.
fn key_bounds(chunks: &[Vec<(u64, [f64; 3])>], pieces: usize) -> Vec<u64> {
    let pieces = pieces.max(1);
    let mut sample: Vec<u64> = chunks
        .iter()
        .flat_map(|c| c.iter().step_by((c.len() / pieces).max(1)).map(|s| s.0))
        .collect();
    sample.sort_unstable();
    let mut bounds = vec![0];
    for i in 1..pieces {
        if let Some(&k) = sample.get(sample.len() * i / pieces) {
            if k > *bounds.last().unwrap_or(&0) {
                bounds.push(k);
            }
        }
    }
    bounds.push(u64::MAX);
    bounds
}

/// The shares of keys in `lo..hi` from every chunk (each sorted by key), summed per key in
/// the chunks' order.
fn gather(chunks: &[Vec<(u64, [f64; 3])>], lo: u64, hi: u64) -> Vec<(u64, [f64; 3])> {
    let mut part: Vec<(u64, [f64; 3])> = Vec::new();
    for c in chunks {
        let a = c.partition_point(|s| s.0 < lo);
        let b = c.partition_point(|s| s.0 < hi);
        part.extend_from_slice(&c[a..b]);
    }
    // Stable: a key's shares stay in the chunks' order.
    part.sort_by_key(|s| s.0);
    merge(part.into_iter())
}

/// Sums the values of equal consecutive keys, in order.
fn merge(sorted: impl Iterator<Item = (u64, [f64; 3])>) -> Vec<(u64, [f64; 3])> {
    let mut out: Vec<(u64, [f64; 3])> = Vec::new();
    for (k, v) in sorted {
        match out.last_mut() {
            Some((last, s)) if *last == k => {
                for c in 0..3 {
                    s[c] += v[c];
                }
            }
            _ => out.push((k, v)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn key_ranges_sum_as_one_sort() {
        // Chunks of sorted unique keys, overlapping, some keys in many chunks, one chunk
        // empty; values that round differently in another order.
        let chunks: Vec<Vec<(u64, [f64; 3])>> = (0..40u64)
            .map(|c| {
                (0..c * 37 % 300)
                    .map(|i| (i * (c % 7 + 1) + c * 11 % 5, i))
                    .map(|(k, i)| {
                        (
                            k,
                            [
                                0.1 * (i + c) as f64,
                                1.0 / (1 + i + c) as f64,
                                1e16 + c as f64,
                            ],
                        )
                    })
                    .collect::<Vec<_>>()
            })
            .map(|mut v| {
                v.dedup_by_key(|s| s.0);
                v
            })
            .collect();
        let mut all = chunks.concat();
        all.sort_by_key(|s| s.0);
        let whole = merge(all.into_iter());
        for pieces in [1, 2, 3, 16, 64, 1000, 100_000] {
            let bounds = key_bounds(&chunks, pieces);
            assert_eq!((bounds[0], *bounds.last().unwrap()), (0, u64::MAX));
            assert!(bounds.windows(2).all(|w| w[0] < w[1]));
            let parts: Vec<_> = bounds
                .windows(2)
                .flat_map(|w| gather(&chunks, w[0], w[1]))
                .collect();
            assert_eq!(parts, whole, "{pieces} pieces");
        }
        assert_eq!(key_bounds(&[], 8), vec![0, u64::MAX]);
    }
}
