//! Cube maps: six square faces in the OpenGL face-selection convention, their mip levels,
//! direction <-> texel mapping (written once, here) and seamless sampling across face edges.

use crate::error::{Error, Result};
use crate::image::Image;
use glam::{Vec3, Vec4};

/// Faces in file and container order: +X -X +Y -Y +Z -Z.
pub const FACE_NAMES: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];
/// Long names some tools use for the same faces.
pub const FACE_LONG_NAMES: [&str; 6] = ["posx", "negx", "posy", "negy", "posz", "negz"];

/// The direction through face coordinates (s, t) (0..1, row 0 is t = 0). Values outside
/// 0..1 continue the face's plane, which is how border texels find their neighbours.
#[inline]
pub fn face_dir(face: usize, s: f32, t: f32) -> Vec3 {
    let sc = 2.0 * s - 1.0;
    let tc = 2.0 * t - 1.0;
    match face {
        0 => Vec3::new(1.0, -tc, -sc),
        1 => Vec3::new(-1.0, -tc, sc),
        2 => Vec3::new(sc, 1.0, tc),
        3 => Vec3::new(sc, -1.0, -tc),
        4 => Vec3::new(sc, -tc, 1.0),
        _ => Vec3::new(-sc, -tc, -1.0),
    }
}

/// The face a direction selects (largest component; ties go to X, then Y) and its (s, t).
#[inline(always)]
pub fn dir_face(d: Vec3) -> (usize, f32, f32) {
    let (face, s, t) = dir_face_lanes(d.x, d.y, d.z);
    (face as usize, s, t)
}

/// Solid angle of texel (x, y) on a face of edge `n` (exact, from the area of a projected
/// rectangle), so averages over the sphere weight texels by the part of the sphere they cover.
/// Angle one texel of a face of edge `size` spans on average: a quarter turn over the edge.
pub fn texel_angle(size: usize) -> f32 {
    std::f32::consts::FRAC_PI_2 / size.max(1) as f32
}

pub fn texel_solid_angle(n: usize, x: usize, y: usize) -> f32 {
    let c = |i: usize| corner(n, i);
    (corner_area(c(x), c(y)) - corner_area(c(x), c(y + 1)) - corner_area(c(x + 1), c(y))
        + corner_area(c(x + 1), c(y + 1))) as f32
}

/// `texel_solid_angle` for every texel of a face (the same on all six), row by row: one
/// arctangent per texel corner instead of four per texel.
pub fn solid_angle_table(n: usize) -> Vec<f32> {
    let row = |j: usize| -> Vec<f64> {
        (0..=n)
            .map(|i| corner_area(corner(n, i), corner(n, j)))
            .collect()
    };
    let mut out = Vec::with_capacity(n * n);
    let mut above = row(0);
    for y in 0..n {
        let below = row(y + 1);
        for x in 0..n {
            out.push((above[x] - below[x] - above[x + 1] + below[x + 1]) as f32);
        }
        above = below;
    }
    out
}

/// Face-plane coordinate (-1..1) of texel corner `i` on a face of edge `n`.
#[inline]
fn corner(n: usize, i: usize) -> f64 {
    i as f64 * (2.0 / n as f64) - 1.0
}

/// Solid angle of the face-plane rectangle from the face centre to (x, y).
#[inline]
fn corner_area(x: f64, y: f64) -> f64 {
    (x * y).atan2((x * x + y * y + 1.0).sqrt())
}

/// Six square faces of one size.
pub type Faces = [Image; 6];

/// A cube map with one or more mip levels (level 0 the largest).
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap {
    pub levels: Vec<Faces>,
}

impl CubeMap {
    /// Checks that six faces are square and of one size.
    pub fn from_faces(faces: Faces) -> std::result::Result<CubeMap, String> {
        let n = faces[0].width;
        for (i, f) in faces.iter().enumerate() {
            if f.width != f.height {
                return Err(format!(
                    "face {} is {}x{}, not square",
                    FACE_NAMES[i], f.width, f.height
                ));
            }
            if f.width != n {
                return Err(format!(
                    "face {} is {}x{} but face px is {}x{}: all faces must be the same size",
                    FACE_NAMES[i], f.width, f.height, n, n
                ));
            }
        }
        if n == 0 {
            return Err("faces are empty".into());
        }
        Ok(CubeMap {
            levels: vec![faces],
        })
    }

    /// Edge of level 0's faces.
    pub fn size(&self) -> usize {
        self.levels[0][0].width
    }

    /// Fills every texel of a `size` cube with `f(direction of its centre)`.
    pub fn from_fn(size: usize, f: impl Fn(Vec3) -> Vec4 + Sync) -> CubeMap {
        let inv = 1.0 / size as f32;
        let faces = std::array::from_fn(|face| {
            Image::from_fn(size, size, |x, y| {
                f(face_dir(face, (x as f32 + 0.5) * inv, (y as f32 + 0.5) * inv).normalize())
            })
        });
        CubeMap {
            levels: vec![faces],
        }
    }

    /// Number of levels in a full chain for a face edge: down to 1 x 1.
    pub fn full_chain_len(size: usize) -> usize {
        (usize::BITS - size.max(1).leading_zeros()) as usize
    }

    /// Keeps level 0 and rebuilds `count` levels (None: the full chain) as plain mipmaps,
    /// each texel the solid-angle-weighted mean of the 2x2 texels above it.
    pub fn with_box_mips(mut self, count: Option<usize>) -> CubeMap {
        let full = Self::full_chain_len(self.size());
        let count = count.unwrap_or(full).clamp(1, full);
        self.levels.truncate(1);
        while self.levels.len() < count {
            let prev = self.levels.last().unwrap();
            let n = prev[0].width;
            let weights = solid_angle_table(n);
            let next =
                std::array::from_fn(|f| box_reduce_face(&prev[f], n, &weights, Vec4::INFINITY));
            self.levels.push(next);
        }
        self
    }

    /// Applies `f` to every texel of every level.
    pub fn map_texels(&mut self, f: impl Fn(Vec4) -> Vec4 + Sync) {
        use rayon::prelude::*;
        for level in &mut self.levels {
            for face in level.iter_mut() {
                face.pixels.par_iter_mut().for_each(|p| *p = f(*p));
            }
        }
    }
}

/// Each texel the mean of the 2x2 above it (each first clamped to `ceiling`), weighted by
/// their solid angles (`weights`, one face's table) so the mean radiance over the sphere is kept.
fn box_reduce_face(src: &Image, n: usize, weights: &[f32], ceiling: Vec4) -> Image {
    let m = (n / 2).max(1);
    if n == 1 {
        return src.clone();
    }
    Image::from_fn(m, m, |x, y| {
        let mut acc = Vec4::ZERO;
        let mut wsum = 0.0;
        for dy in 0..2 {
            for dx in 0..2 {
                let (sx, sy) = (2 * x + dx, 2 * y + dy);
                let w = weights[sy * n + sx];
                acc += src.get(sx, sy).min(ceiling) * w;
                wsum += w;
            }
        }
        acc / wsum
    })
}

/// How a sample between texels is reconstructed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Interp {
    /// Bilinear: smooth, never rings.
    #[default]
    Bilinear,
    /// Catmull-Rom bicubic, clamped to the local texel range so it never rings below zero.
    Bicubic,
}

/// Anything that can be looked up by direction: a cube map, a panorama, a mirror ball, an
/// analytic function. Conversions, filters and the preview all sample through this.
pub trait Environment: Sync {
    /// The value seen along unit direction `d`, from pyramid level `level` (0 = sharpest).
    fn sample(&self, d: Vec3, level: usize, interp: Interp) -> Vec4;
    /// Angle (radians) one texel of level 0 subtends, for choosing a level and a sample count.
    fn texel_angle(&self) -> f32;
    /// Number of pyramid levels available (each halves the resolution).
    fn levels(&self) -> usize;
    /// `texCUBE` along `v` (any length, non-zero) at a fractional level of detail `lod` (0 the
    /// sharpest; clamped to the chain): what the preview samples. By default the nearest
    /// level, bilinear.
    fn lookup(&self, v: Vec3, lod: f32) -> Vec4 {
        let top = self.levels().saturating_sub(1);
        let level = (lod.max(0.0).round() as usize).min(top);
        self.sample(v.normalize(), level, Interp::Bilinear)
    }
    /// Face edge of level 0 in texels: a quarter turn over the texel angle.
    fn face_size(&self) -> usize {
        (std::f32::consts::FRAC_PI_2 / self.texel_angle())
            .round()
            .clamp(1.0, 1e9) as usize
    }
    /// `out[i]` = `sample(dirs[i], level, interp)` for a whole batch. Layouts override it with
    /// loops over the batch's arrays that the compiler vectorises; the default asks one by one.
    fn sample_many(&self, dirs: &Dirs, level: usize, interp: Interp, out: &mut [Vec4]) {
        for (i, o) in out.iter_mut().enumerate().take(dirs.len) {
            *o = self.sample(dirs.get(i), level, interp);
        }
    }
    /// The input's peaks above the ceiling its lookups are clamped to, which a resampler
    /// splats on top of what it rendered (see [`crate::flux`]); None for a plain environment.
    fn peaks(&self) -> Option<&crate::flux::Peaks> {
        None
    }
}

/// Directions per batch: enough to amortise a call, small enough to live on the stack.
pub const BATCH: usize = 128;

/// A batch of directions as separate x, y, z arrays (structure of arrays), so per-direction
/// maths runs four or eight lanes at a time.
#[derive(Clone)]
pub struct Dirs {
    pub x: [f32; BATCH],
    pub y: [f32; BATCH],
    pub z: [f32; BATCH],
    pub len: usize,
}

impl Default for Dirs {
    fn default() -> Self {
        Dirs {
            x: [0.0; BATCH],
            y: [0.0; BATCH],
            z: [0.0; BATCH],
            len: 0,
        }
    }
}

impl Dirs {
    #[inline]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    pub fn is_full(&self) -> bool {
        self.len == BATCH
    }

    /// Appends one direction; the caller flushes a full batch first.
    #[inline]
    pub fn push(&mut self, d: Vec3) {
        let i = self.len;
        self.x[i] = d.x;
        self.y[i] = d.y;
        self.z[i] = d.z;
        self.len = i + 1;
    }

    /// Turns every direction by `m` (same operation order as `Mat3 * Vec3`).
    pub fn transform(&mut self, m: &glam::Mat3) {
        let n = self.len;
        let (c0, c1, c2) = (m.x_axis, m.y_axis, m.z_axis);
        for ((x, y), z) in self.x[..n]
            .iter_mut()
            .zip(self.y[..n].iter_mut())
            .zip(self.z[..n].iter_mut())
        {
            let (a, b, c) = (*x, *y, *z);
            *x = c0.x * a + c1.x * b + c2.x * c;
            *y = c0.y * a + c1.y * b + c2.y * c;
            *z = c0.z * a + c1.z * b + c2.z * c;
        }
    }

    /// Scales every direction to unit length (same arithmetic as `Vec3::normalize`).
    pub fn normalize(&mut self) {
        let n = self.len;
        for ((x, y), z) in self.x[..n]
            .iter_mut()
            .zip(self.y[..n].iter_mut())
            .zip(self.z[..n].iter_mut())
        {
            let inv = 1.0 / (*x * *x + *y * *y + *z * *z).sqrt();
            *x *= inv;
            *y *= inv;
            *z *= inv;
        }
    }
}

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
    pub fn with_box_mips_below(faces: &Faces, count: Option<usize>, ceiling: Vec4) -> CubeSampler {
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
    pub fn sample_lod(&self, d: Vec3, lod: f32) -> Vec4 {
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

/// `dir_face`, written with every branch a select so loops over batches vectorise (the face
/// as a byte keeps the lanes narrow).
#[inline(always)]
fn dir_face_lanes(x: f32, y: f32, z: f32) -> (u8, f32, f32) {
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let xmaj = ax >= ay && ax >= az;
    let ymaj = !xmaj && ay >= az;
    let f = if xmaj {
        if x >= 0.0 {
            0
        } else {
            1
        }
    } else if ymaj {
        if y >= 0.0 {
            2
        } else {
            3
        }
    } else if z >= 0.0 {
        4
    } else {
        5
    };
    let sc = if xmaj {
        if x >= 0.0 {
            -z
        } else {
            z
        }
    } else if ymaj || z >= 0.0 {
        x
    } else {
        -x
    };
    let tc = if ymaj {
        if y >= 0.0 {
            z
        } else {
            -z
        }
    } else {
        -y
    };
    let ma = if xmaj {
        ax
    } else if ymaj {
        ay
    } else {
        az
    };
    let inv = if ma > 0.0 { 0.5 / ma } else { 0.0 };
    (f, sc * inv + 0.5, tc * inv + 0.5)
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

/// Reads a cube map from six same-size images, naming the file of a face that does not fit.
pub fn faces_from_images(images: Vec<Image>, names: &[std::path::PathBuf]) -> Result<CubeMap> {
    let n = images[0].width;
    for (i, img) in images.iter().enumerate() {
        if img.width != img.height {
            return Err(Error::file(
                &names[i],
                format!("face is {}x{}, not square", img.width, img.height),
            ));
        }
        if img.width != n {
            return Err(Error::file(
                &names[i],
                format!(
                    "face is {}x{} but {} is {}x{}: all six faces must be the same size",
                    img.width,
                    img.height,
                    names[0].display(),
                    n,
                    n
                ),
            ));
        }
    }
    let faces: Faces = images
        .try_into()
        .map_err(|_| Error::usage("a cube map needs exactly six faces"))?;
    CubeMap::from_faces(faces).map_err(|e| Error::file(&names[0], e))
}

#[cfg(test)]
mod tests {
    #[test]
    fn solid_angle_table_matches_texel_solid_angle() {
        for n in [1, 2, 5, 64] {
            let table = super::solid_angle_table(n);
            let mut sum = 0.0f64;
            for y in 0..n {
                for x in 0..n {
                    assert_eq!(table[y * n + x], super::texel_solid_angle(n, x, y));
                    sum += table[y * n + x] as f64;
                }
            }
            assert!(
                (sum - 4.0 * std::f64::consts::PI / 6.0).abs() < 1e-5,
                "{n}: {sum}"
            );
        }
    }
}
