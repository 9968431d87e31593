//! The peaks of a panorama streamed by (`convert::stream`): kept a row at a time above a
//! guessed ceiling while the bands are decoded, then settled once the mean's own ceiling is
//! known. Settling raises each texel to that ceiling (what it held between the two goes back
//! into the reduced copy) and sums each 2 x 2 block of peak texels whose flux is centred
//! into one peak of the panorama at half size. The splat that follows cuts nothing finer
//! than half an output texel, and the copy is reduced only where a block is no wider than
//! that (`convert::stream::factor`): such a block lands as its four texels would (four
//! squares that tile the block's one). The 16K esplanade's 3.0 million peak texels become
//! 0.8 million peaks, and were most of the 512 px cube's splat.

use super::{Peak, Peaks};
use crate::flux::Grid;
use crate::image::Image;
use crate::layout::Projection;
use glam::Vec3;
use rayon::prelude::*;

/// One streamed row's peak texels.
pub(crate) struct PeakRow {
    y: u32,
    texels: Vec<RowPeak>,
}

/// A peak texel of a streamed row: 16 bytes where a settled `Peak` takes 24 (millions are
/// held until the ceiling is known).
#[derive(Clone, Copy)]
struct RowPeak {
    x: u32,
    excess: Vec3,
}

impl PeakRow {
    /// Its count of peak texels.
    pub(crate) fn len(&self) -> usize {
        self.texels.len()
    }
}

/// A block is summed when its flux's centre is within this share of a texel of the block's
/// centre, per channel and axis (its light moves no further than that).
const OFF_CENTRE: f32 = 0.125;

impl Peaks {
    /// The texels of row `y` of a panorama on `grid` above `ceiling`, given as planes (R, G,
    /// B, A: see `io::bands::Rows`). Eight texels are tested at once: most of a row holding
    /// peaks is below.
    pub(crate) fn of_planes(grid: Grid, y: usize, planes: &[f32], ceiling: Vec3) -> PeakRow {
        let w = planes.len() / 4;
        let (r, g, b) = (&planes[..w], &planes[w..2 * w], &planes[2 * w..3 * w]);
        let over = |x: usize| r[x] > ceiling.x || g[x] > ceiling.y || b[x] > ceiling.z;
        let any = |x0: usize| (x0..x0 + 8).fold(false, |a, x| a | over(x));
        // A panorama's row shares one solid angle (two sines): asked once.
        let covers = matches!(grid, Grid::Projection(Projection::Equirect, ..))
            .then(|| grid.solid_angle(0, y) > 0.0);
        let mut texels = Vec::new();
        let eights = (0..w / 8).map(|i| 8 * i).filter(|&x0| any(x0));
        for x in eights.flat_map(|x0| x0..x0 + 8).chain(w / 8 * 8..w) {
            if over(x) && covers.unwrap_or_else(|| grid.solid_angle(x, y) > 0.0) {
                texels.push(RowPeak {
                    x: x as u32,
                    excess: (Vec3::new(r[x], g[x], b[x]) - ceiling).max(Vec3::ZERO),
                });
            }
        }
        PeakRow {
            y: y as u32,
            texels,
        }
    }

    /// The peaks of a panorama on `grid` (even-sized) from its `rows` (found above `from`, in
    /// row order), settled under the ceiling `to` (no channel lower than `from`): what each
    /// texel held between the two goes into `half`, the panorama reduced 2 x 2 below the
    /// ceiling, where a texel of row y weighs `share(y)` of its reduced texel (each reduced
    /// texel receives its parts in the rows' order); texels left with no excess are dropped,
    /// and the centred 2 x 2 blocks are summed (see the module's text). None: no peaks.
    pub(crate) fn settle(
        grid: Grid,
        (from, to): (Vec3, Vec3),
        rows: Vec<PeakRow>,
        half: &mut Image,
        share: impl Fn(usize) -> f32 + Sync,
    ) -> Option<Peaks> {
        debug_assert!(rows.windows(2).all(|r| r[0].y < r[1].y), "rows in order");
        let mut slots: Vec<_> = half
            .pixels
            .chunks_mut(half.width.max(1))
            .map(Some)
            .collect();
        let pairs: Vec<_> = rows
            .chunk_by(|a, b| a.y / 2 == b.y / 2)
            .filter_map(|pair| Some((pair, slots.get_mut(pair[0].y as usize / 2)?.take()?)))
            .collect();
        let blocks = blocks_of(grid);
        let settled: Vec<(Vec<Peak>, Vec<Peak>)> = pairs
            .into_par_iter()
            .map(|(pair, slot)| {
                let mut kept = [Vec::new(), Vec::new()];
                for row in pair {
                    let (kept, share) = (&mut kept[row.y as usize % 2], share(row.y as usize));
                    for p in &row.texels {
                        let value = from + p.excess;
                        let part = (value.min(to) - from).max(Vec3::ZERO);
                        if part != Vec3::ZERO {
                            slot[p.x as usize / 2] += (part * share).extend(0.0);
                        }
                        let excess = (value - to).max(Vec3::ZERO);
                        if excess != Vec3::ZERO {
                            let (x, y) = (p.x, row.y);
                            kept.push(Peak {
                                face: 0,
                                x,
                                y,
                                excess,
                            });
                        }
                    }
                }
                match blocks {
                    Some(half) => summed(grid, half, &kept[0], &kept[1]),
                    None => (kept.concat(), Vec::new()),
                }
            })
            .collect();
        // The rows (16 bytes a peak) beside the settled peaks (24), then the settled peaks
        // twice while they are gathered: never more than 48 bytes a peak at once.
        drop(rows);
        let count = |pick: fn(&(Vec<Peak>, Vec<Peak>)) -> usize| settled.iter().map(pick).sum();
        let mut texels = Vec::with_capacity(count(|s| s.0.len()));
        let mut blocks = Vec::with_capacity(count(|s| s.1.len()));
        for (t, b) in settled {
            texels.extend(t);
            blocks.extend(b);
        }
        (!texels.is_empty() || !blocks.is_empty()).then_some(Peaks {
            ceiling: to,
            grid,
            texels,
            blocks,
        })
    }

    /// The grid `blocks` lie on: the panorama at half size.
    pub(super) fn block_grid(&self) -> Grid {
        blocks_of(self.grid).unwrap_or(self.grid)
    }
}

/// The grid of `grid`'s 2 x 2 blocks: an even-sized panorama's at half size; None for others.
fn blocks_of(grid: Grid) -> Option<Grid> {
    match grid {
        Grid::Projection(Projection::Equirect, w, h) if w % 2 == 0 && h % 2 == 0 => {
            Some(Grid::Projection(Projection::Equirect, w / 2, h / 2))
        }
        _ => None,
    }
}

/// The peaks of rows 2j (`upper`) and 2j + 1 (`lower`), each in column order, as the texels
/// left and the blocks summed.
fn summed(full: Grid, half: Grid, upper: &[Peak], lower: &[Peak]) -> (Vec<Peak>, Vec<Peak>) {
    let Some(by) = upper.first().or(lower.first()).map(|p| p.y / 2) else {
        return (Vec::new(), Vec::new());
    };
    let flux = |row: &[Peak]| {
        let omega = row
            .first()
            .map_or(0.0, |p| full.solid_angle(0, p.y as usize)) as f32;
        move |p: &Peak| p.excess * omega
    };
    let (fu, fl) = (flux(upper), flux(lower));
    let omega = half.solid_angle(0, by as usize) as f32;
    let (mut texels, mut blocks) = (Vec::new(), Vec::with_capacity(upper.len() / 2));
    let (mut i, mut j) = (0, 0);
    while i < upper.len() || j < lower.len() {
        let column = |row: &[Peak], k: usize| row.get(k).map_or(u32::MAX, |p| p.x / 2);
        let bx = column(upper, i).min(column(lower, j));
        let ends = |row: &[Peak], k: usize| k + row[k..].partition_point(|p| p.x / 2 == bx);
        let (a, b) = (&upper[i..ends(upper, i)], &lower[j..ends(lower, j)]);
        (i, j) = (i + a.len(), j + b.len());
        if let ([a0, a1], [b0, b1]) = (a, b) {
            let f = [fu(a0), fu(a1), fl(b0), fl(b1)];
            let total = f[0] + f[1] + f[2] + f[3];
            // The flux's centre off the block's, in texels: half the difference of its
            // halves over the whole.
            let centred = |d: Vec3| (0.5 * d.abs()).cmple(OFF_CENTRE * total).all();
            if centred(f[1] + f[3] - f[0] - f[2]) && centred(f[2] + f[3] - f[0] - f[1]) {
                blocks.push(Peak {
                    face: 0,
                    x: bx,
                    y: by,
                    excess: total / omega,
                });
                continue;
            }
        }
        texels.extend(a.iter().chain(b));
    }
    (texels, blocks)
}

#[cfg(test)]
mod tests;
