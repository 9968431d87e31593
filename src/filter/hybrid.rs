//! Narrow GGX lobes split in two: the core within two lobe widths of the axis summed exactly
//! over the texels it covers (as `window` sums narrow cosine lobes), the long tail (GGX falls
//! off as the inverse fourth power of the angle: a fifth of its mass lies beyond two widths)
//! importance-sampled. The glossiest levels of a chain cost most as 64 trilinear samples
//! per texel; the core's exact sum over a few dozen texels of a coarse level and half the
//! samples for the tail cost less (GGX 512 chain, one thread: filtering 0.51 -> 0.46 s) and
//! come closer to brute force (128 faces, the detailed sky: levels 1 and 2 0.52% and 0.55%
//! mean relative error before, 0.31% and 0.26% split).

#![warn(missing_docs)]

use super::bright::{Bright, BrightSum};
use super::lobe::{self, Kernel, Lobe};
use super::window::{self, Window};
use crate::cube::{texel_dir, CubeSampler, Faces};
use glam::Vec3;
use rayon::prelude::*;

/// The core reaches this many lobe widths (2 alpha radians) from the axis: about 80% of the
/// mass. Three widths (90%) made the core's sum cost nearly what the samples it replaced did
/// (512 chain, level 1: 0.145 s against 0.26 s for 64 samples, one thread); two, 0.089 s.
const CORE_WIDTHS: f32 = 2.0;

/// The tail gets 1 / TAIL_SHARE of the samples the whole lobe would (at least `MIN_TAIL`).
/// A quarter was 5% faster but too few next to a sun: a tail sample landing on its clamped
/// residual stands for 1.25% of the lobe (the preview's pipeline error at roughness 0.25
/// rose from 0.01 to 0.043; with half, 0.006).
const TAIL_SHARE: u32 = 2;
const MIN_TAIL: u32 = 8;

/// A lobe's level planned as an exact core and a sampled tail.
pub(crate) struct Hybrid {
    core: Window,
    tail: Kernel,
    /// The core's share of the lobe's mass (over the sphere, weighted by solid angle).
    share: f32,
    lobe: Lobe,
    /// Samples per texel of the tail.
    pub(crate) samples: u32,
}

impl Hybrid {
    /// The split for `lobe` (GGX only) on a source of `levels` box mips below a level 0 of
    /// edge `src_size`, whose whole lobe would take `samples` samples; None where it does not
    /// pay or would not hold: other lobes, or cores wider than a window sums. A core narrower
    /// than the source's texels is still exact: each texel's light is divided by the lobe's
    /// integral, not by the few weights the core holds (issue 45: sampled instead, GGX level
    /// 1 of a 32 px chain was 3.4% off brute force).
    pub(crate) fn plan(lobe: Lobe, samples: u32, src_size: usize, levels: usize) -> Option<Self> {
        let Lobe::Ggx { alpha } = lobe else {
            return None;
        };
        let width = 2.0 * alpha;
        let reach = CORE_WIDTHS * width;
        let core = Window::core(lobe, width, reach, src_size, levels)?;
        let samples = (samples / TAIL_SHARE).max(MIN_TAIL);
        let tail = Kernel::ggx_tail(lobe, samples, src_size, reach)?;
        let share = window::share_within(lobe, reach) as f32;
        Some(Hybrid {
            core,
            tail,
            share,
            lobe,
            samples,
        })
    }

    /// Six faces of edge `size`: the core's light (already its share of the whole lobe's), the
    /// tail's mean weighted by its share, plus the bright texels' exact convolution with the whole lobe.
    pub(crate) fn filter_level(&self, src: &CubeSampler, size: usize, bright: &Bright) -> Faces {
        let none = Bright::default();
        let mut out =
            window::filter_level(src, &self.core, size, &BrightSum::new(&none, self.lobe));
        let tail = lobe::filter_level(src, &self.tail, size, self.lobe, &none);
        let bright = BrightSum::new(bright, self.lobe);
        let b = 1.0 - self.share;
        let inv = 1.0 / size as f32;
        // The core's faces become the level's, row by row.
        for (face, (core, tail)) in out.iter_mut().zip(&tail).enumerate() {
            let w = size.max(1);
            core.pixels
                .par_chunks_mut(w)
                .zip(tail.pixels.par_chunks(w))
                .enumerate()
                .for_each(|(y, (row, tail_row))| {
                    // Eight texels at a time: the bright part's lanes.
                    let mut lit = [Vec3::ZERO; 8];
                    for (x0, (os, ts)) in row.chunks_mut(8).zip(tail_row.chunks(8)).enumerate() {
                        let ns: [Vec3; 8] =
                            std::array::from_fn(|i| texel_dir(face, x0 * 8 + i, y, inv));
                        bright.at_many(&ns[..os.len()], &mut lit[..os.len()]);
                        for ((o, t), l) in os.iter_mut().zip(ts).zip(lit) {
                            *o += *t * b + l.extend(0.0);
                        }
                    }
                });
        }
        out
    }
}
