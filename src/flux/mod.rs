//! Light conservation. The flux of a map (its solid-angle-weighted mean radiance, per channel)
//! must survive every resampling, HDR suns included.
//!
//! Filtered lookups are exact enough on bounded radiance, but a sun a few texels wide is hit or
//! missed by a tap, and each hit stands for a different solid angle than the sun has (43% off
//! at some sizes). So an input is split in two, exactly: a bounded part, each channel at most
//! `PEAK_RATIO` times its mean over the sphere, which the resampler looks up as before, and the
//! excess above that ceiling (the peaks: a sun, a lamp), which is splatted. Each peak texel's
//! excess radiance times its solid angle is cut into sub-cells, each sub-cell's share is added
//! to the output texel its direction lands in, and each output texel divides what it received
//! by its own solid angle. The peaks' flux arrives whole, whatever the two sizes; only a few
//! texels pay for it, so the common path keeps its speed.

#![warn(missing_docs)]

use crate::cube::{dir_face, face_dir, solid_angle_table, texel_density, texel_solid_angle};
use crate::image::Image;
use crate::layout::{equirect, Projection};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::f64::consts::PI;

mod peaks;
pub mod sun;
pub use peaks::Peaks;
pub(crate) use peaks::{PeakRow, RowStats};

/// Texels with a channel above this multiple of its mean hold peaks. Low enough that the
/// bounded part's lookup error is far under the 0.5% flux budget on real panoramas, high
/// enough that peaks stay a small share of the texels (at most 1/8 of the sphere).
pub(crate) const PEAK_RATIO: f32 = 8.0;

/// The texel grid of a layout: where each texel looks and how much of the sphere it covers.
/// The geometry is the layout's (`layout`'s file for each projection, `cube` for faces);
/// a grid names it and adds what splatting needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Grid {
    /// Six faces of edge n.
    Cube(usize),
    /// One w x h image.
    Projection(Projection, usize, usize),
}

impl Grid {
    /// Number of images (6 faces or 1).
    pub fn faces(self) -> usize {
        match self {
            Grid::Cube(_) => 6,
            Grid::Projection(..) => 1,
        }
    }

    /// Width and height of each image.
    pub(crate) fn dims(self) -> (usize, usize) {
        match self {
            Grid::Cube(n) => (n, n),
            Grid::Projection(_, w, h) => (w, h),
        }
    }

    /// The unit direction at continuous texel coordinates (x, y) of `face`, None where the
    /// layout shows nothing (outside a ball).
    #[inline]
    pub fn dir(self, face: usize, x: f32, y: f32) -> Option<Vec3> {
        match self {
            Grid::Cube(n) => {
                let inv = 1.0 / n as f32;
                Some(face_dir(face, x * inv, y * inv).normalize())
            }
            Grid::Projection(p, w, h) => p.to_dir(x / w as f32, y / h as f32),
        }
    }

    /// The k x k sub-cells of texel (x, y) of `face` (row by row) that have a direction, with
    /// their weights (`density`), into `cells`; returns the sum of the weights. A panorama's
    /// directions are separable: k sines and cosines per axis, not per cell. `k` is at most 64.
    pub(crate) fn sub_cells(
        self,
        face: usize,
        x: f32,
        y: f32,
        k: usize,
        cells: &mut Vec<(Vec3, f32)>,
    ) -> f32 {
        debug_assert!((1..=64).contains(&k));
        let at = |i: usize| (i as f32 + 0.5) / k as f32;
        let mut total = 0.0f32;
        if let Grid::Projection(Projection::Equirect, w, h) = self {
            let (iw, ih) = (1.0 / w as f32, 1.0 / h as f32);
            let area = std::f32::consts::TAU * iw * PI as f32 * ih;
            let mut lon = [(0.0f32, 0.0f32); 64];
            let lon = &mut lon[..k.min(64)];
            for (i, l) in lon.iter_mut().enumerate() {
                *l = equirect::sin_cos(((x + at(i)) * iw - 0.5) * std::f32::consts::TAU);
            }
            for j in 0..k {
                let (st, ct) = equirect::sin_cos((0.5 - (y + at(j)) * ih) * PI as f32);
                let wgt = area * ct.max(0.0);
                if wgt <= 0.0 {
                    continue;
                }
                for &(sp, cp) in lon.iter() {
                    cells.push((Vec3::new(ct * sp, st, ct * cp), wgt));
                    total += wgt;
                }
            }
            return total;
        }
        for j in 0..k {
            for i in 0..k {
                let (sx, sy) = (x + at(i), y + at(j));
                let wgt = self.density(sx, sy);
                if wgt <= 0.0 {
                    continue;
                }
                if let Some(d) = self.dir(face, sx, sy) {
                    cells.push((d, wgt));
                    total += wgt;
                }
            }
        }
        total
    }

    /// The texel a unit direction falls in. On a ball the point is kept half a texel inside
    /// the rim, so the texel it names always covers some of the sphere.
    #[inline]
    pub(crate) fn locate(self, d: Vec3) -> (usize, usize, usize) {
        let (f, x, y) = self.position(d);
        let (w, h) = self.dims();
        (f, (x as usize).min(w - 1), (y as usize).min(h - 1))
    }

    /// Continuous texel coordinates of a unit direction (see `locate`).
    #[inline]
    pub fn position(self, d: Vec3) -> (usize, f32, f32) {
        match self {
            Grid::Cube(n) => {
                let (f, s, t) = dir_face(d);
                (f, s * n as f32, t * n as f32)
            }
            Grid::Projection(p, w, h) => {
                let at = p.position(w, h, d);
                (0, at.x, at.y)
            }
        }
    }

    /// A mirror ball or angular map: a disc in a square.
    fn is_ball(self) -> bool {
        matches!(self, Grid::Projection(p, ..) if p.is_ball())
    }

    /// The texels along one axis (of `n`) that a span of `side` texels centred on `at`
    /// overlaps, with the fraction of the span each gets. The span is kept inside the image
    /// (a panorama's columns wrap).
    #[inline(always)]
    fn spans(self, at: f32, side: f32, n: usize) -> [Option<(usize, f32)>; 2] {
        let wraps = matches!(self, Grid::Projection(Projection::Equirect, w, _) if w == n);
        let half = 0.5 * side;
        let c = if wraps {
            at
        } else {
            at.clamp(half, n as f32 - half)
        };
        let (lo, hi) = (c - half, c + half);
        // floor() without libm's call (texel coordinates, far inside i32's range).
        let t = lo as i32 as f32;
        let first = if t > lo { t - 1.0 } else { t };
        let index = |v: f32| {
            if wraps {
                (v as i64).rem_euclid(n as i64) as usize
            } else {
                (v.max(0.0) as usize).min(n - 1)
            }
        };
        if side <= 0.0 || hi <= first + 1.0 {
            return [Some((index(first), 1.0)), None];
        }
        let a = (first + 1.0 - lo) / side;
        [Some((index(first), a)), Some((index(first + 1.0), 1.0 - a))]
    }

    /// Solid angle per unit texel area at continuous texel coordinates (0 outside a ball):
    /// the weight of a point when a texel is cut into sub-cells.
    #[inline(always)]
    pub(crate) fn density(self, x: f32, y: f32) -> f32 {
        match self {
            Grid::Cube(n) => texel_density(n, x, y),
            Grid::Projection(p, w, h) => p.texel_density(w, h, x, y),
        }
    }

    /// Solid angle of texel (x, y) (the same on every face of a cube): exact for cube faces,
    /// panoramas and octahedral maps (closed forms), a fine midpoint sum on balls (16 x 16 on
    /// the rim, where the disc cuts texels).
    pub fn solid_angle(self, x: usize, y: usize) -> f64 {
        match self {
            Grid::Cube(n) => texel_solid_angle(n, x, y) as f64,
            Grid::Projection(p, w, h) => p.texel_solid_angle(w, h, x, y),
        }
    }

    /// Every texel's solid angle, face by face, row by row.
    pub(crate) fn solid_angles(self) -> Vec<f64> {
        let (w, h) = self.dims();
        match self {
            Grid::Cube(n) => {
                let one: Vec<f64> = solid_angle_table(n).iter().map(|&a| a as f64).collect();
                (0..6).flat_map(|_| one.iter().copied()).collect()
            }
            _ => (0..h)
                .into_par_iter()
                .flat_map_iter(|y| (0..w).map(move |x| self.solid_angle(x, y)))
                .collect(),
        }
    }
}

/// The flux of a map: solid-angle-weighted mean radiance per channel (R, G, B). Sums run in
/// f64, row by row, then in a fixed order, so the figure does not depend on thread count.
pub fn mean_radiance(grid: Grid, images: &[&Image]) -> [f64; 3] {
    let (w, h) = grid.dims();
    // A panorama's rows each have one solid angle (two sines): no table of every texel's.
    let equirect = matches!(grid, Grid::Projection(Projection::Equirect, ..));
    // A cube's six faces share one face's table: no table of every texel's (at 4096 px it
    // was 800 MB of f64 beside the faces).
    let face_table = match grid {
        Grid::Cube(n) => solid_angle_table(n),
        _ => Vec::new(),
    };
    let omega = if equirect || !face_table.is_empty() {
        Vec::new()
    } else {
        grid.solid_angles()
    };
    let rows: Vec<([f64; 3], f64)> = (0..grid.faces() * h)
        .into_par_iter()
        .map(|fy| {
            let (face, y) = (fy / h, fy % h);
            let row = &images[face].pixels[y * w..(y + 1) * w];
            if equirect {
                let a = equirect::texel_solid_angle(w, h, y);
                return row_sums(row, |_| a);
            }
            row_sums(row, |x| match face_table.get(y * w + x) {
                Some(&t) => t as f64,
                None => omega[(face * h + y) * w + x],
            })
        })
        .collect();
    mean_of_rows(rows)
}

/// One row's radiance times solid angle per channel and its solid angle, summed in f64 along
/// the row (`a(x)`: texel x's solid angle).
#[inline]
fn row_sums(row: &[Vec4], a: impl Fn(usize) -> f64) -> ([f64; 3], f64) {
    let mut acc = [0.0f64; 3];
    let mut total = 0.0;
    for (x, p) in row.iter().enumerate() {
        let a = a(x);
        for c in 0..3 {
            acc[c] += p[c] as f64 * a;
        }
        total += a;
    }
    (acc, total)
}

/// Row `y` of a single-image `grid`'s share of [`mean_radiance`], for a map read a band of
/// rows at a time: the same sums, so [`mean_of_rows`] over every row in order gives the same
/// bits as the whole image.
pub(crate) fn projection_row(grid: Grid, y: usize, row: &[Vec4]) -> ([f64; 3], f64) {
    match grid {
        Grid::Projection(Projection::Equirect, w, h) => {
            let a = equirect::texel_solid_angle(w, h, y);
            row_sums(row, |_| a)
        }
        _ => row_sums(row, |x| grid.solid_angle(x, y)),
    }
}

/// The flux from every row's sums ([`projection_row`]), added in row order.
pub(crate) fn mean_of_rows(rows: impl IntoIterator<Item = ([f64; 3], f64)>) -> [f64; 3] {
    let mut acc = [0.0f64; 3];
    let mut total = 0.0;
    for (r, t) in rows {
        for c in 0..3 {
            acc[c] += r[c];
        }
        total += t;
    }
    acc.map(|v| if total > 0.0 { v / total } else { 0.0 })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solid_angles_cover_the_sphere() {
        for grid in [
            Grid::Cube(7),
            Grid::Projection(Projection::Equirect, 64, 32),
            Grid::Projection(Projection::Sphere, 64, 64),
            Grid::Projection(Projection::Angular, 64, 64),
            Grid::Projection(Projection::Angular, 257, 257),
            Grid::Projection(Projection::Octahedral, 64, 64),
            Grid::Projection(Projection::Octahedral, 33, 33),
        ] {
            let sum: f64 = grid.solid_angles().iter().sum();
            assert!((sum / (4.0 * PI) - 1.0).abs() < 2e-4, "{grid:?}: {sum}");
        }
    }

    #[test]
    fn density_integrates_to_the_solid_angle() {
        let grid = Grid::Projection(Projection::Equirect, 64, 32);
        for y in [0, 5, 16, 31] {
            let mid = grid.density(3.5, y as f32 + 0.5) as f64;
            let exact = grid.solid_angle(3, y);
            assert!(
                (mid / exact - 1.0).abs() < 0.01,
                "row {y}: {mid} vs {exact}"
            );
        }
    }
}
