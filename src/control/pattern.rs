//! Procedural sources: gradients, checkers, stripes and value noise, each a function of the
//! texel centre's (u, v), evaluated row by row in parallel.

#![warn(missing_docs)]

use super::numbers::{
    angle, cells, count, eight, eight_cells, half, middle, octaves, one_octave, origin, point,
    radius, right, unit,
};
use rayon::prelude::*;
use serde::Deserialize;

/// 0 at `from`, 1 at `to`, clamped beyond them.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinearGradient {
    /// Where the value is 0, `[u, v]` as fractions of the image; default the top-left corner.
    #[serde(default = "origin", deserialize_with = "point")]
    pub from: [f32; 2],
    /// Where the value reaches 1, `[u, v]`; default the top-right corner (left to right).
    #[serde(default = "right", deserialize_with = "point")]
    pub to: [f32; 2],
}

/// 0 at `center`, 1 at `radius` and beyond.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadialGradient {
    /// Where the value is 0, `[u, v]`; default the middle of the image.
    #[serde(default = "middle", deserialize_with = "point")]
    pub center: [f32; 2],
    /// Distance at which the value reaches 1, a fraction of the image (up to 2); default 0.5.
    #[serde(default = "half", deserialize_with = "radius")]
    pub radius: f32,
}

/// `cells[0]` x `cells[1]` cells, 0 in the top-left one.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Checker {
    /// Cells across and down; default 8 x 8.
    #[serde(default = "eight_cells", deserialize_with = "cells")]
    pub cells: [u32; 2],
}

/// `count` periods, each 1 over its first `width` and 0 over the rest.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stripes {
    /// Periods across the image (along the stripes' direction); default 8.
    #[serde(default = "eight", deserialize_with = "count")]
    pub count: u32,
    /// The fraction of each period that is 1, in [0, 1]; default 0.5.
    #[serde(default = "half", deserialize_with = "unit")]
    pub width: f32,
    /// Degrees: 0 changes left to right, 90 top to bottom.
    #[serde(default, deserialize_with = "angle")]
    pub angle: f32,
    /// Shift, as a fraction of a period.
    #[serde(default, deserialize_with = "unit")]
    pub offset: f32,
}

/// Seeded, tiling value noise.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// Lattice cells across and down at the first octave (the noise tiles); default 8 x 8.
    #[serde(default = "eight_cells", deserialize_with = "cells")]
    pub cells: [u32; 2],
    /// Picks the pattern: the same seed gives the same values on every run and machine.
    #[serde(default)]
    pub seed: u64,
    /// Layers summed, each with twice the cells of the one before; default 1.
    #[serde(default = "one_octave", deserialize_with = "octaves")]
    pub octaves: u32,
    /// Weight of each octave relative to the one before, in [0, 1]; default 0.5.
    #[serde(default = "half", deserialize_with = "unit")]
    pub persistence: f32,
}

impl LinearGradient {
    /// The values at `width` x `height`, rows top to bottom.
    pub(super) fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let (fx, fy) = (self.from[0] as f64, self.from[1] as f64);
        let (dx, dy) = (self.to[0] as f64 - fx, self.to[1] as f64 - fy);
        let len2 = dx * dx + dy * dy;
        plane(width, height, |u, v| {
            (((u - fx) * dx + (v - fy) * dy) / len2).clamp(0.0, 1.0)
        })
    }
}

impl RadialGradient {
    /// The values at `width` x `height`, rows top to bottom.
    pub(super) fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let (cx, cy) = (self.center[0] as f64, self.center[1] as f64);
        let r = self.radius as f64;
        plane(width, height, |u, v| {
            ((u - cx).hypot(v - cy) / r).clamp(0.0, 1.0)
        })
    }
}

impl Checker {
    /// The values at `width` x `height`, rows top to bottom.
    pub(super) fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let (cx, cy) = (self.cells[0] as f64, self.cells[1] as f64);
        plane(width, height, |u, v| {
            let i = (u * cx).floor() as u64 + (v * cy).floor() as u64;
            (i % 2) as f64
        })
    }
}

impl Stripes {
    /// The values at `width` x `height`, rows top to bottom.
    pub(super) fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        let (sin, cos) = sin_cos_degrees(self.angle as f64);
        let (n, wd, off) = (self.count as f64, self.width as f64, self.offset as f64);
        plane(width, height, |u, v| {
            let p = (u * cos + v * sin) * n - off;
            if p - p.floor() < wd {
                1.0
            } else {
                0.0
            }
        })
    }
}

impl Noise {
    /// The values at `width` x `height`, rows top to bottom.
    pub(super) fn eval(&self, width: usize, height: usize) -> Vec<f32> {
        plane(width, height, |u, v| self.at(u, v))
    }
}

/// Fills a plane from `f(u, v)` at texel centres, rows in parallel.
fn plane(width: usize, height: usize, f: impl Fn(f64, f64) -> f64 + Sync) -> Vec<f32> {
    let mut out = vec![0.0f32; width * height];
    if width == 0 {
        return out;
    }
    out.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
        let v = (y as f64 + 0.5) / height as f64;
        for (x, p) in row.iter_mut().enumerate() {
            let u = (x as f64 + 0.5) / width as f64;
            *p = f(u, v) as f32;
        }
    });
    out
}

/// Exact at multiples of 90 degrees, so axis-aligned stripes have no drift.
fn sin_cos_degrees(deg: f64) -> (f64, f64) {
    let a = deg.rem_euclid(360.0);
    if a == 0.0 {
        (0.0, 1.0)
    } else if a == 90.0 {
        (1.0, 0.0)
    } else if a == 180.0 {
        (0.0, -1.0)
    } else if a == 270.0 {
        (-1.0, 0.0)
    } else {
        a.to_radians().sin_cos()
    }
}

impl Noise {
    /// The value at (u, v): octaves of smoothly interpolated lattice values, in [0, 1].
    pub fn at(&self, u: f64, v: f64) -> f64 {
        let mut sum = 0.0;
        let mut total = 0.0;
        let mut weight = 1.0;
        for octave in 0..self.octaves {
            let cx = (self.cells[0] as u64) << octave;
            let cy = (self.cells[1] as u64) << octave;
            let (px, py) = (u * cx as f64, v * cy as f64);
            let (x0, y0) = (px.floor(), py.floor());
            let (fx, fy) = (smoother(px - x0), smoother(py - y0));
            let (ix, iy) = (x0 as u64 % cx, y0 as u64 % cy);
            let (ix1, iy1) = ((ix + 1) % cx, (iy + 1) % cy);
            let l = |x, y| lattice(self.seed, octave, x, y);
            let top = l(ix, iy) * (1.0 - fx) + l(ix1, iy) * fx;
            let bottom = l(ix, iy1) * (1.0 - fx) + l(ix1, iy1) * fx;
            sum += weight * (top * (1.0 - fy) + bottom * fy);
            total += weight;
            weight *= self.persistence as f64;
        }
        (sum / total).clamp(0.0, 1.0)
    }
}

/// Quintic smoothstep: 6t^5 - 15t^4 + 10t^3 (zero first and second derivative at 0 and 1).
#[inline]
fn smoother(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// The noise value at lattice point (x, y) of an octave: a hash of the point and the seed,
/// in [0, 1]. The same inputs give the same value on every run and machine.
pub fn lattice(seed: u64, octave: u32, x: u64, y: u64) -> f64 {
    let mut h = mix64(seed ^ 0x9E37_79B9_7F4A_7C15);
    h = mix64(h ^ x.wrapping_mul(0xA24B_AED4_963E_E407));
    h = mix64(h ^ y.wrapping_mul(0x9FB2_1C65_1E98_DF25));
    h = mix64(h ^ (octave as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93));
    (h >> 11) as f64 / ((1u64 << 53) - 1) as f64
}

/// The splitmix64 finaliser.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lattice_is_in_range() {
        for i in 0..1000 {
            let v = lattice(i, 0, i * 7, i * 13);
            assert!((0.0..=1.0).contains(&v));
        }
    }
}
