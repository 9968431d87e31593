//! Filtered importance sampling of rotationally symmetric lobes around each texel's direction:
//! one precomputed set of (local direction, weight, source lod) per level, rotated into every
//! texel's frame and looked up trilinearly in a box-mipmapped, seamless source.

#![warn(missing_docs)]

use super::bright::BrightSum;
pub use super::bright::{Bright, Patch};
use super::shape::ggx_d;
pub use super::shape::Lobe;
use crate::cube::{texel_dir, CubeMap, CubeSampler, Dirs, TapLevels, TapScratch, BATCH};
use crate::image::Image;
use glam::{Mat3, Vec3, Vec4};
use std::f32::consts::{PI, TAU};

/// The cosine c = n.l at which the Charlie lobe's CDF reaches `u`, and the lobe's density there
/// (per steradian). With y = 1 - c and k = 1 / (2 alpha) the lobe is y^k (1 - y), whose mass
/// within y is P(y) = (k + 2) y^(k+1) - (k + 1) y^(k+2) of the whole: bisected for P(y) = u.
fn charlie_sample(u: f64, alpha: f32) -> (f32, f32) {
    let k = 0.5 / alpha.max(1e-4) as f64;
    let mass = |y: f64| y.powf(k + 1.0) * ((k + 2.0) - (k + 1.0) * y);
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if mass(mid) < u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let y = 0.5 * (lo + hi);
    let c = 1.0 - y;
    let pdf = (k + 1.0) * (k + 2.0) * y.powf(k) * c / std::f64::consts::TAU;
    (c as f32, pdf as f32)
}

/// The i-th of n points of the Hammersley set: deterministic, low discrepancy.
#[inline]
pub(crate) fn hammersley(i: u32, n: u32) -> (f32, f32) {
    (
        (i as f32 + 0.5) / n as f32,
        (i.reverse_bits() as f64 / 4_294_967_296.0) as f32,
    )
}

/// One sample of a kernel: direction in the lobe's frame (+Z is the axis), weight, source lod.
#[derive(Clone, Copy, Debug)]
pub struct Tap {
    /// Sample direction in the lobe's frame (unit length, +Z the axis).
    pub dir: Vec3,
    /// Weight in the texel's mean (the lobe value over the sampling density's).
    pub weight: f32,
    /// Source mip level (fractional) whose texels cover the sample's solid angle.
    pub lod: f32,
    /// The lod split for the lookup: level below and the fraction towards the next.
    pub level: usize,
    /// Fraction from `level` towards `level + 1`, in [0, 1).
    pub frac: f32,
}

/// The precomputed samples of one lobe.
#[derive(Clone, Debug)]
pub struct Kernel {
    /// Samples in a fixed (Hammersley) order; those with no weight are left out.
    pub taps: Vec<Tap>,
}

impl Kernel {
    /// `count` importance samples of `lobe`, each looked up at the source level whose texels
    /// cover the solid angle the sample stands for (Krivanek and Colbert's filtered importance
    /// sampling), on a source whose level 0 has faces of edge `src_size`.
    pub fn new(lobe: Lobe, count: u32, src_size: usize) -> Kernel {
        Kernel::sampled(lobe, count, src_size, 0.0)
    }

    /// `count` samples of a GGX lobe's tail: the directions more than `reach` radians from
    /// its axis, the part `filter::hybrid` leaves to sampling. None for
    /// other lobes.
    pub(crate) fn ggx_tail(lobe: Lobe, count: u32, src_size: usize, reach: f32) -> Option<Kernel> {
        let Lobe::Ggx { alpha } = lobe else {
            return None;
        };
        // The reflected direction's angle is twice the half vector's: the fraction of the
        // half vectors within half the reach, from the sampling formula below inverted.
        let a2 = alpha as f64 * alpha as f64;
        let c2 = (reach as f64 * 0.5).cos().powi(2);
        let u0 = (1.0 - c2) / (1.0 + c2 * (a2 - 1.0));
        Some(Kernel::sampled(lobe, count, src_size, u0 as f32))
    }

    /// The samples of `new`, drawn from the part of the sampling distribution above `u0` (0:
    /// all of it); the density rises by 1 / (1 - u0) in the part drawn from.
    fn sampled(lobe: Lobe, count: u32, src_size: usize, u0: f32) -> Kernel {
        let texel_solid_angle = 4.0 * PI / (6.0 * (src_size * src_size) as f32);
        let mut taps = Vec::with_capacity(count as usize);
        for i in 0..count {
            let (u, v) = hammersley(i, count);
            let u = u0 + u * (1.0 - u0);
            let phi = TAU * v;
            // (cos theta of the sampled direction, weight, pdf in solid angle)
            let (cos_t, weight, pdf) = match lobe {
                Lobe::Ggx { alpha } => {
                    let a2 = alpha * alpha;
                    let cos_h = ((1.0 - u) / (1.0 + (a2 - 1.0) * u)).sqrt();
                    // l = reflect(-n, h) with n = v: angle doubles.
                    let cos_l = 2.0 * cos_h * cos_h - 1.0;
                    if cos_l <= 0.0 {
                        continue;
                    }
                    // pdf(l) = D(h) (n.h) / (4 (v.h)) = D / 4 with n = v.
                    (cos_l, cos_l, ggx_d(cos_h, alpha) * 0.25)
                }
                Lobe::Charlie { alpha } => {
                    // n.l drawn from the lobe itself, D(h) n.l = ((1 - c) / 2)^k c with
                    // k = 1 / (2 alpha): every sample counts. (Drawing h from D(h) n.h and
                    // reflecting, as the Khronos sampler does, converges to the same
                    // convolution but puts almost every h near the horizon, its reflection
                    // below it: 2^-(1 + k) of them land above, 1 in 10^4 at alpha 0.04.)
                    let (c, pdf) = charlie_sample(u as f64, alpha);
                    if c <= 0.0 {
                        continue;
                    }
                    (c, 1.0, pdf)
                }
                Lobe::CosinePower { power } => {
                    let c = (1.0 - u).powf(1.0 / (power + 1.0));
                    (c, 1.0, (power + 1.0) / TAU * c.powf(power))
                }
                Lobe::Gaussian { sigma } => {
                    // Rayleigh-distributed angle; the sphere's sin(theta) / theta corrects it.
                    let theta = sigma * (-2.0 * (1.0 - u).ln()).sqrt();
                    if theta >= PI {
                        continue;
                    }
                    let pdf = (-theta * theta / (2.0 * sigma * sigma)).exp()
                        / (TAU * sigma * sigma)
                        * theta
                        / theta.sin().max(1e-12);
                    let w = if theta > 1e-6 {
                        theta.sin() / theta
                    } else {
                        1.0
                    };
                    (theta.cos(), w, pdf)
                }
            };
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let dir = Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t);
            let pdf = pdf / (1.0 - u0);
            let sample_solid_angle = 1.0 / (count as f32 * pdf.max(1e-20));
            let max_lod = (CubeMap::full_chain_len(src_size) - 1) as f32;
            let lod = (0.5 * (sample_solid_angle / texel_solid_angle).log2()).clamp(0.0, max_lod);
            taps.push(Tap {
                dir,
                weight,
                lod,
                level: lod as usize,
                frac: lod.fract(),
            });
        }
        Kernel { taps }
    }
}

/// An orthonormal frame around unit `n`, continuous except where n is near +-Y.
#[inline]
pub fn frame(n: Vec3) -> (Vec3, Vec3) {
    let up = if n.y.abs() < 0.999 { Vec3::Y } else { Vec3::X };
    let t = up.cross(n).normalize();
    (t, n.cross(t))
}

/// Filters one level: every texel of six `size` faces is the weighted mean of the kernel's
/// taps around its direction, plus the exact convolution of the bright texels with `lobe`.
/// Rows in parallel; sums in a fixed order (deterministic).
pub fn filter_level(
    src: &CubeSampler,
    kernel: &Kernel,
    size: usize,
    lobe: Lobe,
    bright: &Bright,
) -> [Image; 6] {
    let inv = 1.0 / size as f32;
    let wsum: f32 = kernel.taps.iter().map(|t| t.weight).sum();
    let bright = BrightSum::new(bright, lobe);
    // The kernel in batches of directions, turned into each texel's frame and looked up a
    // batch at a time (the face selection of a whole batch vectorises).
    let taps = &kernel.taps;
    let batches: Vec<(Dirs, TapLevels)> = taps
        .chunks(BATCH)
        .map(|chunk| {
            let mut d = Dirs::default();
            let mut l = TapLevels::default();
            for tap in chunk {
                d.push(tap.dir);
                l.push(src, tap.level, tap.frac);
            }
            (d, l)
        })
        .collect();
    let filter_texel = |n: Vec3, scratch: &mut Scratch| -> Vec4 {
        let (t, b) = frame(n);
        // The same arithmetic as t * x + b * y + n * z.
        let to_world = Mat3::from_cols(t, b, n);
        let mut acc = Vec4::ZERO;
        for ((batch, levels), start) in batches.iter().zip((0..).step_by(BATCH)) {
            let end = start + batch.len;
            scratch.dirs.transform_from(batch, &to_world);
            src.trilinear_taps(
                &scratch.dirs,
                levels,
                &mut scratch.taps,
                &mut scratch.values[..batch.len],
            );
            for (v, tap) in scratch.values.iter().zip(&taps[start..end]) {
                acc += *v * tap.weight;
            }
        }
        acc / wsum
    };
    std::array::from_fn(|face| {
        Image::from_rows(size, size, |y, row| {
            let mut scratch = Scratch {
                dirs: Dirs::default(),
                taps: TapScratch::new(),
                values: [Vec4::ZERO; BATCH],
            };
            // The bright part eight texels at a time (its lanes), added as before.
            let mut lit = [Vec3::ZERO; 8];
            for (x0, texels) in row.chunks_mut(8).enumerate() {
                let ns: [Vec3; 8] = std::array::from_fn(|i| texel_dir(face, x0 * 8 + i, y, inv));
                bright.at_many(&ns[..texels.len()], &mut lit[..texels.len()]);
                for ((texel, n), l) in texels.iter_mut().zip(ns).zip(lit) {
                    *texel = filter_texel(n, &mut scratch) + l.extend(0.0);
                }
            }
        })
    })
}

/// One row's scratch space: a batch of turned directions, the lookups' and their values.
struct Scratch {
    dirs: Dirs,
    taps: TapScratch,
    values: [Vec4; BATCH],
}

/// The source prepared for filtering: its box mips, seamless.
pub fn source_sampler(base: &CubeMap) -> CubeSampler {
    CubeSampler::with_box_mips(&base.levels[0], None)
}

#[cfg(test)]
mod tests {
    use super::super::bright::split_bright;
    use super::*;

    /// The cutoff holds for lobes that peak on the axis and for Charlie's ring alike: every
    /// weight beyond it is under 1e-10 of the peak, and it is no further out than it must be.
    #[test]
    fn cutoff_bounds_every_lobe() {
        for lobe in [
            Lobe::Ggx { alpha: 0.01 },
            Lobe::Ggx { alpha: 1.0 },
            Lobe::Charlie { alpha: 0.04 },
            Lobe::Charlie { alpha: 1.0 },
            Lobe::CosinePower { power: 1e6 },
            Lobe::Gaussian { sigma: 0.1 },
        ] {
            let cut = lobe.cutoff_cos();
            let peak = (0..=100_000)
                .map(|i| lobe.weight(-1.0 + 2.0 * i as f32 / 100_000.0))
                .fold(0.0f32, f32::max);
            for i in 0..10_000 {
                let c = -1.0 + (cut + 1.0) * i as f32 / 10_000.0;
                assert!(lobe.weight(c) < peak * 1e-10, "{lobe:?}: {c} beyond {cut}");
            }
            assert!(
                lobe.weight(cut + 1e-3) >= peak * 1e-10 || cut >= 0.999,
                "{lobe:?}: {cut}"
            );
        }
    }

    /// Charlie's sampled directions follow its weight: the kernel's mean of n.l matches the
    /// lobe's own, by quadrature.
    #[test]
    fn charlie_kernel_samples_its_lobe() {
        for alpha in [0.04f32, 0.25, 1.0] {
            let lobe = Lobe::Charlie { alpha };
            let k = Kernel::new(lobe, 4096, 64);
            let w: f64 = k.taps.iter().map(|t| t.weight as f64).sum();
            let mean = k
                .taps
                .iter()
                .map(|t| (t.weight * t.dir.z) as f64)
                .sum::<f64>()
                / w;
            let steps = 100_000;
            let (mut num, mut den) = (0.0f64, 0.0f64);
            for i in 0..steps {
                let t = (i as f64 + 0.5) / steps as f64 * std::f64::consts::PI;
                let wt = lobe.weight(t.cos() as f32) as f64 * t.sin();
                num += wt * t.cos();
                den += wt;
            }
            let want = num / den;
            assert!(
                (mean - want).abs() < 2e-3,
                "alpha {alpha}: {mean} vs {want}"
            );
        }
    }

    /// Skipping patches beyond a lobe's reach changes no output by more than 1e-6 of it.
    #[test]
    fn patch_culling_keeps_the_exact_convolution() {
        let sun = Vec3::new(-0.3, 0.5, 0.8).normalize();
        let lamp = Vec3::new(0.6, -0.2, -0.7).normalize();
        let base = CubeMap::from_fn(32, |d| {
            let v = if d.dot(sun) > 0.98 || d.dot(lamp) > 0.995 {
                1e5
            } else {
                0.2 + 0.1 * d.y
            };
            Vec4::new(v, v * 0.5, v, 1.0)
        });
        let (residual, bright) = split_bright(&base, 64.0);
        assert!(bright.patches.len() > 1, "the sun spans several patches");
        let all = Bright {
            texels: bright.texels.clone(),
            patches: vec![Patch {
                axis: Vec3::Z,
                radius: PI,
                members: (0..bright.texels.len()).collect(),
            }],
        };
        let src = source_sampler(&residual);
        for lobe in [
            Lobe::CosinePower { power: 2049.0 },
            Lobe::CosinePower { power: 40.0 },
            Lobe::Ggx { alpha: 0.05 },
            Lobe::Charlie { alpha: 0.09 },
        ] {
            let k = Kernel::new(lobe, 16, 32);
            let culled = filter_level(&src, &k, 32, lobe, &bright);
            let full = filter_level(&src, &k, 32, lobe, &all);
            for (a, b) in culled.iter().zip(&full) {
                for (p, q) in a.pixels.iter().zip(&b.pixels) {
                    let d = (*p - *q).abs().max_element();
                    assert!(d <= 1e-6 * q.max_element() + 1e-6, "{lobe:?}: {p} vs {q}");
                }
            }
        }
    }
}
