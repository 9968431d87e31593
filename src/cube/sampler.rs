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

    /// Number of levels (level 0 and its box mips).
    pub(crate) fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// Face edge of `level`.
    pub(crate) fn level_size(&self, level: usize) -> usize {
        self.levels[level].0
    }

    /// Row `y` of a level's face, without the border.
    pub(crate) fn row(&self, level: usize, face: usize, y: usize) -> &[Vec4] {
        let (n, faces) = &self.levels[level];
        let img = &faces[face];
        let start = (y + BORDER) * img.width + BORDER;
        &img.pixels[start..start + n]
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
        let mut taps = TapLevels::default();
        for i in 0..dirs.len {
            taps.push(self, level[i], frac[i]);
        }
        self.trilinear_taps(dirs, &taps, &mut TapScratch::new(), out);
    }

    /// `trilinear_many` with the levels prepared once (a filter kernel's taps keep theirs for
    /// every texel) and scratch space the caller keeps: nothing per call but the lookups.
    #[inline]
    pub(crate) fn trilinear_taps(
        &self,
        dirs: &Dirs,
        taps: &TapLevels,
        scratch: &mut TapScratch,
        out: &mut [Vec4],
    ) {
        let count = dirs.len.min(taps.len);
        let TapScratch {
            face,
            col,
            row,
            fx,
            fy,
        } = scratch;
        // Face selection and both levels' texel coordinates four lanes at a time (BATCH is a
        // multiple of 4; lanes past `count` compute harmless values that are never read).
        for j in (0..count).step_by(4) {
            let lanes = |a: &[f32; BATCH]| Vec4::from_slice(&a[j..j + 4]);
            let (f, s, t) = dir_face_vec4(lanes(&dirs.x), lanes(&dirs.y), lanes(&dirs.z));
            f.write_to_slice(&mut face[j..j + 4]);
            for k in 0..2 {
                let (c, r, x, y) = texel_at_vec4(s, t, lanes(&taps.edge[k]));
                c.write_to_slice(&mut col[k][j..j + 4]);
                r.write_to_slice(&mut row[k][j..j + 4]);
                x.write_to_slice(&mut fx[k][j..j + 4]);
                y.write_to_slice(&mut fy[k][j..j + 4]);
            }
        }
        // The reads, tap by tap.
        // SAFETY (the conversions): faces are 0..=5, columns and rows whole floats in
        // 0..=width-2 (`texel_at_vec4`): all exactly representable as integers.
        let at = |k: usize, i: usize| TexelAt {
            col: unsafe { col[k][i].to_int_unchecked::<u32>() },
            row: unsafe { row[k][i].to_int_unchecked::<u32>() },
            fx: fx[k][i],
            fy: fy[k][i],
        };
        for (i, o) in out.iter_mut().enumerate().take(count) {
            let l = taps.level[i] as usize;
            let f = unsafe { face[i].to_int_unchecked::<usize>() };
            let a = read_bilinear(&self.levels[l].1[f], at(0, i));
            *o = if taps.blend[i] {
                a.lerp(
                    read_bilinear(&self.levels[l + 1].1[f], at(1, i)),
                    taps.frac[i],
                )
            } else {
                a
            };
        }
    }
}

/// `dir_face_lanes` for four directions in vector registers: the face (as a float) and
/// (s, t), bit for bit (the same operations, selects for branches).
#[inline(always)]
fn dir_face_vec4(x: Vec4, y: Vec4, z: Vec4) -> (Vec4, Vec4, Vec4) {
    let zero = Vec4::ZERO;
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let xmaj = ax.cmpge(ay) & ax.cmpge(az);
    let ymaj = !xmaj & ay.cmpge(az);
    let (xpos, ypos, zpos) = (x.cmpge(zero), y.cmpge(zero), z.cmpge(zero));
    let c = Vec4::splat;
    let face = Vec4::select(
        xmaj,
        Vec4::select(xpos, c(0.0), c(1.0)),
        Vec4::select(
            ymaj,
            Vec4::select(ypos, c(2.0), c(3.0)),
            Vec4::select(zpos, c(4.0), c(5.0)),
        ),
    );
    let sc = Vec4::select(
        xmaj,
        Vec4::select(xpos, -z, z),
        Vec4::select(ymaj | zpos, x, -x),
    );
    let tc = Vec4::select(ymaj, Vec4::select(ypos, z, -z), -y);
    let ma = Vec4::select(xmaj, ax, Vec4::select(ymaj, ay, az));
    let inv = Vec4::select(ma.cmpgt(zero), c(0.5) / ma, zero);
    (face, sc * inv + c(0.5), tc * inv + c(0.5))
}

/// `texel_at` for four lanes: column, row (whole floats), and the two weights.
#[inline(always)]
fn texel_at_vec4(s: Vec4, t: Vec4, n: Vec4) -> (Vec4, Vec4, Vec4, Vec4) {
    let last = n + Vec4::splat((2 * BORDER - 2) as f32);
    let half = Vec4::splat(BORDER as f32 - 0.5);
    let x = (s * n + half).max(Vec4::ZERO);
    let y = (t * n + half).max(Vec4::ZERO);
    // Truncation of values in 0..2^23, as `trunc_small`.
    let cap = Vec4::splat(8_388_608.0);
    let (xi, yi) = (trunc_small_vec4(x.min(cap)), trunc_small_vec4(y.min(cap)));
    (xi.min(last), yi.min(last), x - xi, y - yi)
}

/// The levels a batch of trilinear taps reads, prepared for one sampler: per tap the level,
/// the fraction towards the next, whether it blends at all, and both levels' face edges.
#[derive(Clone)]
pub(crate) struct TapLevels {
    level: [u32; BATCH],
    frac: [f32; BATCH],
    blend: [bool; BATCH],
    edge: [[f32; BATCH]; 2],
    len: usize,
}

impl Default for TapLevels {
    fn default() -> Self {
        TapLevels {
            level: [0; BATCH],
            frac: [0.0; BATCH],
            blend: [false; BATCH],
            edge: [[1.0; BATCH]; 2],
            len: 0,
        }
    }
}

impl TapLevels {
    /// Appends a tap reading `level` (clamped to the sampler's) blended by `frac` with the next.
    pub(crate) fn push(&mut self, sampler: &CubeSampler, level: usize, frac: f32) {
        let top = sampler.levels.len() - 1;
        let level = level.min(top);
        let i = self.len;
        self.level[i] = level as u32;
        self.frac[i] = frac;
        // As `sample_split`: no second read at the top level or without a fraction.
        self.blend[i] = frac > 0.0 && level < top;
        self.edge[0][i] = sampler.levels[level].0 as f32;
        self.edge[1][i] = sampler.levels[(level + 1).min(top)].0 as f32;
        self.len = i + 1;
    }
}

/// Scratch space for `trilinear_taps`, kept by the caller so no call zeroes it: per tap
/// its face, and per level read the texel position (whole floats) and weights.
pub(crate) struct TapScratch {
    face: [f32; BATCH],
    col: [[f32; BATCH]; 2],
    row: [[f32; BATCH]; 2],
    fx: [[f32; BATCH]; 2],
    fy: [[f32; BATCH]; 2],
}

impl TapScratch {
    pub(crate) fn new() -> TapScratch {
        TapScratch {
            face: [0.0; BATCH],
            col: [[0.0; BATCH]; 2],
            row: [[0.0; BATCH]; 2],
            fx: [[0.0; BATCH]; 2],
            fy: [[0.0; BATCH]; 2],
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

/// `trunc_small` for four lanes (values in 0..=2^23, as `texel_at_vec4` makes them): one
/// conversion each way.
#[inline(always)]
fn trunc_small_vec4(v: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_cvtepi32_ps, _mm_cvttps_epi32};
        // SAFETY: SSE2 is part of x86_64; the lanes are in range, so the conversion is exact.
        Vec4::from(unsafe { _mm_cvtepi32_ps(_mm_cvttps_epi32(v.into())) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    v.trunc()
}

/// Reads and blends the 2x2 texels of a tap.
#[inline(always)]
fn read_bilinear(img: &Image, at: TexelAt) -> Vec4 {
    let w = img.width;
    let k = at.row as usize * w + at.col as usize;
    // One bounds check for all four: the furthest, k + w + 1 (row and column come from u32s,
    // so none of these sums wraps).
    let p = &img.pixels[..k + w + 2];
    // SAFETY: k < k + 1 < k + w < k + w + 1 < p.len().
    let t = |i: usize| unsafe { *p.get_unchecked(i) };
    let upper = t(k).lerp(t(k + 1), at.fx);
    let lower = t(k + w).lerp(t(k + w + 1), at.fx);
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
/// texel at most `ceiling`. Rows of all six faces in parallel (no face-sized serial step).
fn bordered(faces: &Faces, ceiling: Vec4) -> [Image; 6] {
    use rayon::prelude::*;
    let n = faces[0].width;
    let m = n + 2 * BORDER;
    let inv = 1.0 / n as f32;
    let mut out: [Image; 6] = std::array::from_fn(|_| Image::new(m, m));
    let mut rows: Vec<(usize, usize, &mut [Vec4])> = Vec::with_capacity(6 * m);
    for (face, img) in out.iter_mut().enumerate() {
        for (y, row) in img.pixels.chunks_mut(m).enumerate() {
            rows.push((face, y, row));
        }
    }
    let clamp = ceiling.x.is_finite();
    rows.into_par_iter().for_each(|(face, y, row)| {
        let inner_row = (BORDER..BORDER + n).contains(&y);
        for (x, p) in row.iter_mut().enumerate() {
            let inside = inner_row && (BORDER..BORDER + n).contains(&x);
            *p = if inside {
                faces[face].get(x - BORDER, y - BORDER)
            } else {
                let s = (x as f32 - BORDER as f32 + 0.5) * inv;
                let t = (y as f32 - BORDER as f32 + 0.5) * inv;
                let (f2, s2, t2) = dir_face(face_dir(face, s, t));
                // Clamp half a texel inside so the tap stays on the neighbour face.
                let px = (s2 * n as f32).clamp(0.5, n as f32 - 0.5);
                let py = (t2 * n as f32).clamp(0.5, n as f32 - 0.5);
                faces[f2].bilinear(px, py, false)
            };
            if clamp {
                *p = p.min(ceiling);
            }
        }
    });
    out
}
