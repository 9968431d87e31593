//! The diffuse side: the irradiance map, by an exact sum over the source's texels (the
//! default) or from its 9 SH coefficients.
//!
//! The clamped cosine is the smoothest lobe there is, so the sum runs over a small copy of the
//! source (`IRRADIANCE_SOURCE_SIZE` faces) once its HDR peaks are split off: those are added
//! texel by texel at the base's own resolution, where they are, not where a reduced texel's
//! centre is. The sum itself is a dot product, a clamp and four multiply-adds per texel pair
//! in vector lanes, over arrays of directions, solid angles and radiance made once.

#![warn(missing_docs)]

use super::{bright, sh, BRIGHT_RATIO};
use crate::cube::{box_reduce_face, solid_angle_table, texel_dir, CubeMap, CubeSampler, Faces};
use crate::image::Image;
use glam::{Vec3, Vec4};
use serde::Serialize;
use std::borrow::Cow;

/// How the irradiance map is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum IrradianceMethod {
    /// Exact cosine-weighted sum over every texel of a 64-face copy of the source, its HDR
    /// peaks at full resolution: right next to an HDR sun, where 9 SH coefficients ring (the
    /// default).
    #[default]
    Brute,
    /// From the 9 SH coefficients: fast, smooth, up to ~10% off (and possibly negative)
    /// opposite a strong sun.
    Sh,
}

/// Face edge of the copy of the source (below the bright threshold) the brute-force sum runs
/// over: against the sum over every texel of a 128-face base, docs/prefilter.md gives the
/// error on the real panoramas (`tests/it/texel_truth/irradiance_source.rs` measures it).
pub(crate) const IRRADIANCE_SOURCE_SIZE: usize = 64;

/// The SH projection reads at most this face size (a box-reduced copy of larger bases).
const SH_SOURCE_SIZE: usize = 256;

/// The Lambertian irradiance map at face edge `size`, stored as (1/pi) times the
/// cosine-weighted integral of radiance (a constant environment c gives c), and the order-2
/// SH coefficients of the radiance.
pub fn irradiance(
    base: &CubeMap,
    size: usize,
    method: IrradianceMethod,
) -> (CubeMap, [[f64; 3]; 9]) {
    irradiance_with_progress(base, size, method, &|_| {})
}

/// [`irradiance`], calling `progress(1)` for each of the 6 x `size` output rows the brute
/// integral finishes (nothing for the SH method, which is instant).
pub fn irradiance_with_progress(
    base: &CubeMap,
    size: usize,
    method: IrradianceMethod,
    progress: &(dyn Fn(u64) + Sync),
) -> (CubeMap, [[f64; 3]; 9]) {
    // A box-reduced copy keeps the integral, and the SH of it is what the map holds.
    let src = reduced(&base.levels[0], SH_SOURCE_SIZE);
    let coeffs = sh::project_faces(&src);
    let faces = match method {
        IrradianceMethod::Brute => brute_force(&src, size, progress),
        IrradianceMethod::Sh => {
            let e = sh::irradiance(&coeffs);
            let over_pi: [[f64; 3]; 9] =
                std::array::from_fn(|i| e[i].map(|v| v / std::f64::consts::PI));
            CubeMap::from_fn(size, |d| sh::eval(&over_pi, d))
                .levels
                .remove(0)
        }
    };
    (opaque(faces), coeffs)
}

/// The brute-force irradiance map of [`irradiance_with_progress`] without the 9 SH
/// coefficients, for callers that project their own set (`irradiance --sh-bands`).
pub fn brute_irradiance_with_progress(
    base: &CubeMap,
    size: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> CubeMap {
    let src = reduced(&base.levels[0], SH_SOURCE_SIZE);
    opaque(brute_force(&src, size, progress))
}

/// `faces` as a one-level cube map, alpha 1.
fn opaque(mut faces: Faces) -> CubeMap {
    for face in &mut faces {
        for p in &mut face.pixels {
            p.w = 1.0;
        }
    }
    CubeMap {
        levels: vec![faces],
    }
}

/// `faces` box-reduced (solid-angle weighted, as [`CubeMap::with_box_mips`]) until their edge
/// is at most `max`; borrowed when it already is.
pub(crate) fn reduced(faces: &Faces, max: usize) -> Cow<'_, Faces> {
    let mut out = Cow::Borrowed(faces);
    while out[0].width > max.max(1) {
        let n = out[0].width;
        let weights = solid_angle_table(n);
        out = Cow::Owned(std::array::from_fn(|f| {
            box_reduce_face(&out[f], n, &weights, Vec4::INFINITY)
        }));
    }
    out
}

/// The cosine-weighted mean of `src` around each texel of six `size` faces: the bounded part
/// over a reduced copy, the HDR peaks over their own texels, one sum per output texel in a
/// fixed order (the same bytes on every thread count).
fn brute_force(src: &Faces, size: usize, progress: &(dyn Fn(u64) + Sync)) -> Faces {
    let (residual, bright) = bright::split_bright_faces(src, BRIGHT_RATIO);
    let small = reduced(&residual, IRRADIANCE_SOURCE_SIZE);
    let texels = Lanes::of_faces(&small);
    let peaks = Lanes::of_bright(&bright);
    by_rows(size, progress, |n| {
        let sum = texels.cosine_sum(n);
        // Normalised by the discrete integral of the cosine, so a constant stays exact.
        let wsum = sum.w;
        if wsum > 0.0 {
            let lit = sum.truncate() + peaks.cosine_sum(n).truncate();
            (lit / wsum).extend(1.0)
        } else {
            Vec4::W
        }
    })
}

/// Six `size` faces, each texel `f` of its centre's direction, rows in parallel
/// (`progress(1)` per row).
fn by_rows(size: usize, progress: &(dyn Fn(u64) + Sync), f: impl Fn(Vec3) -> Vec4 + Sync) -> Faces {
    use rayon::prelude::*;
    let inv = 1.0 / size as f32;
    let mut out: Faces = std::array::from_fn(|_| Image::new(size, size));
    let mut rows: Vec<(usize, usize, &mut [Vec4])> = Vec::with_capacity(6 * size);
    for (face, img) in out.iter_mut().enumerate() {
        for (y, row) in img.pixels.chunks_mut(size).enumerate() {
            rows.push((face, y, row));
        }
    }
    rows.into_par_iter().for_each(|(face, y, row)| {
        for (x, texel) in row.iter_mut().enumerate() {
            *texel = f(texel_dir(face, x, y, inv));
        }
        progress(1);
    });
    out
}

/// Face edge of [`IrradianceLight`]'s cube of the bounded part: against the brute-force
/// cosine integral, docs/preview.md gives the error of this size and its neighbours
/// (`tests/it/preview_pbr/diffuse.rs` measures it).
pub const IRRADIANCE_LIGHT_SIZE: usize = 32;

/// A map's irradiance as a renderer looks it up by normal (the preview's diffuse light): the
/// sum [`irradiance`] computes (its bounded part over a 64-face copy, its HDR peaks over
/// their own texels), its bounded part kept in a small cube looked up bilinearly and its
/// peaks summed at the exact normal, since a sun's clamped cosine bends at its terminator
/// faster than any cheap cube follows.
pub struct IrradianceLight {
    /// Per texel: the bounded part's irradiance over pi (rgb), and 1 over the discrete
    /// integral of the cosine the irradiance job divides by (alpha), for the peaks.
    cube: CubeSampler,
    peaks: Vec<PeakPatch>,
}

/// Bright texels close together: summed at once where a normal sees all of them above its
/// horizon (the clamped cosine is then linear), member by member where it cuts them.
struct PeakPatch {
    axis: Vec3,
    /// Sine of the patch's angular radius: |n.axis| beyond it, the patch is on one side.
    reach: f32,
    /// Per channel, the members' directions weighed by solid angle times excess radiance.
    sum: [Vec3; 3],
    /// Direction and solid angle times excess radiance of each member.
    members: Vec<(Vec3, Vec3)>,
}

impl IrradianceLight {
    /// The irradiance of `base`'s level 0, its bounded part in a `size` cube.
    pub fn new(base: &CubeMap, size: usize) -> IrradianceLight {
        let src = reduced(&base.levels[0], SH_SOURCE_SIZE);
        let (residual, bright) = bright::split_bright_faces(&src, BRIGHT_RATIO);
        let texels = Lanes::of_faces(&reduced(&residual, IRRADIANCE_SOURCE_SIZE));
        let faces = by_rows(size.max(1), &|_| {}, |n| {
            let sum = texels.cosine_sum(n);
            if sum.w > 0.0 {
                (sum.truncate() / sum.w).extend(1.0 / sum.w)
            } else {
                Vec4::ZERO
            }
        });
        let peaks = bright
            .patches
            .iter()
            .map(|p| {
                let members: Vec<(Vec3, Vec3)> = p
                    .members
                    .iter()
                    .map(|&i| {
                        let (d, sa, excess) = bright.texels[i];
                        (d, excess.truncate() * sa)
                    })
                    .collect();
                let sum = [0, 1, 2].map(|c| members.iter().map(|(d, w)| *d * w[c]).sum());
                PeakPatch {
                    axis: p.axis,
                    reach: (p.radius + 1e-3).min(std::f32::consts::FRAC_PI_2).sin(),
                    sum,
                    members,
                }
            })
            .collect();
        IrradianceLight {
            cube: CubeSampler::new(&CubeMap {
                levels: vec![faces],
            }),
            peaks,
        }
    }

    /// Irradiance over pi at unit normal `n`: what a white Lambertian surface reflects.
    #[inline]
    pub fn at(&self, n: Vec3) -> Vec3 {
        let t = self.cube.bilinear(n, 0);
        let mut lit = Vec3::ZERO;
        for p in &self.peaks {
            let c = n.dot(p.axis);
            if c >= p.reach {
                lit += Vec3::new(n.dot(p.sum[0]), n.dot(p.sum[1]), n.dot(p.sum[2]));
            } else if c > -p.reach {
                for (d, w) in &p.members {
                    lit += *w * n.dot(*d).max(0.0);
                }
            }
        }
        t.truncate() + lit * t.w
    }

    /// Face edge of the bounded part's cube.
    pub fn size(&self) -> usize {
        self.cube.size()
    }

    /// How many bright texels are summed at each normal.
    pub fn peak_texels(&self) -> usize {
        self.peaks.iter().map(|p| p.members.len()).sum()
    }

    /// [`IrradianceLight::at`] at the texel centres of a `size` cube (alpha 1): for a renderer
    /// that can only look a cube up (the viewer's GPU).
    pub fn to_cube(&self, size: usize) -> CubeMap {
        opaque(by_rows(size.max(1), &|_| {}, |n| self.at(n).extend(1.0)))
    }

    /// Bytes [`IrradianceLight::new`] holds at its peak for a base of `face` texels and a cube
    /// of `size`: the copies of the source it sums (box-reduced to 256, its bounded part, the
    /// 64-face copy in lanes), the bright texels (at most 4096) and the cube with its border.
    pub fn plan_bytes(face: usize, size: usize) -> u64 {
        let src = face.min(SH_SOURCE_SIZE) as u64;
        let copies = if face > SH_SOURCE_SIZE { 2 } else { 1 };
        let small = IRRADIANCE_SOURCE_SIZE as u64;
        let bordered = (size as u64 + 4).pow(2);
        copies * 6 * src * src * 16
            + 6 * small * small * (16 + 28)
            + bright::MAX_BRIGHT as u64 * 64
            + 6 * bordered * 16
    }
}

impl std::fmt::Debug for IrradianceLight {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("IrradianceLight")
            .field("size", &self.size())
            .field("peak_texels", &self.peak_texels())
            .finish()
    }
}

/// Vectors per block: eight lanes, two independent chains of sums per quantity.
const VECS: usize = 2;

/// Four texels, field by field, so the sum over them runs in vector lanes.
#[derive(Clone, Copy, Default)]
struct Quad {
    x: Vec4,
    y: Vec4,
    z: Vec4,
    /// Solid angle (0 for padding).
    w: Vec4,
    r: Vec4,
    g: Vec4,
    b: Vec4,
}

/// Texels as blocks of lanes: unit direction, solid angle, radiance.
#[derive(Default)]
struct Lanes {
    blocks: Vec<[Quad; VECS]>,
    len: usize,
}

impl Lanes {
    fn push(&mut self, d: Vec3, solid_angle: f32, v: Vec3) {
        let lane = self.len % (4 * VECS);
        if lane == 0 {
            self.blocks.push([Quad::default(); VECS]);
        }
        let q = &mut self.blocks.last_mut().expect("a block")[lane / 4];
        let l = lane % 4;
        (q.x[l], q.y[l], q.z[l], q.w[l]) = (d.x, d.y, d.z, solid_angle);
        (q.r[l], q.g[l], q.b[l]) = (v.x, v.y, v.z);
        self.len += 1;
    }

    /// Every texel of six faces, face by face, row by row.
    fn of_faces(faces: &Faces) -> Lanes {
        let n = faces[0].width;
        let inv = 1.0 / n as f32;
        let angles = solid_angle_table(n);
        let mut out = Lanes::default();
        for (face, img) in faces.iter().enumerate() {
            for y in 0..n {
                for x in 0..n {
                    let d = texel_dir(face, x, y, inv);
                    out.push(d, angles[y * n + x], img.get(x, y).truncate());
                }
            }
        }
        out
    }

    /// The excess radiance of the bright texels, where they are.
    fn of_bright(bright: &bright::Bright) -> Lanes {
        let mut out = Lanes::default();
        for &(d, sa, excess) in &bright.texels {
            out.push(d, sa, excess.truncate());
        }
        out
    }

    /// Sum over the texels of max(0, n.d) times (solid angle x radiance, solid angle): each
    /// lane in texel order, the lanes then added in a fixed order.
    #[inline]
    fn cosine_sum(&self, n: Vec3) -> Vec4 {
        let (nx, ny, nz) = (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
        let mut acc = [[Vec4::ZERO; 4]; VECS];
        for block in &self.blocks {
            for (q, a) in block.iter().zip(acc.iter_mut()) {
                let c = nx * q.x + ny * q.y + nz * q.z;
                let w = c.max(Vec4::ZERO) * q.w;
                a[0] += w * q.r;
                a[1] += w * q.g;
                a[2] += w * q.b;
                a[3] += w;
            }
        }
        let total = |k: usize| {
            let v = acc[1..].iter().fold(acc[0][k], |s, a| s + a[k]);
            (v.x + v.z) + (v.y + v.w)
        };
        Vec4::new(total(0), total(1), total(2), total(3))
    }
}
