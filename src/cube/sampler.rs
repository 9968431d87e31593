//! Seamless lookups: a cube map whose faces carry a border filled from their neighbours, so
//! bilinear and bicubic taps never leave a face, with batched lookups for the filters.

#![warn(missing_docs)]

use super::environment::{Dirs, Environment, Interp, BATCH};
use super::face::{dir_face, dir_face_lanes, face_dir, solid_angle_table, texel_angle};
use super::map::{box_reduce_face, CubeMap, Faces};
use crate::image::Image;
use glam::{Vec3, Vec4};

/// Border texels added around each face so bilinear and bicubic taps never leave the face.
const BORDER: usize = 2;

/// A cube map prepared for seamless lookups: each level's faces carry a border filled from
/// their neighbours, so filtering across an edge reads the adjacent face.
pub struct CubeSampler {
    levels: Vec<(usize, [Image; 6])>,
}

impl CubeSampler {
    /// Prepares every level of `cube` as it is.
    pub fn new(cube: &CubeMap) -> CubeSampler {
        let levels = cube
            .levels
            .iter()
            .map(|faces| (faces[0].width, bordered(faces, Vec4::INFINITY)))
            .collect();
        CubeSampler { levels }
    }

    /// Prepares `faces` as level 0 and `count` plain box mips below it (None: the full
    /// chain), as `new(&cube.with_box_mips(count))` would, without copying level 0 first.
    pub fn with_box_mips(faces: &Faces, count: Option<usize>) -> CubeSampler {
        Self::with_box_mips_below(faces, count, Vec4::INFINITY)
    }

    /// `with_box_mips` with every texel first clamped to `ceiling` (per channel), so lookups
    /// see the bounded part of an input whose peaks are splatted (see [`crate::flux`]).
    pub(crate) fn with_box_mips_below(
        faces: &Faces,
        count: Option<usize>,
        ceiling: Vec4,
    ) -> CubeSampler {
        let n = faces[0].width;
        let full = CubeMap::full_chain_len(n);
        let count = count.unwrap_or(full).clamp(1, full);
        let mut levels = vec![(n, bordered(faces, ceiling))];
        if count > 1 {
            let weights = solid_angle_table(n);
            let first: Faces =
                std::array::from_fn(|f| box_reduce_face(&faces[f], n, &weights, ceiling));
            let rest = CubeMap {
                levels: vec![first],
            }
            .with_box_mips(Some(count - 1));
            levels.extend(
                rest.levels
                    .iter()
                    .map(|l| (l[0].width, bordered(l, Vec4::INFINITY))),
            );
        }
        CubeSampler { levels }
    }

    /// Face edge of level 0.
    pub fn size(&self) -> usize {
        self.levels[0].0
    }

    /// Reads one texel of a level (no interpolation), for exact lookups.
    pub fn texel(&self, level: usize, face: usize, x: usize, y: usize) -> Vec4 {
        self.levels[level].1[face].get(x + BORDER, y + BORDER)
    }

    /// Trilinear lookup: bilinear in the two levels around fractional `lod`, blended.
    #[inline]
    pub(crate) fn sample_lod(&self, d: Vec3, lod: f32) -> Vec4 {
        let max = (self.levels.len() - 1) as f32;
        let lod = lod.clamp(0.0, max);
        let l0 = lod as usize;
        self.sample_split(d, l0, lod - l0 as f32)
    }

    /// Trilinear lookup with the level already split into integer level and fraction.
    #[inline]
    pub fn sample_split(&self, d: Vec3, level: usize, frac: f32) -> Vec4 {
        // One face selection for both levels.
        let (face, s, t) = dir_face(d);
        let a = self.bilinear_at(face, s, t, level);
        if frac <= 0.0 || level + 1 >= self.levels.len() {
            return a;
        }
        a.lerp(self.bilinear_at(face, s, t, level + 1), frac)
    }

    /// Bilinear lookup in one level. The border makes every tap land inside the bordered
    /// face, so no clamping or wrapping is needed: the hot path of every filter.
    #[inline(always)]
    pub fn bilinear(&self, d: Vec3, level: usize) -> Vec4 {
        let (face, s, t) = dir_face(d);
        self.bilinear_at(face, s, t, level)
    }

    /// Bilinear lookup at face coordinates (s, t) of `face`.
    #[inline(always)]
    fn bilinear_at(&self, face: usize, s: f32, t: f32, level: usize) -> Vec4 {
        let (n, faces) = &self.levels[level];
        let img = &faces[face];
        read_bilinear(img, texel_at(s, t, *n as f32))
    }

    /// `bilinear` for a whole batch: face selection and texel coordinates in vector lanes,
    /// prefetches for every tap, then the reads. Gives `bilinear`'s values bit for bit.
    fn bilinear_many(&self, dirs: &Dirs, level: usize, out: &mut [Vec4]) {
        let (n, faces) = &self.levels[level];
        let count = dirs.len;
        let mut face = [0u8; BATCH];
        let mut at = [TexelAt::default(); BATCH];
        for i in 0..count {
            let (f, s, t) = dir_face_lanes(dirs.x[i], dirs.y[i], dirs.z[i]);
            face[i] = f;
            at[i] = texel_at(s, t, *n as f32);
        }
        #[cfg(target_arch = "x86_64")]
        for i in 0..count {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let img = &faces[face[i] as usize];
            let k = at[i].row as usize * img.width + at[i].col as usize;
            let p = img.pixels.as_ptr();
            // SAFETY: the index lies inside the bordered face (clamped in `texel_at`); a
            // prefetch never faults and brings nothing into the program.
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p.add(k) as *const i8);
                _mm_prefetch::<_MM_HINT_T0>(p.add(k + img.width) as *const i8);
            }
        }
        for (i, o) in out.iter_mut().enumerate().take(count) {
            *o = read_bilinear(&faces[face[i] as usize], at[i]);
        }
    }

    /// `sample_split(dirs[i], level[i], frac[i])` for a batch: the face selection and both
    /// levels' texel coordinates in vector lanes, then the reads. Bit for bit `sample_split`.
    pub fn trilinear_many(&self, dirs: &Dirs, level: &[usize], frac: &[f32], out: &mut [Vec4]) {
        let count = dirs.len;
        let top = self.levels.len() - 1;
        let mut face = [0u8; BATCH];
        let mut fs = [0.0f32; BATCH];
        let mut ft = [0.0f32; BATCH];
        for i in 0..count {
            (face[i], fs[i], ft[i]) = dir_face_lanes(dirs.x[i], dirs.y[i], dirs.z[i]);
        }
        // Each tap reads two levels (the second only when it blends): their face edges.
        let mut edge = [[0.0f32; BATCH]; 2];
        for i in 0..count {
            edge[0][i] = self.levels[level[i]].0 as f32;
            edge[1][i] = self.levels[(level[i] + 1).min(top)].0 as f32;
        }
        let mut at = [[TexelAt::default(); BATCH]; 2];
        for k in 0..2 {
            for i in 0..count {
                at[k][i] = texel_at(fs[i], ft[i], edge[k][i]);
            }
        }
        let read = |k: usize, i: usize, l: usize| {
            read_bilinear(&self.levels[l].1[face[i] as usize], at[k][i])
        };
        for i in 0..count {
            let l = level[i];
            let a = read(0, i, l);
            out[i] = if frac[i] <= 0.0 || l >= top {
                a
            } else {
                a.lerp(read(1, i, l + 1), frac[i])
            };
        }
    }
}

/// Where a bilinear tap reads in a bordered face: the top-left texel and the weights.
#[derive(Clone, Copy, Default)]
struct TexelAt {
    col: u32,
    row: u32,
    fx: f32,
    fy: f32,
}

/// The bilinear tap at face coordinates (s, t) of a bordered face of edge `n` (width
/// n + 2 BORDER): coordinates minus half a texel, always >= BORDER - 0.5 > 0, their integer
/// parts clamped to width - 2 and their fractions. Float arithmetic only, so it vectorises.
#[inline(always)]
fn texel_at(s: f32, t: f32, n: f32) -> TexelAt {
    let last = n + (2 * BORDER - 2) as f32;
    let x = (s * n + (BORDER as f32 - 0.5)).max(0.0);
    let y = (t * n + (BORDER as f32 - 0.5)).max(0.0);
    let (xi, yi) = (trunc_small(x), trunc_small(y));
    TexelAt {
        // SAFETY: both lie in 0..=width-2 (non-negative, clamped).
        col: unsafe { xi.min(last).to_int_unchecked::<u32>() },
        row: unsafe { yi.min(last).to_int_unchecked::<u32>() },
        fx: x - xi,
        fy: y - yi,
    }
}

/// Reads and blends the 2x2 texels of a tap.
#[inline(always)]
fn read_bilinear(img: &Image, at: TexelAt) -> Vec4 {
    let w = img.width;
    let k = at.row as usize * w + at.col as usize;
    let p = &img.pixels;
    let upper = p[k].lerp(p[k + 1], at.fx);
    let lower = p[k + w].lerp(p[k + w + 1], at.fx);
    upper.lerp(lower, at.fy)
}

/// The integer part of a non-negative value, as a float, without the saturating cast that
/// keeps a loop scalar (values here are texel coordinates, far below 2^23).
#[inline(always)]
fn trunc_small(v: f32) -> f32 {
    // SAFETY: `v` >= 0 after the callers' max (which also drops NaN) and clamped below 2^23.
    (unsafe { v.min(8_388_608.0).to_int_unchecked::<i32>() }) as f32
}

impl Environment for CubeSampler {
    fn sample_many(&self, dirs: &Dirs, level: usize, interp: Interp, out: &mut [Vec4]) {
        let level = level.min(self.levels.len() - 1);
        if interp == Interp::Bilinear {
            return self.bilinear_many(dirs, level, out);
        }
        for (i, o) in out.iter_mut().enumerate().take(dirs.len) {
            *o = self.sample(dirs.get(i), level, interp);
        }
    }

    #[inline]
    fn sample(&self, d: Vec3, level: usize, interp: Interp) -> Vec4 {
        let level = level.min(self.levels.len() - 1);
        if interp == Interp::Bilinear {
            return self.bilinear(d, level);
        }
        let (n, faces) = &self.levels[level];
        let (face, s, t) = dir_face(d);
        let x = s * *n as f32 + BORDER as f32;
        let y = t * *n as f32 + BORDER as f32;
        faces[face].bicubic(x, y, false)
    }
    fn texel_angle(&self) -> f32 {
        texel_angle(self.size())
    }
    fn levels(&self) -> usize {
        self.levels.len()
    }
    /// Trilinear between the two levels around `lod`; plain bilinear at level 0.
    #[inline]
    fn lookup(&self, v: Vec3, lod: f32) -> Vec4 {
        if lod <= 0.0 {
            self.bilinear(v, 0)
        } else {
            self.sample_lod(v, lod)
        }
    }
    fn face_size(&self) -> usize {
        self.size()
    }
}

/// Copies each face into the middle of a larger image and fills the border from the faces
/// the extended face plane runs into (bilinear there, so the continuation is smooth); every
/// texel at most `ceiling`.
fn bordered(faces: &Faces, ceiling: Vec4) -> [Image; 6] {
    use rayon::prelude::*;
    let n = faces[0].width;
    let m = n + 2 * BORDER;
    let inv = 1.0 / n as f32;
    let out: Vec<Image> = (0..6usize)
        .into_par_iter()
        .map(|face| {
            let mut out = Image::new(m, m);
            out.paste(&faces[face], BORDER, BORDER);
            for y in 0..m {
                for x in 0..m {
                    let inside =
                        (BORDER..BORDER + n).contains(&x) && (BORDER..BORDER + n).contains(&y);
                    if inside {
                        continue;
                    }
                    let s = (x as f32 - BORDER as f32 + 0.5) * inv;
                    let t = (y as f32 - BORDER as f32 + 0.5) * inv;
                    let (f2, s2, t2) = dir_face(face_dir(face, s, t));
                    // Clamp half a texel inside so the tap stays on the neighbour face.
                    let px = (s2 * n as f32).clamp(0.5, n as f32 - 0.5);
                    let py = (t2 * n as f32).clamp(0.5, n as f32 - 0.5);
                    out.set(x, y, faces[f2].bilinear(px, py, false));
                }
            }
            if ceiling.x.is_finite() {
                for p in &mut out.pixels {
                    *p = p.min(ceiling);
                }
            }
            out
        })
        .collect();
    out.try_into().expect("six faces")
}
