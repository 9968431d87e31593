//! The brute-force truth, written apart from the tool: its own face table (checked once against
//! the crate's), exact texel solid angles from the corners' arctangents, the lobes' formulas in
//! f64 and their integrals by their own quadrature. Nothing from `cubeforge::internals::filter`.
//!
//! The model: each base texel is light of power value x solid angle at its centre direction;
//! a lobe spreads it over the sphere; an output texel holds the lobe-weighted light over its
//! patch divided by the lobe-weighted solid angle over it (so a constant stays exactly
//! constant; where the lobe is wider than a texel, that total is the lobe's integral and the
//! flux is exact), the patch summed on k x k sub-patches, each at its centre with its exact
//! solid angle. k is chosen so a sub-patch is at most a quarter
//! of the lobe's width; base texels far from the lobe's peak (its axis, or Charlie's ring),
//! where the lobe changes slowly over the patch, are summed on 2 x 2 and then 1 sub-patch
//! (`reference_is_the_crates_geometry_and_converged` doubles every tier and measures what
//! moves).

use rayon::prelude::*;
use std::f64::consts::PI;

/// Six faces of `n` x `n` RGB texels, face by face, row by row.
#[derive(Clone)]
pub struct Cube {
    pub n: usize,
    pub texels: Vec<[f64; 3]>,
}

/// The OpenGL cube-map face table (+X, -X, +Y, -Y, +Z, -Z), (a, b) in [-1, 1] across and down.
pub fn face_point(face: usize, a: f64, b: f64) -> [f64; 3] {
    match face {
        0 => [1.0, -b, -a],
        1 => [-1.0, -b, a],
        2 => [a, 1.0, b],
        3 => [a, -1.0, -b],
        4 => [a, -b, 1.0],
        _ => [-a, -b, -1.0],
    }
}

fn unit(p: [f64; 3]) -> [f64; 3] {
    let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
    [p[0] / l, p[1] / l, p[2] / l]
}

pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Solid angle of the face rectangle [a0, a1] x [b0, b1] (face coordinates in [-1, 1]).
pub fn rect_solid_angle(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    let f = |a: f64, b: f64| (a * b).atan2((a * a + b * b + 1.0).sqrt());
    f(a1, b1) - f(a0, b1) - f(a1, b0) + f(a0, b0)
}

/// A texel's centre direction and solid angle.
pub fn texel(n: usize, face: usize, x: usize, y: usize) -> ([f64; 3], f64) {
    let h = 2.0 / n as f64;
    let (a0, b0) = (-1.0 + x as f64 * h, -1.0 + y as f64 * h);
    (
        unit(face_point(face, a0 + 0.5 * h, b0 + 0.5 * h)),
        rect_solid_angle(a0, a0 + h, b0, b0 + h),
    )
}

/// A texel split into k x k sub-patches: centre directions and solid angles.
fn sub_patches(n: usize, face: usize, x: usize, y: usize, k: usize) -> Vec<([f64; 3], f64)> {
    let h = 2.0 / n as f64;
    let s = h / k as f64;
    let (a0, b0) = (-1.0 + x as f64 * h, -1.0 + y as f64 * h);
    let mut out = Vec::with_capacity(k * k);
    for j in 0..k {
        for i in 0..k {
            let (a, b) = (a0 + i as f64 * s, b0 + j as f64 * s);
            out.push((
                unit(face_point(face, a + 0.5 * s, b + 0.5 * s)),
                rect_solid_angle(a, a + s, b, b + s),
            ));
        }
    }
    out
}

/// The lobes, as functions of the cosine c between the filtered direction and the light's.
#[derive(Clone, Copy, Debug)]
pub enum Lobe {
    /// max(c, 0)^p (cmft's Phong lobes; p = 1 is the irradiance's clamped cosine).
    Cosine(f64),
    /// exp(-angle^2 / (2 sigma^2)).
    Gaussian(f64),
    /// Split-sum GGX with n = v = r: D(h) (n.l), h halfway, n.h = sqrt((1 + c) / 2); alpha.
    Ggx(f64),
    /// Charlie sheen, D(h) = (2 + 1/alpha) sin(h)^(1/alpha) / (2 pi), times n.l; alpha.
    Charlie(f64),
}

impl Lobe {
    pub fn weight(self, c: f64) -> f64 {
        match self {
            Lobe::Cosine(p) => {
                if c > 0.0 {
                    c.powf(p)
                } else {
                    0.0
                }
            }
            Lobe::Gaussian(s) => {
                let t = c.clamp(-1.0, 1.0).acos();
                (-t * t / (2.0 * s * s)).exp()
            }
            Lobe::Ggx(a) => {
                if c <= 0.0 {
                    return 0.0;
                }
                let nh2 = (1.0 + c) * 0.5;
                let a2 = a * a;
                let d = nh2 * (a2 - 1.0) + 1.0;
                a2 / (PI * d * d) * c
            }
            Lobe::Charlie(a) => {
                if c <= 0.0 {
                    return 0.0;
                }
                let sin2 = ((1.0 - c) * 0.5).max(0.0);
                (2.0 + 1.0 / a) * sin2.powf(0.5 / a) / (2.0 * PI) * c
            }
        }
    }

    /// Angle (radians) over which the weight changes by about e: what a sub-patch must resolve.
    fn width(self) -> f64 {
        match self {
            Lobe::Cosine(p) => (1.0 / p).sqrt(),
            Lobe::Gaussian(s) => s,
            Lobe::Ggx(a) => 1.3 * a,
            Lobe::Charlie(a) => 2.0 * a / (2.0 * a + 1.0),
        }
    }

    /// The angle (radians) at which the weight peaks: 0 but for Charlie's ring, where
    /// ((1 - c) / 2)^(1 / (2 alpha)) c is largest, at c = 2 alpha / (2 alpha + 1).
    fn peak_angle(self) -> f64 {
        match self {
            Lobe::Charlie(a) => (2.0 * a / (2.0 * a + 1.0)).acos(),
            _ => 0.0,
        }
    }

    /// The weight's integral over the sphere: 2 pi int w(cos t) sin t dt, midpoint rule in f64
    /// on steps a fortieth of the lobe's width.
    pub fn integral(self) -> f64 {
        let steps = ((PI / self.width()) * 40.0).max(20_000.0) as usize;
        let dt = PI / steps as f64;
        (0..steps)
            .map(|i| {
                let t = (i as f64 + 0.5) * dt;
                self.weight(t.cos()) * t.sin()
            })
            .sum::<f64>()
            * dt
            * 2.0
            * PI
    }

    /// The angle beyond which the weight stays under 1e-12 of its peak (pi: everywhere).
    fn reach(self) -> f64 {
        let steps = 20_000;
        let at = |i: usize| PI * i as f64 / steps as f64;
        let peak = (0..=steps)
            .map(|i| self.weight(at(i).cos()))
            .fold(0.0, f64::max);
        (0..=steps)
            .rev()
            .find(|&i| self.weight(at(i).cos()) >= 1e-12 * peak)
            .map_or(PI, |i| (at(i) + PI / steps as f64).min(PI))
    }
}

/// A lobe's weight as the reference evaluates it: the formula, but Charlie's (a power per
/// call, its ring on most of a hemisphere: 10 s of the module) by linear interpolation in
/// 2^16 steps of c over [0, 1], built from the formula in f64: off by under 1e-8 of its
/// peak on its ring; where ((1 - c) / 2)^(1 / (2 alpha)) has no slope, at c = 1, over
/// 1e-4 steradian.
struct Weigher {
    lobe: Lobe,
    table: Option<Vec<f64>>,
}

const CHARLIE_STEPS: usize = 1 << 16;

impl Weigher {
    fn new(lobe: Lobe) -> Weigher {
        let table = matches!(lobe, Lobe::Charlie(_)).then(|| {
            (0..=CHARLIE_STEPS)
                .map(|i| lobe.weight(i as f64 / CHARLIE_STEPS as f64))
                .collect()
        });
        Weigher { lobe, table }
    }

    #[inline]
    fn at(&self, c: f64) -> f64 {
        match &self.table {
            None => self.lobe.weight(c),
            Some(_) if c <= 0.0 => 0.0,
            Some(t) => {
                let x = c.min(1.0) * CHARLIE_STEPS as f64;
                let i = (x as usize).min(CHARLIE_STEPS - 1);
                t[i] + (x - i as f64) * (t[i + 1] - t[i])
            }
        }
    }
}

/// Base texels' directions, solid angles and values, in arrays, and blocks of them (8 x 8
/// blocks per face) with bounding cones, so an output texel skips the blocks beyond its
/// lobe's reach without testing their texels (what the per-texel test would skip anyway).
struct Base {
    dirs: Vec<[f64; 3]>,
    angles: Vec<f64>,
    values: Vec<[f64; 3]>,
    /// Axis, angular radius and texel indices of each block.
    blocks: Vec<([f64; 3], f64, Vec<usize>)>,
}

fn base_of(cube: &Cube) -> Base {
    let n = cube.n;
    let (mut dirs, mut angles) = (Vec::new(), Vec::new());
    for face in 0..6 {
        for y in 0..n {
            for x in 0..n {
                let (d, sa) = texel(n, face, x, y);
                dirs.push(d);
                angles.push(sa);
            }
        }
    }
    let edge = n.div_ceil(8).max(1);
    let mut blocks = Vec::new();
    for face in 0..6 {
        for by in (0..n).step_by(edge) {
            for bx in (0..n).step_by(edge) {
                let members: Vec<usize> = (by..(by + edge).min(n))
                    .flat_map(|y| (bx..(bx + edge).min(n)).map(move |x| (face * n + y) * n + x))
                    .collect();
                let sum = members.iter().fold([0.0; 3], |a, &i| {
                    [a[0] + dirs[i][0], a[1] + dirs[i][1], a[2] + dirs[i][2]]
                });
                let axis = unit(sum);
                let radius = members
                    .iter()
                    .map(|&i| dot(axis, dirs[i]).clamp(-1.0, 1.0).acos())
                    .fold(0.0, f64::max);
                blocks.push((axis, radius + 1e-9, members));
            }
        }
    }
    Base {
        dirs,
        angles,
        values: cube.texels.clone(),
        blocks,
    }
}

/// Sub-patches per texel edge for a lobe of `width` radians on texels of `size` faces, times
/// `refine` (1 for the reference, 2 to check that it converged).
fn subdivisions(width: f64, size: usize, refine: usize) -> usize {
    let h = PI / 2.0 / size as f64;
    ((4.0 * h / width).ceil() as usize).clamp(1, 24) * refine
}

/// The level of face edge `size`: each texel the mean over its patch of the base convolved
/// with `lobe`. Sub-patches in three tiers by the angle between a base texel and the lobe's
/// peak (its axis; Charlie's ring): k x k near it, 2 x 2 further, then the centre; `refine`
/// multiplies all three, so doubling it shows every tier's convergence.
pub fn convolve(base: &Cube, lobe: Lobe, size: usize, refine: usize) -> Cube {
    let b = base_of(base);
    let weigher = Weigher::new(lobe);
    let k = subdivisions(lobe.width(), size, refine);
    let h = PI / 2.0 / size as f64;
    let near = (4.0 * lobe.width()).max(3.0 * h);
    let mid = (4.0 * near).min(PI);
    let peak = lobe.peak_angle();
    let reach = (lobe.reach() + 1.5 * h).min(PI);
    let (cos_near, cos_mid, cos_reach) = (near.min(PI).cos(), mid.cos(), reach.cos());
    let texels = (0..6 * size * size)
        .into_par_iter()
        .map(|i| {
            let (face, y, x) = (i / (size * size), (i / size) % size, i % size);
            let (centre, omega) = texel(size, face, x, y);
            let fine = sub_patches(size, face, x, y, k);
            let coarse = sub_patches(size, face, x, y, k.min(2 * refine));
            let far = sub_patches(size, face, x, y, refine);
            let (mut acc, mut total) = ([0.0f64; 3], 0.0f64);
            for (axis, radius, members) in &b.blocks {
                if dot(centre, *axis).clamp(-1.0, 1.0).acos() - radius > reach {
                    continue;
                }
                for &j in members {
                    let (d, sa, v) = (b.dirs[j], b.angles[j], b.values[j]);
                    let c = dot(centre, d);
                    if c < cos_reach {
                        continue;
                    }
                    // The angle to the peak (cosines compared where it is the axis).
                    let (is_near, is_mid) = if peak == 0.0 {
                        (c >= cos_near, c >= cos_mid)
                    } else {
                        let off = (c.clamp(-1.0, 1.0).acos() - peak).abs();
                        (off <= near, off <= mid)
                    };
                    let patches = if is_near {
                        &fine
                    } else if is_mid {
                        &coarse
                    } else {
                        &far
                    };
                    let w: f64 = if patches.len() == 1 {
                        weigher.at(c) * omega
                    } else {
                        patches
                            .iter()
                            .map(|(r, o)| weigher.at(dot(*r, d)) * o)
                            .sum()
                    };
                    let w = w * sa;
                    total += w;
                    for ch in 0..3 {
                        acc[ch] += w * v[ch];
                    }
                }
            }
            acc.map(|a| a / total)
        })
        .collect();
    Cube { n: size, texels }
}

/// The box level of face edge `size`: each texel the solid-angle-weighted mean of the base
/// texels inside it.
pub fn box_level(base: &Cube, size: usize) -> Cube {
    let n = base.n;
    let r = n / size;
    let texels = (0..6 * size * size)
        .map(|i| {
            let (face, y, x) = (i / (size * size), (i / size) % size, i % size);
            let (mut acc, mut area) = ([0.0f64; 3], 0.0);
            for by in y * r..(y + 1) * r {
                for bx in x * r..(x + 1) * r {
                    let sa = texel(n, face, bx, by).1;
                    let v = base.texels[(face * n + by) * n + bx];
                    for ch in 0..3 {
                        acc[ch] += v[ch] * sa;
                    }
                    area += sa;
                }
            }
            acc.map(|a| a / area)
        })
        .collect();
    Cube { n: size, texels }
}

/// Largest weight `lobe` gives any direction of output texel (`size`, face, x, y) from any
/// direction within `radius` of `axis`: [`max_weight_over`] with the angles widened by it.
pub fn max_weight_over_cone(
    lobe: Lobe,
    size: usize,
    face: usize,
    x: usize,
    y: usize,
    axis: [f64; 3],
    radius: f64,
) -> f64 {
    max_weight_within(lobe, size, face, x, y, axis, radius)
}

/// Largest weight `lobe` gives any direction of output texel (`size`, face, x, y) from `d`: the
/// lobe over the angles the patch spans from `d`, on 64 steps (it may peak off the axis).
pub fn max_weight_over(
    lobe: Lobe,
    size: usize,
    face: usize,
    x: usize,
    y: usize,
    d: [f64; 3],
) -> f64 {
    max_weight_within(lobe, size, face, x, y, d, 0.0)
}

/// [`max_weight_over`] from any direction within `spread` of `d`.
fn max_weight_within(
    lobe: Lobe,
    size: usize,
    face: usize,
    x: usize,
    y: usize,
    d: [f64; 3],
    spread: f64,
) -> f64 {
    let (centre, _) = texel(size, face, x, y);
    // The patch lies within this angle of its centre (its corners are furthest).
    let h = 2.0 / size as f64;
    let (a0, b0) = (-1.0 + x as f64 * h, -1.0 + y as f64 * h);
    let radius = [(0.0, 0.0), (h, 0.0), (0.0, h), (h, h)]
        .iter()
        .map(|&(da, db)| {
            dot(centre, unit(face_point(face, a0 + da, b0 + db)))
                .clamp(-1.0, 1.0)
                .acos()
        })
        .fold(0.0, f64::max);
    let t = dot(centre, d).clamp(-1.0, 1.0).acos();
    let (lo, hi) = (
        (t - radius - spread).max(0.0),
        (t + radius + spread).min(PI),
    );
    (0..=64)
        .map(|i| lobe.weight((lo + (hi - lo) * i as f64 / 64.0).cos()))
        .fold(0.0, f64::max)
}
