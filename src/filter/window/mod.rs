//! Exact sums for narrow lobes (cosine powers, Gaussians): each output texel is the
//! lobe-weighted mean of every source texel within the lobe's reach, with each texel's own
//! direction and solid angle, as the brute-force reference computes it, but only over the few
//! hundred texels the lobe covers.
//!
//! The sum runs on the coarsest box-mip level where the lobe is still `MIN_SIGMA_TEXELS`
//! texels wide (level 0 when it is narrower there): a 2049-power lobe on a 256-face source
//! has a standard deviation of 2.8 texels of level 0 and 1.4 of level 1; its sum over level 1
//! covers about 300 texels per output texel, costs about what 64 filtered importance samples
//! do, and is 5 to 9 times closer to the brute-force convolution (0.06% against 0.36% mean
//! relative error on park, 0.25% against 2.2% on esplanade). Output texels go in tiles
//! of 4 x 4 that share one gathered list of candidate texels (those within the lobe's reach of
//! any of them), found through blocks of source texels with bounding cones; the weight is a
//! function of u = 1 - cos(angle) computed eight candidates at a time (2 to the power of a
//! short polynomial fitted to the log weight, or GGX's own rational form: relative error under
//! 1e-6), u from the difference of the two unit vectors so narrow lobes keep their precision.
//! Fused multiply-adds (one rounding, the same bits on every CPU that has them; CPUs without
//! FMA take the portable build and compute them in software, much more slowly). Against the
//! table it replaced (two lookups per candidate, four candidates at a time): the cosine 256
//! chain's level 0 took 119 ms instead of 170 ms on one core.
//!
//! Split by role: `fit` turns a lobe into the weight formula, `source` prepares a level and
//! finds the texels near a tile, `sum` holds the weighted mean those texels go into; this
//! module plans the window and runs the tiles.

#![warn(missing_docs)]

mod fit;
mod source;
mod sum;

#[cfg(test)]
mod tests;

pub(crate) use fit::share_within;

use super::bright::BrightSum;
use super::lobe::Lobe;
use crate::cube::{face_dir, texel_dir, CubeSampler, Faces};
use crate::image::Image;
use fit::fit_log_weight;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use source::Source;
use std::f64::consts::FRAC_PI_2;
use std::marker::PhantomData;
use sum::Candidates;

/// Weights below this fraction of the lobe's peak are left out (a cosine power loses
/// e^-9.2 of its mass beyond, about 1e-4; the sum is normalised by the weights it keeps).
const EPS: f64 = 1e-3;

/// The lobe's standard deviation, in texels (at a face's centre) of the level the sum runs
/// on, at least. Measured on esplanade and park at 256 faces: 1.4 to 2.6 texels gave 0.03%
/// to 0.34% mean relative error against brute force; 0.7 to 1.3, 0.2% to 2.2%.
pub(crate) const MIN_SIGMA_TEXELS: f32 = 1.4;

/// Lobes reaching further than this (radians) are left to importance sampling: their
/// windows would hold thousands of texels.
const MAX_REACH: f32 = 0.5;

/// Output texels per tile edge, where the output's texels are the source level's size; twice
/// that where they are half the size (a chain's level 0 summed on source level 1: the tile
/// then covers as many source texels). Measured on the cosine 256 chain, one core: level 0
/// 123 -> 115 ms with 8; level 1 (same texel size) 67 -> 71 ms with 8, 106 ms with 2.
const TILE: usize = 4;

/// A whole lobe's width (GGX: 2 alpha) in texels of the level it is summed on, at least.
const WHOLE_SIGMA_TEXELS: f64 = 2.0;

/// Most weights a whole-lobe sum may take for one level (about 80 ms on one core): small
/// levels and small chains, where importance sampling was least accurate. 2^29 made the GGX
/// 256 chain 2.5 times slower (its middle levels summed whole); 2^26 left GGX's and Charlie's
/// level 1 of a 32 px chain sampled, 1.3-1.8% off brute force.
pub(crate) const WHOLE_BUDGET: f64 = (1u64 << 27) as f64;

/// [`WHOLE_BUDGET`] for Charlie, whose sampled ring was 1.85% off on a 64 px chain's level 1
/// (its chain, for sheen, is the rarer one; summed whole it is no slower than sampled).
pub(crate) const CHARLIE_WHOLE_BUDGET: f64 = (1u64 << 29) as f64;

/// Most weights a whole-lobe sum may take where a window would do, on a finer source (about
/// 20 ms on one core).
pub(crate) const SMALL_BUDGET: f64 = (1u64 << 25) as f64;

/// The smallest source level a whole lobe is summed on (the base where it is smaller).
const WHOLE_MIN_SOURCE: usize = 16;

/// Steps of a [`Shape::Table`] (Charlie's ring at alpha 0.04 spans 300 of them).
const TABLE_STEPS: usize = 8192;

/// Highest degree of the polynomial in a log-weight fit.
const MAX_DEGREE: usize = 4;

/// How a level is summed exactly: the source level, the lobe's reach and its weights.
pub(crate) struct Window {
    level: usize,
    /// One over the lobe's integral over the sphere in the shape's units (weight over peak,
    /// per steradian): the sum divides by it, not by its own weights, so every source texel
    /// sends its light times its solid angle into the sphere exactly once, whatever the lobe's
    /// width against the texels (issue 45: a lobe narrower than a texel gave the texel under
    /// it 30% more than the continuous integral the bright texels were divided by).
    norm: f32,
    /// Largest 1 - cos(angle) within reach.
    u_cut: f32,
    shape: Shape,
    /// [`Shape::Table`]'s weights over their largest, on equal steps of u from 0 to `u_cut`.
    table: Vec<f32>,
}

/// The lobe's weight over its peak as a function of u = 1 - cos(angle), in a form eight lanes
/// evaluate at once with plain arithmetic (a table lookup per lane cost as much as the rest
/// of the sum).
#[derive(Clone, Copy, Debug)]
enum Shape {
    /// 2^(u q(u)), q a polynomial (coefficients from the constant up): cosine powers and
    /// Gaussians, whose log weight over u is smooth and slowly varying on the reach.
    Exp2 { q: [f32; MAX_DEGREE + 1] },
    /// (1 - u) (a2 / (a2 + h u))^2 with h = (1 - a2) / 2: GGX, whose log has a pole just
    /// below u = 0 that no short polynomial follows.
    Ggx { a2: f32, h: f32 },
    /// Linear interpolation in `Window::table`, `scale` steps per unit of u: lobes summed
    /// over the whole sphere whose log weight no short polynomial follows (Charlie's ring,
    /// Gaussians reaching past 150 degrees).
    Table { scale: f32 },
}

impl Window {
    /// The exact sum for `lobe` on a source of `levels` box mips below a level 0 of edge
    /// `src_size`, or None for lobes it does not apply to (GGX and Charlie, whose tails reach
    /// far; lobes wider than `MAX_REACH`).
    pub(crate) fn plan(lobe: Lobe, src_size: usize, levels: usize) -> Option<Window> {
        // Standard deviation (radians) and the angle where the weight falls to EPS.
        let (sigma, reach) = match lobe {
            Lobe::CosinePower { power } if power >= 1.0 => {
                let p = power as f64;
                ((1.0 / p).sqrt(), EPS.powf(1.0 / p).acos())
            }
            Lobe::Gaussian { sigma } if sigma > 0.0 => {
                let s = sigma as f64;
                (s, s * (2.0 * (1.0 / EPS).ln()).sqrt())
            }
            _ => return None,
        };
        if reach >= MAX_REACH as f64 {
            return None;
        }
        let kept = fit::integral_over_peak(lobe, 1.0 - reach.cos());
        Some(Window::build(lobe, sigma, reach, src_size, levels, kept))
    }

    /// The part of `lobe` within `reach` radians of its axis, for lobes whose tails reach too
    /// far to sum whole (GGX: see `filter::hybrid`); `width` (radians) stands for the
    /// standard deviation in the choice of level. None where the core itself reaches too far.
    pub(crate) fn core(
        lobe: Lobe,
        width: f32,
        reach: f32,
        src_size: usize,
        levels: usize,
    ) -> Option<Window> {
        let whole = fit::integral_over_peak(lobe, 2.0);
        (reach < MAX_REACH)
            .then(|| Window::build(lobe, width as f64, reach as f64, src_size, levels, whole))
    }

    /// The sum on the coarsest level where the lobe is still MIN_SIGMA_TEXELS texels wide (a
    /// texel at the face centre spans 2 / n radians), its weights up to `reach`, divided by
    /// `integral` (of the weight over its peak, per steradian).
    fn build(
        lobe: Lobe,
        sigma: f64,
        reach: f64,
        src_size: usize,
        levels: usize,
        integral: f64,
    ) -> Window {
        let wide =
            |l: usize| sigma as f32 * (src_size >> l).max(1) as f32 / 2.0 >= MIN_SIGMA_TEXELS;
        let level = (0..levels).take_while(|&l| wide(l)).last().unwrap_or(0);
        let u_cut = 1.0 - reach.cos();
        let shape = match lobe {
            Lobe::Ggx { alpha } => {
                let a2 = alpha as f64 * alpha as f64;
                Shape::Ggx {
                    a2: a2 as f32,
                    h: ((1.0 - a2) * 0.5) as f32,
                }
            }
            _ => Shape::Exp2 {
                q: fit_log_weight(lobe, u_cut),
            },
        };
        Window {
            level,
            norm: (1.0 / integral) as f32,
            u_cut: u_cut as f32,
            shape,
            table: Vec::new(),
        }
    }

    /// The whole lobe summed exactly on a reduced source (every texel within its reach, the
    /// tail included), for GGX, Charlie and Gaussians too wide for [`Window::plan`]: on the coarsest level
    /// where the lobe is still `WHOLE_SIGMA_TEXELS` texels wide, when six faces of `size`
    /// output texels cost at most `budget` weights (importance sampling's trilinear
    /// lookups at coarse lods left 1-2.6% in GGX, Charlie and the Gaussian's wide levels of a
    /// 32 px chain, issue 45). None where it would cost more.
    pub(crate) fn whole(
        lobe: Lobe,
        src_size: usize,
        levels: usize,
        size: usize,
        budget: f64,
    ) -> Option<Self> {
        let sigma = match lobe {
            Lobe::Ggx { alpha } => 2.0 * alpha,
            Lobe::Charlie { .. } => lobe.width(),
            Lobe::Gaussian { sigma } => sigma,
            // Wide cosine lobes stay sampled: within 0.3% of brute force that way, and their
            // whole sums made the 256 cosine chain 12% slower.
            Lobe::CosinePower { .. } => return None,
        } as f64;
        let reach = (lobe.cutoff_cos().clamp(-1.0, 1.0) as f64).acos();
        let wide = |l: usize| sigma * (src_size >> l).max(1) as f64 / 2.0 >= WHOLE_SIGMA_TEXELS;
        // Not below WHOLE_MIN_SOURCE texels: on a 2 px level, GGX's alpha 1 (2 radians
        // wide) was 6% off brute force (on 16 px, 0.21%).
        let fine_enough = |l: usize| (src_size >> l) >= WHOLE_MIN_SOURCE.min(src_size);
        let level = (0..levels)
            .take_while(|&l| wide(l) && fine_enough(l))
            .last()
            .unwrap_or(0);
        let m = (src_size >> level).max(1) as f64;
        let candidates = 6.0 * m * m * (1.0 - reach.cos()) * 0.5;
        if 6.0 * (size * size) as f64 * candidates > budget {
            return None;
        }
        let u_cut = 1.0 - reach.cos();
        if let Lobe::Ggx { .. } = lobe {
            // GGX's own form is exact and vectorises; its reach is the hemisphere.
            let mut w = Window::build(lobe, sigma, reach.min(FRAC_PI_2), src_size, 1, 1.0);
            w.level = level;
            w.norm = (1.0 / fit::integral_over_peak(lobe, 2.0)) as f32;
            return Some(w);
        }
        let steps = TABLE_STEPS as f64;
        let raw: Vec<f64> = (0..=TABLE_STEPS)
            .map(|i| fit::weight_f64(lobe, 1.0 - u_cut * i as f64 / steps))
            .collect();
        let peak = raw.iter().copied().fold(0.0, f64::max).max(1e-300);
        Some(Window {
            level,
            norm: (peak / lobe.integral()) as f32,
            u_cut: u_cut as f32,
            shape: Shape::Table {
                scale: (steps / u_cut) as f32,
            },
            table: raw.iter().map(|w| (w / peak) as f32).collect(),
        })
    }

    /// The source level the sum runs on.
    pub(crate) fn level(&self) -> usize {
        self.level
    }

    /// The lobe's reach, radians.
    fn reach(&self) -> f32 {
        (1.0 - self.u_cut).acos()
    }
}

/// Filters one level by exact sums: six faces of edge `size`, tiles of 4 x 4 (or 8 x 8) texels in
/// parallel, plus the bright texels' exact part. Deterministic: every output texel's sum has
/// one order whatever the thread count.
pub(crate) fn filter_level(
    src: &CubeSampler,
    window: &Window,
    size: usize,
    bright: &BrightSum,
) -> Faces {
    let inv = 1.0 / size as f32;
    let reach = window.reach();
    let finer = size / src.level_size(window.level).max(1);
    let tile = (TILE * finer).clamp(TILE, 2 * TILE).min(size);
    // A tile's texel centres lie within `tile` texels of its axis, and no texel spans more
    // than 2 / size radians.
    let max_reach = reach + tile as f32 * 2.0 * inv;
    let source = Source::new(src, window.level, max_reach);
    let mut out: Faces = std::array::from_fn(|_| Image::new(size, size));
    // Rows of tiles, each a band of `tile` output rows of one face.
    let mut bands: Vec<(usize, usize, &mut [Vec4])> = Vec::new();
    for (face, img) in out.iter_mut().enumerate() {
        for (b, band) in img.pixels.chunks_mut(tile * size).enumerate() {
            bands.push((face, b * tile, band));
        }
    }
    bands.into_par_iter().for_each(|(face, y0, band)| {
        let setup = (&source, window, bright, size, tile, reach, max_reach);
        crate::simd::fast(Band((setup, face, y0, band), PhantomData));
    });
    out
}

type BandSetup<'k> = (
    &'k Source,
    &'k Window,
    &'k BrightSum,
    usize,
    usize,
    f32,
    f32,
);
crate::simd::kernel!(Band((BandSetup<'k>, usize, usize, &'k mut [Vec4])) -> () = filter_band);

/// One band of `filter_level`: `tile` output rows of one face, tile by tile.
#[inline(always)]
fn filter_band(
    ((source, window, bright, size, tile, reach, max_reach), face, y0, band): (
        BandSetup,
        usize,
        usize,
        &mut [Vec4],
    ),
) {
    let inv = 1.0 / size as f32;
    let centre = |face: usize, x: usize, y: usize| texel_dir(face, x, y, inv);
    let mut found = Candidates::default();
    let rows = band.len() / size;
    for x0 in (0..size).step_by(tile) {
        let (x1, y1) = ((x0 + tile).min(size), y0 + rows);
        // The tile's cone: its centre and the furthest texel centre from it.
        let mid = (x0 + x1) as f32 * 0.5 * inv;
        let (t, b) = (y0 as f32 * inv, y1 as f32 * inv);
        let axis = face_dir(face, mid, (t + b) * 0.5).normalize();
        let radius = [(x0, y0), (x1 - 1, y0), (x0, y1 - 1), (x1 - 1, y1 - 1)]
            .iter()
            .map(|&(x, y)| axis.dot(centre(face, x, y)).clamp(-1.0, 1.0).acos())
            .fold(0.0f32, f32::max);
        found.clear();
        source.gather(axis, (reach + radius + 1e-4).min(max_reach), &mut found);
        // The whole tile's bright part in one call (at most 8 x 8 texels): a row of a
        // four-wide tile alone would leave half of its eight lanes idle.
        let w = x1 - x0;
        let k = w * (y1 - y0);
        let ns: [Vec3; 64] = std::array::from_fn(|i| {
            let i = i.min(k - 1);
            centre(face, x0 + i % w, y0 + i / w)
        });
        let mut lit = [Vec3::ZERO; 64];
        bright.at_many(&ns[..k], &mut lit[..k]);
        for (i, (n, l)) in ns[..k].iter().zip(lit).enumerate() {
            let (x, y) = (x0 + i % w, y0 + i / w);
            band[(y - y0) * size + x] = found.mean(window, *n) + l.extend(0.0);
        }
    }
}
