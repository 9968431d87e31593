//! HDR peaks (a sun, a lamp) for the filters: the texels too bright to sample split off the
//! source, and their exact convolution with a lobe, patch by patch in vector lanes.

#![warn(missing_docs)]

use super::shape::Lobe;
use crate::cube::{solid_angle_table, texel_dir, CubeMap, Faces};
use glam::{Vec3, Vec4};
use std::f32::consts::PI;

#[cfg(target_arch = "x86_64")]
mod avx2;

/// Texels too bright to importance-sample without fireflies (an HDR sun), split off the
/// source: their excess over a threshold is convolved exactly, texel by texel.
#[derive(Clone, Debug, Default)]
pub struct Bright {
    /// Direction, solid angle and excess radiance of each bright texel.
    pub texels: Vec<(Vec3, f32, Vec4)>,
    /// The texels in patches (8 x 8 source texels of one face), each with a bounding cone, so
    /// an output texel skips whole patches beyond its lobe's reach.
    pub patches: Vec<Patch>,
}

/// Bright texels close together: indices into `Bright::texels` and the cone around them.
#[derive(Clone, Debug)]
pub struct Patch {
    /// Unit direction at the centre of the patch's cone.
    pub axis: Vec3,
    /// Angle from the axis to the furthest member.
    pub radius: f32,
    /// Indices into `Bright::texels`.
    pub members: Vec<usize>,
}

impl Bright {
    /// Groups the texels (found at `keys`: face and texel position) into patches.
    fn with_patches(texels: Vec<(Vec3, f32, Vec4)>, keys: &[(usize, usize, usize)]) -> Bright {
        let mut groups: std::collections::BTreeMap<(usize, usize, usize), Vec<usize>> =
            Default::default();
        for (i, &(face, x, y)) in keys.iter().enumerate() {
            groups.entry((face, x / 8, y / 8)).or_default().push(i);
        }
        let patches = groups
            .into_values()
            .map(|members| {
                let sum: Vec3 = members.iter().map(|&i| texels[i].0).sum();
                let axis = sum.normalize_or(texels[members[0]].0);
                let radius = members
                    .iter()
                    .map(|&i| axis.dot(texels[i].0).clamp(-1.0, 1.0).acos())
                    .fold(0.0f32, f32::max);
                Patch {
                    axis,
                    // A little margin for the rounding of the cosines.
                    radius: radius + 1e-4,
                    members,
                }
            })
            .collect();
        Bright { texels, patches }
    }
}

/// Most texels handled exactly; beyond that the threshold rises.
pub(crate) const MAX_BRIGHT: usize = 4096;

/// Splits `base` into a residual whose luminance is at most `ratio` times its mean (what the
/// sampled filters see) and the excess of the brighter texels.
pub(crate) fn split_bright(base: &CubeMap, ratio: f32) -> (CubeMap, Bright) {
    let (residual, bright) = split_bright_faces(&base.levels[0], ratio);
    (
        CubeMap {
            levels: vec![residual],
        },
        bright,
    )
}

/// [`split_bright`] for six faces. Rows in parallel, each row's sums in f64 and the rows'
/// added in order, so the threshold, and the result, do not depend on the thread count.
pub(crate) fn split_bright_faces(faces: &Faces, ratio: f32) -> (Faces, Bright) {
    use crate::image::luminance;
    use rayon::prelude::*;
    let n = faces[0].width;
    let angles = solid_angle_table(n);
    let row = |fy: usize| &faces[fy / n].pixels[(fy % n) * n..(fy % n + 1) * n];
    let sums: Vec<(f64, f64)> = (0..6 * n)
        .into_par_iter()
        .map(|fy| {
            let y = fy % n;
            let (mut total, mut area) = (0.0f64, 0.0f64);
            for (p, &sa) in row(fy).iter().zip(&angles[y * n..(y + 1) * n]) {
                total += luminance(*p) as f64 * sa as f64;
                area += sa as f64;
            }
            (total, area)
        })
        .collect();
    let (total, area) = sums
        .iter()
        .fold((0.0f64, 0.0f64), |(t, a), &(rt, ra)| (t + rt, a + ra));
    let mean = (total / area) as f32;
    let mut threshold = (ratio * mean).max(1e-6);
    let above = |t: f32| {
        (0..6 * n)
            .into_par_iter()
            .map(|fy| row(fy).iter().filter(|p| luminance(**p) > t).count())
            .sum::<usize>()
    };
    if above(threshold) > MAX_BRIGHT {
        // The (MAX_BRIGHT + 1)-th brightest: the same value whatever the selection's order.
        let mut lums: Vec<f32> = faces
            .iter()
            .flat_map(|f| f.pixels.iter().map(|p| luminance(*p)))
            .collect();
        lums.select_nth_unstable_by(MAX_BRIGHT, |a, b| b.total_cmp(a));
        threshold = lums[MAX_BRIGHT];
    }
    let inv = 1.0 / n as f32;
    // Copied row by row in the same parallel pass (a 512 cube is 25 MB: no serial clone).
    let mut residual: Faces = std::array::from_fn(|_| crate::image::Image::new(n, n));
    let mut rows: Vec<(usize, usize, &mut [Vec4])> = Vec::with_capacity(6 * n);
    for (face, img) in residual.iter_mut().enumerate() {
        for (y, r) in img.pixels.chunks_mut(n).enumerate() {
            rows.push((face, y, r));
        }
    }
    type Found = ((Vec3, f32, Vec4), (usize, usize, usize));
    let found: Vec<Vec<Found>> = rows
        .into_par_iter()
        .map(|(face, y, r)| {
            r.copy_from_slice(row(face * n + y));
            let mut out = Vec::new();
            for (x, p) in r.iter_mut().enumerate() {
                let l = luminance(*p);
                if l > threshold {
                    let kept = (*p * (threshold / l)).truncate().extend(p.w);
                    let excess = (*p - kept).truncate().extend(0.0);
                    let d = texel_dir(face, x, y, inv);
                    out.push(((d, angles[y * n + x], excess), (face, x, y)));
                    *p = kept;
                }
            }
            out
        })
        .collect();
    let (texels, keys): (Vec<_>, Vec<_>) = found.into_iter().flatten().unzip();
    (residual, Bright::with_patches(texels, &keys))
}

/// The bright texels prepared for one lobe: per patch the cosine to its axis beyond which it
/// cannot reach an output texel, and its members in lanes of four, each member's excess
/// radiance already times its solid angle and the lobe's normalisation.
pub(crate) struct BrightSum {
    lobe: Lobe,
    patches: Vec<(Vec3, f32, Vec<Quad>)>,
    /// A cone around every patch's, widened by the lobe's reach: an output texel outside it
    /// reaches no patch (most of a narrow lobe's texels: one test instead of one per patch).
    all: (Vec3, f32),
}

/// Four members: directions and weighted excess radiance (zero in padding lanes).
#[derive(Clone, Copy)]
struct Quad {
    x: Vec4,
    y: Vec4,
    z: Vec4,
    r: Vec4,
    g: Vec4,
    b: Vec4,
}

impl BrightSum {
    pub(crate) fn new(bright: &Bright, lobe: Lobe) -> BrightSum {
        if bright.texels.is_empty() {
            return BrightSum {
                lobe,
                patches: Vec::new(),
                all: (Vec3::Z, -2.0),
            };
        }
        let norm = (1.0 / lobe.integral()) as f32;
        // A patch can reach an output texel only within its radius plus the lobe's cutoff.
        let reach = lobe.cutoff_cos().clamp(-1.0, 1.0).acos();
        let patches = bright
            .patches
            .iter()
            .map(|p| {
                let a = p.radius + reach;
                let limit = if a >= PI { -2.0 } else { a.cos() };
                let quads = p
                    .members
                    .chunks(4)
                    .map(|chunk| {
                        // Padding repeats the first member's direction (a finite weight) with
                        // no radiance.
                        let at = |l: usize| chunk.get(l).copied();
                        let dir = |l: usize| bright.texels[at(l).unwrap_or(chunk[0])].0;
                        let excess = |l: usize| {
                            at(l).map_or(Vec4::ZERO, |i| {
                                let (_, sa, e) = bright.texels[i];
                                e * (sa * norm)
                            })
                        };
                        let lanes = |f: &dyn Fn(usize) -> f32| Vec4::new(f(0), f(1), f(2), f(3));
                        Quad {
                            x: lanes(&|l| dir(l).x),
                            y: lanes(&|l| dir(l).y),
                            z: lanes(&|l| dir(l).z),
                            r: lanes(&|l| excess(l).x),
                            g: lanes(&|l| excess(l).y),
                            b: lanes(&|l| excess(l).z),
                        }
                    })
                    .collect();
                (p.axis, limit, quads)
            })
            .collect();
        // The patches' cone: around the mean of their axes, out to the furthest patch's edge,
        // then the lobe's reach (with a margin for the rounding of the cosines).
        let axis = bright
            .patches
            .iter()
            .map(|p| p.axis)
            .sum::<Vec3>()
            .normalize_or(Vec3::Z);
        let radius = bright
            .patches
            .iter()
            .map(|p| axis.dot(p.axis).clamp(-1.0, 1.0).acos() + p.radius)
            .fold(0.0f32, f32::max);
        let a = radius + reach + 1e-4;
        let all = (axis, if a >= PI { -2.0 } else { a.cos() });
        BrightSum { lobe, patches, all }
    }

    /// The lobe's weight at four cosines; 0 where it is not positive (NaN included).
    #[inline]
    fn weights(&self, c: Vec4) -> Vec4 {
        let w = match self.lobe {
            Lobe::Ggx { alpha } => {
                // ggx_d(n.h) * c with (n.h)^2 = (1 + c) / 2.
                let a2 = alpha * alpha;
                let nh2 = (c + 1.0) * 0.5;
                let d = nh2 * (a2 - 1.0) + 1.0;
                Vec4::splat(a2) / (d * d * PI) * c
            }
            lobe => Vec4::from_array(c.to_array().map(|c| lobe.weight(c))),
        };
        Vec4::select(w.cmpgt(Vec4::ZERO), w, Vec4::ZERO)
    }

    /// [`BrightSum::at`] of each of `ns` into `out` (as long): GGX lobes eight texels at a
    /// time in AVX lanes where the CPU has them (the same bits; a level's bright part cost
    /// as much as its sampled tail four lanes wide).
    pub(crate) fn at_many(&self, ns: &[Vec3], out: &mut [Vec3]) {
        #[cfg(target_arch = "x86_64")]
        if let Lobe::Ggx { alpha } = self.lobe {
            if crate::simd::avx2_available() {
                for (n, o) in ns.chunks(8).zip(out.chunks_mut(8)) {
                    if self.patches.is_empty() {
                        o.fill(Vec3::ZERO);
                    } else {
                        // SAFETY: the CPU has AVX and AVX2 (checked just above).
                        unsafe { avx2::ggx_at8(self, alpha, n, o) };
                    }
                }
                return;
            }
        }
        for (n, o) in ns.iter().zip(out) {
            *o = self.at(*n);
        }
    }

    /// The bright texels' part of the convolution at unit direction `n`: patches in order,
    /// each member's share summed in its lane, the lanes added in a fixed order.
    #[inline]
    pub(crate) fn at(&self, n: Vec3) -> Vec3 {
        if self.patches.is_empty() || n.dot(self.all.0) <= self.all.1 {
            return Vec3::ZERO;
        }
        let (nx, ny, nz) = (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
        let mut acc = [Vec4::ZERO; 3];
        for (axis, limit, quads) in &self.patches {
            if n.dot(*axis) <= *limit {
                continue;
            }
            for q in quads {
                let w = self.weights(nx * q.x + ny * q.y + nz * q.z);
                acc[0] += w * q.r;
                acc[1] += w * q.g;
                acc[2] += w * q.b;
            }
        }
        let total = |v: Vec4| (v.x + v.z) + (v.y + v.w);
        Vec3::new(total(acc[0]), total(acc[1]), total(acc[2]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Eight texels at a time give `at`'s bits for every texel: near a sun and its patches,
    /// far from it, at the edges of the patches' reach, in runs shorter than eight.
    #[test]
    fn at_many_matches_at_bit_for_bit() {
        let sun = Vec3::new(-0.3, 0.5, 0.8).normalize();
        let base = CubeMap::from_fn(48, |d| {
            let v = if d.dot(sun) > 0.99 {
                3e4 * (1.0 + d.x)
            } else {
                0.2 + 0.1 * d.y
            };
            Vec4::new(v, v * 0.5, v * 0.25, 1.0)
        });
        let (_, bright) = split_bright(&base, 64.0);
        assert!(bright.patches.len() > 1);
        let ns: Vec<Vec3> = (0..2000)
            .map(|i| {
                let (u, v) = (i as f32 * 0.618_034 % 1.0, i as f32 / 2000.0);
                let (z, phi) = (1.0 - 2.0 * v, std::f32::consts::TAU * u);
                let r = (1.0 - z * z).max(0.0).sqrt();
                Vec3::new(r * phi.cos(), r * phi.sin(), z)
            })
            .collect();
        for alpha in [0.01f32, 0.0278, 0.111, 0.25, 1.0] {
            let sum = BrightSum::new(&bright, Lobe::Ggx { alpha });
            for len in [8usize, 5, 1] {
                for chunk in ns.chunks(len) {
                    let mut got = vec![Vec3::NAN; chunk.len()];
                    sum.at_many(chunk, &mut got);
                    for (n, g) in chunk.iter().zip(&got) {
                        let want = sum.at(*n);
                        assert_eq!(
                            g.to_array().map(f32::to_bits),
                            want.to_array().map(f32::to_bits),
                            "alpha {alpha} at {n}"
                        );
                    }
                }
            }
        }
    }
}
