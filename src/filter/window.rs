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

#![warn(missing_docs)]

use super::bright::BrightSum;
use super::lobe::Lobe;
use crate::cube::{face_dir, solid_angle_table, texel_dir, CubeSampler, Faces};
use crate::image::Image;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::f32::consts::PI;
use std::marker::PhantomData;

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

/// Candidate texels per lane group: eight, one AVX register (two SSE ones without AVX).
const LANES: usize = 8;

/// Highest degree of the polynomial in a log-weight fit.
const MAX_DEGREE: usize = 4;

/// How a level is summed exactly: the source level, the lobe's reach and its weights.
pub(crate) struct Window {
    level: usize,
    /// Largest 1 - cos(angle) within reach.
    u_cut: f32,
    shape: Shape,
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
        Some(Window::build(lobe, sigma, reach, src_size, levels))
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
        (reach < MAX_REACH)
            .then(|| Window::build(lobe, width as f64, reach as f64, src_size, levels))
    }

    /// The sum on the coarsest level where the lobe is still MIN_SIGMA_TEXELS texels wide (a
    /// texel at the face centre spans 2 / n radians), its weights up to `reach`.
    fn build(lobe: Lobe, sigma: f64, reach: f64, src_size: usize, levels: usize) -> Window {
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
            u_cut: u_cut as f32,
            shape,
        }
    }

    /// The lobe's reach, radians.
    fn reach(&self) -> f32 {
        (1.0 - self.u_cut).acos()
    }
}

/// The polynomial q of [`Shape::Exp2`] for `lobe` on 0 < u <= `u_cut`, of the lowest degree
/// whose weights (its f32 coefficients, evaluated in f64) are within 2e-7 of the lobe's
/// relative to it (else the closest fit of degree up to MAX_DEGREE). Chebyshev interpolation on t = u / u_cut,
/// turned into powers of t and then of u in f64 (the coefficients fall fast: the log weights
/// are nearly linear in u).
fn fit_log_weight(lobe: Lobe, u_cut: f64) -> [f32; MAX_DEGREE + 1] {
    let peak = weight_f64(lobe, 1.0).ln();
    let q = |t: f64| {
        let u = t * u_cut;
        (weight_f64(lobe, 1.0 - u).ln() - peak) / (u * std::f64::consts::LN_2)
    };
    let horner = |c: &[f32], t: f64| c.iter().rev().fold(0.0, |a, &k| a * t + k as f64);
    let mut best = ([0.0; MAX_DEGREE + 1], f64::INFINITY);
    for degree in 1..=MAX_DEGREE {
        let n = degree + 1;
        // Chebyshev nodes on (0, 1) and the interpolant's coefficients.
        let nodes: Vec<f64> = (0..n)
            .map(|k| 0.5 + 0.5 * (std::f64::consts::PI * (k as f64 + 0.5) / n as f64).cos())
            .collect();
        let values: Vec<f64> = nodes.iter().map(|&t| q(t)).collect();
        let cheb: Vec<f64> = (0..n)
            .map(|j| {
                let s: f64 = (0..n)
                    .map(|k| {
                        let a = std::f64::consts::PI * j as f64 * (k as f64 + 0.5) / n as f64;
                        values[k] * a.cos()
                    })
                    .sum();
                s * if j == 0 { 1.0 } else { 2.0 } / n as f64
            })
            .collect();
        // T_j(2t - 1) as powers of t, by the three-term recurrence.
        let mut power = [0.0f64; MAX_DEGREE + 1];
        let (mut prev, mut cur) = (vec![1.0], vec![-1.0, 2.0]);
        for (j, c) in cheb.iter().enumerate() {
            let t_j: &[f64] = if j == 0 { &prev } else { &cur };
            for (p, t) in power.iter_mut().zip(t_j) {
                *p += c * t;
            }
            if j >= 1 {
                let mut next = vec![0.0; cur.len() + 1];
                for (i, &v) in cur.iter().enumerate() {
                    next[i + 1] += 4.0 * v;
                    next[i] -= 2.0 * v;
                }
                for (i, &v) in prev.iter().enumerate() {
                    next[i] -= v;
                }
                prev = std::mem::replace(&mut cur, next);
            }
        }
        let mut scale = 1.0;
        let coeffs = power.map(|c| {
            let c = (c * scale) as f32;
            scale /= u_cut;
            c
        });
        let error = (0..=4096)
            .map(|i| {
                let t = (i as f64 / 4096.0).max(1e-9);
                let u = t * u_cut;
                ((u * horner(&coeffs, u) - u * q(t)) * std::f64::consts::LN_2)
                    .exp_m1()
                    .abs()
            })
            .fold(0.0, f64::max);
        if error < best.1 {
            best = (coeffs, error);
        }
        if error <= 2e-7 {
            break;
        }
    }
    best.0
}

/// The share of `lobe`'s mass (weighted by solid angle) within `reach` radians of its axis:
/// the midpoint rule on 2^16 steps either side of the reach, in f64.
pub(crate) fn share_within(lobe: Lobe, reach: f32) -> f64 {
    let mass = |a: f64, b: f64| {
        const STEPS: usize = 1 << 16;
        let dt = (b - a) / STEPS as f64;
        (0..STEPS)
            .map(|i| {
                let t = a + (i as f64 + 0.5) * dt;
                weight_f64(lobe, t.cos()) * t.sin()
            })
            .sum::<f64>()
            * dt
    };
    let r = (reach as f64).min(std::f64::consts::PI);
    let core = mass(0.0, r);
    let total = core + mass(r, std::f64::consts::PI);
    if total > 0.0 {
        core / total
    } else {
        1.0
    }
}

/// The lobe's weight at cosine `c`, in f64 for the fits and the tests.
fn weight_f64(lobe: Lobe, c: f64) -> f64 {
    match lobe {
        Lobe::CosinePower { power } => c.max(0.0).powf(power as f64),
        Lobe::Gaussian { sigma } => {
            let a = c.clamp(-1.0, 1.0).acos();
            (-a * a / (2.0 * sigma as f64 * sigma as f64)).exp()
        }
        // In f64 from 1 - c: the core of a narrow GGX lobe lies within 1e-4 of c = 1.
        Lobe::Ggx { alpha } => {
            let a2 = alpha as f64 * alpha as f64;
            let d = a2 + 0.5 * (1.0 - c) * (1.0 - a2);
            if c > 0.0 {
                a2 / (std::f64::consts::PI * d * d) * c
            } else {
                0.0
            }
        }
        other => other.weight(c as f32) as f64,
    }
}

/// One source level prepared for gathering: every texel's direction, solid angle and value
/// (face by face, row by row), and blocks of texels with bounding cones.
struct Source {
    n: usize,
    dirs: Vec<Vec3>,
    /// The directions' components apart, for tests four texels at a time.
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    solid_angles: Vec<f32>,
    values: Vec<Vec4>,
    /// Block edge in texels; blocks per face edge.
    block: usize,
    per_edge: usize,
    /// Per face, its blocks four at a time: axes (x, y, z) and the cosine below which a
    /// block holds no texel within the level's largest reach (the lobe's plus a tile's
    /// radius) of a tile's axis; padding is never reached.
    cones: Vec<Vec<[Vec4; 4]>>,
    /// The cosine to a face's normal below which a tile reaches none of the face.
    face_limit: f32,
}

impl Source {
    fn new(src: &CubeSampler, level: usize, max_reach: f32) -> Source {
        let n = src.level_size(level);
        let inv = 1.0 / n as f32;
        let angles = solid_angle_table(n);
        // Every texel's direction (and its components apart), solid angle and value, row by
        // row in parallel straight into place.
        let count = 6 * n * n;
        let mut dirs = vec![Vec3::ZERO; count];
        let (mut xs, mut ys, mut zs) = (vec![0.0; count], vec![0.0; count], vec![0.0; count]);
        let mut solid_angles = vec![0.0; count];
        let mut values = vec![Vec4::ZERO; count];
        let w = n.max(1);
        dirs.par_chunks_mut(w)
            .zip(xs.par_chunks_mut(w))
            .zip(ys.par_chunks_mut(w))
            .zip(zs.par_chunks_mut(w))
            .zip(solid_angles.par_chunks_mut(w))
            .zip(values.par_chunks_mut(w))
            .enumerate()
            .for_each(|(fy, (((((d, x), y), z), sa), v))| {
                let (face, row) = (fy / n, fy % n);
                for (i, d) in d.iter_mut().enumerate() {
                    *d = texel_dir(face, i, row, inv);
                    (x[i], y[i], z[i]) = (d.x, d.y, d.z);
                }
                sa.copy_from_slice(&angles[row * n..(row + 1) * n]);
                v.copy_from_slice(src.row(level, face, row));
            });
        // About 16 blocks per face edge: few enough to test them all per tile.
        let block = n.div_ceil(16).max(1);
        let per_edge = n.div_ceil(block);
        let cones: Vec<(Vec3, f32)> = (0..6 * per_edge * per_edge)
            .into_par_iter()
            .map(|b| {
                let (face, by, bx) = (
                    b / (per_edge * per_edge),
                    (b / per_edge) % per_edge,
                    b % per_edge,
                );
                let texels = || {
                    (by * block..((by + 1) * block).min(n)).flat_map(move |y| {
                        (bx * block..((bx + 1) * block).min(n)).map(move |x| (face * n + y) * n + x)
                    })
                };
                let axis = texels().map(|i| dirs[i]).sum::<Vec3>().normalize();
                let radius = texels()
                    .map(|i| axis.dot(dirs[i]).clamp(-1.0, 1.0).acos())
                    .fold(0.0f32, f32::max);
                let limit = max_reach + radius + 1e-4;
                (axis, if limit < PI { limit.cos() } else { -2.0 })
            })
            .collect();
        let cones = cones
            .chunks(per_edge * per_edge)
            .map(|face| {
                face.chunks(4)
                    .map(|c| {
                        let at = |l: usize| c.get(l).copied().unwrap_or((Vec3::ZERO, 2.0));
                        let lanes = |f: &dyn Fn((Vec3, f32)) -> f32| {
                            Vec4::new(f(at(0)), f(at(1)), f(at(2)), f(at(3)))
                        };
                        [
                            lanes(&|c| c.0.x),
                            lanes(&|c| c.0.y),
                            lanes(&|c| c.0.z),
                            lanes(&|c| c.1),
                        ]
                    })
                    .collect()
            })
            .collect();
        // Every direction of a face is within acos(1 / sqrt(3)) of its normal.
        let face_reach = (1.0f32 / 3f32.sqrt()).acos() + max_reach + 1e-3;
        let face_limit = if face_reach < PI {
            face_reach.cos()
        } else {
            -2.0
        };
        Source {
            n,
            xs,
            ys,
            zs,
            dirs,
            solid_angles,
            values,
            block,
            per_edge,
            cones,
            face_limit,
        }
    }

    /// Appends every texel whose centre lies within `reach` (at most the level's largest) of
    /// `axis` to `out`.
    fn gather(&self, axis: Vec3, reach: f32, out: &mut Candidates) {
        let cos_reach = reach.cos();
        let (n, block, per_edge) = (self.n, self.block, self.per_edge);
        let (ax, ay, az) = (
            Vec4::splat(axis.x),
            Vec4::splat(axis.y),
            Vec4::splat(axis.z),
        );
        for (face, quads) in self.cones.iter().enumerate() {
            if axis.dot(crate::cube::face_dir(face, 0.5, 0.5)) < self.face_limit {
                continue;
            }
            for (j, [x, y, z, limit]) in quads.iter().enumerate() {
                let mut hit = (ax * *x + ay * *y + az * *z).cmpge(*limit).bitmask();
                while hit != 0 {
                    let b = 4 * j + hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    let (by, bx) = (b / per_edge, b % per_edge);
                    let (x0, x1) = (bx * block, ((bx + 1) * block).min(n));
                    for y in by * block..((by + 1) * block).min(n) {
                        let row = (face * n + y) * n;
                        // Four texels of the row at a time, the tail one by one.
                        let mut x = x0;
                        while x + 4 <= x1 {
                            let i = row + x;
                            let lanes = |a: &[f32]| Vec4::from_slice(&a[i..i + 4]);
                            let c =
                                ax * lanes(&self.xs) + ay * lanes(&self.ys) + az * lanes(&self.zs);
                            let mut m = c.cmpge(Vec4::splat(cos_reach)).bitmask();
                            while m != 0 {
                                let k = i + m.trailing_zeros() as usize;
                                m &= m - 1;
                                out.push(self.dirs[k], self.solid_angles[k], self.values[k]);
                            }
                            x += 4;
                        }
                        for i in row + x..row + x1 {
                            let c = axis.x * self.xs[i] + axis.y * self.ys[i] + axis.z * self.zs[i];
                            if c >= cos_reach {
                                out.push(self.dirs[i], self.solid_angles[i], self.values[i]);
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Eight candidate texels in lanes: direction, solid angle, value.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Oct {
    x: [f32; LANES],
    y: [f32; LANES],
    z: [f32; LANES],
    sa: [f32; LANES],
    r: [f32; LANES],
    g: [f32; LANES],
    b: [f32; LANES],
    a: [f32; LANES],
}

/// The texels a tile gathered, eight to an oct (padding has no solid angle).
#[derive(Default)]
struct Candidates {
    octs: Vec<Oct>,
    len: usize,
}

impl Candidates {
    fn clear(&mut self) {
        self.octs.clear();
        self.len = 0;
    }

    fn push(&mut self, d: Vec3, sa: f32, v: Vec4) {
        let l = self.len % LANES;
        if l == 0 {
            // Padding points along the first member (a finite weight) with no solid angle.
            let zero = [0.0; LANES];
            self.octs.push(Oct {
                x: [d.x; LANES],
                y: [d.y; LANES],
                z: [d.z; LANES],
                sa: zero,
                r: zero,
                g: zero,
                b: zero,
                a: zero,
            });
        }
        let o = self.octs.last_mut().expect("an oct");
        (o.x[l], o.y[l], o.z[l], o.sa[l]) = (d.x, d.y, d.z, sa);
        (o.r[l], o.g[l], o.b[l], o.a[l]) = (v.x, v.y, v.z, v.w);
        self.len += 1;
    }

    /// The weighted mean of the candidates around unit `n`.
    #[inline(always)]
    fn mean(&self, window: &Window, n: Vec3) -> Vec4 {
        let cut = window.u_cut;
        match window.shape {
            Shape::Exp2 { q } => self.mean_with(n, cut, |u| exp2_weight(&q, u)),
            Shape::Ggx { a2, h } => self.mean_with(n, cut, |u| ggx_weight(a2, h, u)),
        }
    }

    /// The mean with `weight` (over the peak, a function of 1 - cos) for u up to `cut`: each
    /// lane summed in order, the lanes added in a fixed order, so every build and thread
    /// count gives the same bits. The lane loop is written lane by lane for the compiler to
    /// turn into one eight-wide instruction per step (two four-wide ones without AVX).
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // one index into nine arrays, for the vectoriser
    fn mean_with(&self, n: Vec3, cut: f32, weight: impl Fn(f32) -> f32) -> Vec4 {
        let mut acc = [[0.0f32; LANES]; 5];
        for o in &self.octs {
            for l in 0..LANES {
                // 1 - cos from the difference: |n - d|^2 / 2, precise for small angles.
                let (dx, dy, dz) = (n.x - o.x[l], n.y - o.y[l], n.z - o.z[l]);
                let u = dx.mul_add(dx, dy.mul_add(dy, dz * dz)) * 0.5;
                let w = weight(u);
                let w = if u <= cut { w } else { 0.0 } * o.sa[l];
                acc[0][l] = w.mul_add(o.r[l], acc[0][l]);
                acc[1][l] = w.mul_add(o.g[l], acc[1][l]);
                acc[2][l] = w.mul_add(o.b[l], acc[2][l]);
                acc[3][l] = w.mul_add(o.a[l], acc[3][l]);
                acc[4][l] += w;
            }
        }
        let total =
            |v: &[f32; LANES]| ((v[0] + v[4]) + (v[2] + v[6])) + ((v[1] + v[5]) + (v[3] + v[7]));
        let wsum = total(&acc[4]);
        if wsum > 0.0 {
            Vec4::new(
                total(&acc[0]),
                total(&acc[1]),
                total(&acc[2]),
                total(&acc[3]),
            ) / wsum
        } else {
            Vec4::ZERO
        }
    }
}

/// [`Shape::Exp2`]'s weight at `u`.
#[inline(always)]
fn exp2_weight(q: &[f32; MAX_DEGREE + 1], u: f32) -> f32 {
    let mut p = q[MAX_DEGREE];
    for &c in q[..MAX_DEGREE].iter().rev() {
        p = p.mul_add(u, c);
    }
    exp2_small(u * p)
}

/// [`Shape::Ggx`]'s weight at `u`.
#[inline(always)]
fn ggx_weight(a2: f32, h: f32, u: f32) -> f32 {
    let r = a2 / h.mul_add(u, a2);
    (1.0 - u) * (r * r)
}

/// 2^x for -126 < x <= 0 (a log weight): 2^round(x) from the exponent bits, times a degree-5
/// polynomial for 2^f on |f| <= 1/2 (fitted for relative error: 7.5e-8, 2.3e-7 in f32).
/// Rounding by adding and taking away 1.5 2^23 keeps it to additions, so it vectorises
/// without SSE4.1's round.
#[inline(always)]
fn exp2_small(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0;
    let shifted = x + MAGIC;
    let k = shifted - MAGIC;
    let f = x - k;
    // Highest power first.
    const C: [f32; 6] = [
        1.327_647_1e-3,
        9.675_541e-3,
        5.550_713e-2,
        0.240_221_2,
        0.693_146_94,
        1.000_000_1,
    ];
    let mut p = C[0];
    for &c in &C[1..] {
        p = p.mul_add(f, c);
    }
    // The integer k sits in the low bits of `shifted`; 2^k's bits are (k + 127) << 23.
    let k_bits = shifted.to_bits().wrapping_sub(MAGIC.to_bits());
    p * f32::from_bits(k_bits.wrapping_add(127) << 23)
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
        for y in y0..y1 {
            for x in x0..x1 {
                let n = centre(face, x, y);
                band[(y - y0) * size + x] = found.mean(window, n) + bright.at(n).extend(0.0);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every lobe a window sums (cosine powers from the widest allowed up, Gaussians, GGX
    /// cores), its f32 weights against the f64 lobe over the reach: within 1e-6 relative.
    #[test]
    fn weights_follow_the_lobe() {
        let mut lobes: Vec<(Lobe, f64)> = Vec::new();
        for p in [
            53.0f32, 64.0, 100.0, 152.0, 362.0, 861.0, 2048.0, 8192.0, 1e5, 1e6,
        ] {
            let l = Lobe::CosinePower { power: p };
            lobes.push((l, EPS.powf(1.0 / p as f64).acos()));
        }
        for s in [0.0005f32, 0.001, 0.01, 0.05, 0.1, 0.13] {
            let reach = s as f64 * (2.0 * (1.0 / EPS).ln()).sqrt();
            lobes.push((Lobe::Gaussian { sigma: s }, reach));
        }
        for a in [0.002f32, 0.01, 0.05, 0.06] {
            lobes.push((Lobe::Ggx { alpha: a }, 4.0 * a as f64));
        }
        for (lobe, reach) in lobes {
            assert!(reach < MAX_REACH as f64, "{lobe:?}");
            let w = Window::build(lobe, 0.01, reach, 256, 9);
            let peak = weight_f64(lobe, 1.0);
            let mut worst = 0.0f64;
            for i in 0..=10_000 {
                let u = w.u_cut * i as f32 / 10_000.0;
                let got = match w.shape {
                    Shape::Exp2 { q } => exp2_weight(&q, u),
                    Shape::Ggx { a2, h } => ggx_weight(a2, h, u),
                } as f64;
                let want = weight_f64(lobe, 1.0 - u as f64) / peak;
                worst = worst.max((got / want - 1.0).abs());
            }
            assert!(worst < 1e-6, "{lobe:?}: relative error {worst:e}");
        }
    }

    /// 2^x against f64 over the log weights' range, integers and halves included.
    #[test]
    fn exp2_small_is_close() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let x = -12.0 * i as f32 / 200_000.0;
            let got = exp2_small(x) as f64;
            worst = worst.max((got / (x as f64).exp2() - 1.0).abs());
        }
        assert!(worst < 3e-7, "relative error {worst:e}");
    }
}
