//! Every conversion: for each output texel, its direction; look the direction up in the input.
//! Coarse outputs are antialiased by supersampling the texel's footprint on a pyramid level.

#![warn(missing_docs)]

use crate::cube::{face_dir, texel_footprint, CubeMap, Dirs, Environment, Interp, BATCH};
use crate::flux::{Grid, Peaks};
use crate::image::Image;
use crate::layout::{angular, equirect, octahedral, sphere, Projection};
use glam::{Mat3, Vec3, Vec4};
use std::marker::PhantomData;

/// A rotation of the environment (degrees) and an optional handedness flip.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Orientation {
    /// Turn about +Y, degrees (90 brings the old centre +Z to +X).
    pub yaw: f32,
    /// Turn about +X, degrees, after yaw.
    pub pitch: f32,
    /// Turn about +Z, degrees, after pitch.
    pub roll: f32,
    /// Negate X of the input: the other handedness (some engines).
    pub mirror: bool,
}

impl Orientation {
    /// The matrix taking an output direction to the input direction that lands there.
    /// The environment turns by yaw about +Y, then pitch about +X, then roll about +Z
    /// (counter-clockwise looking down each axis); mirror negates X of the input.
    pub fn lookup_matrix(&self) -> Mat3 {
        let r = Mat3::from_rotation_y(self.yaw.to_radians())
            * Mat3::from_rotation_x(self.pitch.to_radians())
            * Mat3::from_rotation_z(self.roll.to_radians());
        let m = r.transpose();
        if self.mirror {
            Mat3::from_diagonal(Vec3::new(-1.0, 1.0, 1.0)) * m
        } else {
            m
        }
    }

    pub(crate) fn is_identity(&self) -> bool {
        *self == Orientation::default()
    }
}

/// How to resample: interpolation, antialiasing, orientation.
#[derive(Clone, Copy, Debug)]
pub struct Resampler {
    /// Interpolation of the source's texels.
    pub interp: Interp,
    /// Supersample texels whose footprint covers more than a source texel or so.
    pub antialias: bool,
    /// Rotation (and mirror) applied to the environment before sampling.
    pub orientation: Orientation,
}

impl Default for Resampler {
    fn default() -> Self {
        Resampler {
            interp: Interp::Bilinear,
            antialias: true,
            orientation: Orientation::default(),
        }
    }
}

/// Subsamples per axis of one coarse output texel, one per texel of the pyramid level they
/// read, so the taps cover its footprint evenly and a shrunk map keeps its flux. At least
/// MIN_SUB; up to MAX_SUB while the whole output stays within TAP_BUDGET taps: the flux error
/// left by uneven coverage averages out over many texels, so small outputs (faces of 8 or 16)
/// need the most taps and can afford them. Measured on the real panoramas: 4 everywhere
/// leaves up to 0.6% at faces 8; this schedule, 0.2%.
const MIN_SUB: usize = 4;
const MAX_SUB: usize = 16;
const TAP_BUDGET: f64 = (1 << 21) as f64;

/// Subsamples per axis for an output of `texels` texels in all.
fn taps_per_axis(texels: usize) -> usize {
    ((TAP_BUDGET / texels.max(1) as f64).sqrt() as usize).clamp(MIN_SUB, MAX_SUB)
}

/// Source texels an output texel may span and still be one tap at its centre, on level 0.
const ONE_TAP: f32 = 1.5;

/// Subsamples per axis of a texel a ball's rim cuts (its centre outside the ball).
const RIM_SUB: usize = 4;

/// The pyramid level a coarse output texel spanning `ratio` source texels reads with `sub`
/// taps per axis: the sharpest where it spans at most `sub` texels.
fn footprint_level(ratio: f32, sub: usize) -> usize {
    // ceil(log2(x)) from the float's bits: the exponent, plus one unless x is a power of two
    // (libm's log2f per coarse texel was 3% of a 4K -> 512 resample).
    let x = ratio / sub as f32;
    // (NaN too: no level below 0.)
    if x.is_nan() || x <= 1.0 {
        return 0;
    }
    if !x.is_finite() {
        return 64;
    }
    let bits = x.to_bits();
    ((bits >> 23) as usize - 127) + usize::from(bits & 0x7f_ffff != 0)
}

/// The pyramid levels an input needs for outputs whose texels span at most `ratio` of its
/// texels: level 0 alone up to `ONE_TAP`, else down to the deepest level any output reads.
pub(crate) fn levels_for(ratio: f32) -> usize {
    if ratio <= ONE_TAP {
        1
    } else {
        footprint_level(ratio, MIN_SUB) + 1
    }
}

impl Resampler {
    /// A cube map of face edge `size` from any environment.
    pub fn to_cube(&self, env: &dyn Environment, size: usize) -> CubeMap {
        self.to_cube_with_peaks(env, None, size)
    }

    /// `to_cube`, then an input's peaks (see [`crate::flux`]) splatted on top: `env` looks
    /// up the input below their ceiling.
    pub fn to_cube_with_peaks(
        &self,
        env: &dyn Environment,
        peaks: Option<&Peaks>,
        size: usize,
    ) -> CubeMap {
        let inv = 1.0 / size as f32;
        let grid = Grid::Cube(size);
        let mut faces = std::array::from_fn(|face| {
            self.render(
                env,
                (size, size, 6 * size * size, 2.0 * inv),
                |x, y| Some(face_dir(face, x * inv, y * inv)),
                |x, y| texel_footprint(inv, x, y),
                |x, y| grid.density(x, y),
            )
        });
        self.splat(peaks, grid, &mut faces);
        CubeMap {
            levels: vec![faces],
        }
    }

    /// Adds an input's peaks, if it has any, to an output rendered from the rest of it.
    fn splat(&self, peaks: Option<&Peaks>, grid: Grid, images: &mut [Image]) {
        if let Some(peaks) = peaks {
            let turn = (!self.orientation.is_identity()).then(|| self.orientation.lookup_matrix());
            peaks.splat(grid, turn, images);
        }
    }

    /// A panorama, mirror ball, angular or octahedral map of `w` x `h` from any environment.
    pub fn to_projection(
        &self,
        env: &dyn Environment,
        proj: Projection,
        w: usize,
        h: usize,
    ) -> Image {
        self.to_projection_with_peaks(env, None, proj, w, h)
    }

    /// `to_projection`, then an input's peaks splatted on top (see `to_cube_with_peaks`).
    pub fn to_projection_with_peaks(
        &self,
        env: &dyn Environment,
        peaks: Option<&Peaks>,
        proj: Projection,
        w: usize,
        h: usize,
    ) -> Image {
        let (iw, ih) = (1.0 / w as f32, 1.0 / h as f32);
        let at = move |p: Projection| move |x: f32, y: f32| p.to_dir(x * iw, y * ih);
        let grid = Grid::Projection(proj, w, h);
        let density = move |x: f32, y: f32| grid.density(x, y);
        // The output's size and texel count, and `widest` (see `render`).
        let dims = |widest: f32| (w, h, w * h, widest);
        // The angle one texel spans, from each layout's formula (its file's `footprint`). One
        // render per layout, so each inlines its own direction maths.
        let mut image = match proj {
            Projection::Equirect => {
                let rows = equirect::footprint(h);
                let dir = move |x: f32, y: f32| Some(equirect::uv_to_dir(x * iw, y * ih));
                self.render(env, dims(rows), dir, move |_, _| rows, density)
            }
            Projection::Angular => {
                let texel = angular::footprint(w);
                self.render(env, dims(texel), at(proj), move |_, _| texel, density)
            }
            Projection::Sphere => {
                let footprint = move |x: f32, y: f32| sphere::footprint(iw, ih, x, y);
                self.render(env, dims(f32::INFINITY), at(proj), footprint, density)
            }
            Projection::Octahedral => {
                let footprint = move |x: f32, y: f32| octahedral::footprint(iw, ih, x, y);
                self.render(env, dims(f32::INFINITY), at(proj), footprint, density)
            }
        };
        self.splat(peaks, grid, std::slice::from_mut(&mut image));
        image
    }

    /// The shared loop: `dir(x, y)` gives the direction at continuous pixel coordinates
    /// (None where the layout shows nothing), `footprint` the angle one texel spans there and
    /// `density` the solid angle per unit of texel area, which weights the taps of a texel.
    /// `texels` counts the whole output's texels (it sets the taps per coarse texel), `widest`
    /// bounds `footprint` over the whole output (infinity: no bound known).
    /// Texels are worked in short runs of a row: every tap of a run (one per texel, or up to
    /// MAX_SUB x MAX_SUB for coarse texels and for texels a ball's rim cuts) is queued and
    /// looked up in batches.
    fn render(
        &self,
        env: &dyn Environment,
        (w, h, texels, widest): (usize, usize, usize, f32),
        dir: impl Fn(f32, f32) -> Option<Vec3> + Sync,
        footprint: impl Fn(f32, f32) -> f32 + Sync,
        density: impl Fn(f32, f32) -> f32 + Sync,
    ) -> Image {
        let turn = (!self.orientation.is_identity()).then(|| self.orientation.lookup_matrix());
        let src_angle = env.texel_angle();
        let levels = env.levels();
        let sub = taps_per_axis(texels);
        // An output no sharper than the input anywhere takes one tap per texel: no texel's
        // footprint need be worked out (a square root and a division each).
        let single = !self.antialias || widest / src_angle <= ONE_TAP;
        Image::from_rows(w, h, |y, row| {
            let setup = (turn, src_angle, levels, sub, single);
            let lookups = (&dir, &footprint, &density);
            crate::simd::fast(RenderRow((self, env, setup, lookups, y, row), PhantomData))
        })
    }

    /// One row of `render` (inlined into both builds of `simd::fast`).
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn render_row<D, F, G>(
        (this, env, (turn, src_angle, levels, sub, single), (dir, footprint, density), y, row): (
            &Resampler,
            &dyn Environment,
            (Option<Mat3>, f32, usize, usize, bool),
            (&D, &F, &G),
            usize,
            &mut [Vec4],
        ),
    ) where
        D: Fn(f32, f32) -> Option<Vec3>,
        F: Fn(f32, f32) -> f32,
        G: Fn(f32, f32) -> f32,
    {
        let mut taps = Taps {
            env,
            interp: this.interp,
            turn,
            level: 0,
            dirs: Dirs::default(),
            slot: [0; BATCH],
            weight: [0.0; BATCH],
        };
        // Source texels a texel spans (0 without antialiasing: always one tap).
        let ratio = |cx: f32, cy: f32| {
            if this.antialias {
                footprint(cx, cy) / src_angle
            } else {
                0.0
            }
        };
        for (run, out) in row.chunks_mut(RUN).enumerate() {
            // The common case first: every texel of the run one tap at its centre (an
            // output about as sharp as the input), looked up straight into the row.
            if single_taps(&mut taps.dirs, run * RUN, y, out.len(), |cx, cy| {
                if single || ratio(cx, cy) <= ONE_TAP {
                    dir(cx, cy)
                } else {
                    None
                }
            }) {
                if let Some(m) = &turn {
                    taps.dirs.transform(m);
                }
                taps.dirs.normalize();
                env.sample_many(&taps.dirs, 0, this.interp, out);
                taps.dirs.len = 0;
                continue;
            }
            let mut acc = [Vec4::ZERO; RUN];
            // Sum of a texel's tap weights; 0 for a single tap (weight 1, no division).
            let mut total = [0.0f32; RUN];
            let mut empty = [true; RUN];
            for i in 0..out.len() {
                let x = run * RUN + i;
                let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
                let ratio = ratio(cx, cy);
                let centre = dir(cx, cy);
                if ratio <= ONE_TAP && (centre.is_some() || !this.antialias) {
                    if let Some(d) = centre {
                        taps.push(d, 0, i, 1.0, &mut acc);
                        empty[i] = false;
                    }
                    continue;
                }
                // A pyramid level where the footprint spans at most `sub` texels, then a
                // bilinear tap per texel of that level spread over the texel, each weighted
                // by the solid angle it stands for. A texel whose centre lies outside a
                // ball gets the taps inside it.
                let level = footprint_level(ratio, sub).min(levels - 1);
                let rest = ratio / (1u32 << level) as f32;
                let n = if centre.is_none() {
                    RIM_SUB
                } else {
                    (rest.ceil() as usize).clamp(1, sub)
                };
                let step = 1.0 / n as f32;
                for j in 0..n {
                    for k in 0..n {
                        let sx = x as f32 + (k as f32 + 0.5) * step;
                        let sy = y as f32 + (j as f32 + 0.5) * step;
                        if let Some(d) = dir(sx, sy) {
                            let wgt = density(sx, sy);
                            if wgt > 0.0 {
                                taps.push(d, level, i, wgt, &mut acc);
                                total[i] += wgt;
                                empty[i] = false;
                            }
                        }
                    }
                }
            }
            taps.flush(&mut acc);
            finish(out, &acc, &total, &empty);
        }
    }
}

/// A run's texels from their taps' sums: over their weights' `total` (0: one tap of weight
/// 1), 0 where no tap fell (`empty`).
#[inline]
fn finish(out: &mut [Vec4], acc: &[Vec4; RUN], total: &[f32; RUN], empty: &[bool; RUN]) {
    for (((o, &a), &t), &e) in out.iter_mut().zip(acc).zip(total).zip(empty) {
        *o = if e {
            Vec4::ZERO
        } else if t > 0.0 {
            a / t
        } else {
            a
        };
    }
}

crate::simd::kernel!(RenderRow<D, F, G>((&'k Resampler, &'k dyn Environment, (Option<Mat3>, f32, usize, usize, bool), (&'k D, &'k F, &'k G), usize, &'k mut [Vec4])) -> () = Resampler::render_row where D: Fn(f32, f32) -> Option<Vec3>, F: Fn(f32, f32) -> f32, G: Fn(f32, f32) -> f32);

/// Queues the centre directions of the `n` texels of row `y` from column `x0` into `dirs`,
/// or leaves `dirs` empty and says false when one of them needs more than its centre
/// (`centre` gives None for a texel to antialias or outside the layout).
#[inline(always)]
fn single_taps(
    dirs: &mut Dirs,
    x0: usize,
    y: usize,
    n: usize,
    centre: impl Fn(f32, f32) -> Option<Vec3>,
) -> bool {
    debug_assert!(dirs.len == 0 && n <= BATCH);
    let cy = y as f32 + 0.5;
    for i in 0..n {
        match centre((x0 + i) as f32 + 0.5, cy) {
            Some(d) => dirs.push(d),
            None => {
                dirs.len = 0;
                return false;
            }
        }
    }
    true
}

/// Output texels per run: their sums live on the stack while the run's taps are looked up.
const RUN: usize = 64;

/// Queued lookups of one level, each adding into the sum of the texel (slot) it belongs to.
/// Flushing keeps each slot's order of additions, so results do not depend on batch edges.
struct Taps<'a> {
    env: &'a dyn Environment,
    interp: Interp,
    turn: Option<Mat3>,
    level: usize,
    dirs: Dirs,
    slot: [u8; BATCH],
    weight: [f32; BATCH],
}

impl Taps<'_> {
    #[inline]
    fn push(&mut self, d: Vec3, level: usize, slot: usize, weight: f32, acc: &mut [Vec4; RUN]) {
        if self.dirs.is_full() || (level != self.level && self.dirs.len > 0) {
            self.flush(acc);
        }
        self.level = level;
        self.slot[self.dirs.len] = slot as u8;
        self.weight[self.dirs.len] = weight;
        self.dirs.push(d);
    }

    fn flush(&mut self, acc: &mut [Vec4; RUN]) {
        let n = self.dirs.len;
        if n == 0 {
            return;
        }
        if let Some(m) = &self.turn {
            self.dirs.transform(m);
        }
        self.dirs.normalize();
        let mut out = [Vec4::ZERO; BATCH];
        self.env
            .sample_many(&self.dirs, self.level, self.interp, &mut out[..n]);
        for ((&s, &w), v) in self.slot[..n].iter().zip(&self.weight[..n]).zip(&out[..n]) {
            acc[s as usize] += *v * w;
        }
        self.dirs.len = 0;
    }
}

/// An environment given by a function of direction: exact ground truth for tests and fixtures.
pub struct FnEnv<F: Fn(Vec3) -> Vec4 + Sync>(pub F);

impl<F: Fn(Vec3) -> Vec4 + Sync> Environment for FnEnv<F> {
    fn sample(&self, d: Vec3, _level: usize, _interp: Interp) -> Vec4 {
        (self.0)(d)
    }
    fn texel_angle(&self) -> f32 {
        1e-6
    }
    fn levels(&self) -> usize {
        1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The level from the float's bits is ceil(log2) exactly (checked in f64, where no value
    /// just above a power of two rounds onto it), 0 up to a footprint of `sub` texels.
    #[test]
    fn footprint_level_is_the_exact_ceiling_of_log2() {
        let mut x = 1e-3f32;
        while x < 1e7 {
            for sub in [1, 4, 16] {
                let want = (x as f64 / sub as f64).log2().ceil().max(0.0) as usize;
                assert_eq!(footprint_level(x, sub), want, "{x} / {sub}");
            }
            x = f32::from_bits(x.to_bits() + 997);
        }
        for p in 0..20 {
            let x = (1u32 << p) as f32;
            assert_eq!(footprint_level(x, 1), p as usize);
            assert_eq!(
                footprint_level(f32::from_bits(x.to_bits() + 1), 1),
                p as usize + 1
            );
        }
        assert_eq!(footprint_level(f32::NAN, 4), 0);
        assert_eq!(footprint_level(f32::INFINITY, 4), 64);
    }
}
