//! What every input is sampled through: the `Environment` trait, the interpolation it is asked
//! for, and batches of directions laid out so per-direction maths vectorises.

#![warn(missing_docs)]

use glam::{Vec3, Vec4};

/// How a sample between texels is reconstructed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
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
}

/// Directions per batch: enough to amortise a call, small enough to live on the stack.
pub const BATCH: usize = 128;

/// A batch of directions as separate x, y, z arrays (structure of arrays), so per-direction
/// maths runs four or eight lanes at a time.
#[derive(Clone)]
pub struct Dirs {
    /// The x components; only the first `len` are meaningful.
    pub x: [f32; BATCH],
    /// The y components.
    pub y: [f32; BATCH],
    /// The z components.
    pub z: [f32; BATCH],
    /// How many directions the batch holds, up to [`BATCH`].
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
    /// Direction `i` (below `len`) as a vector.
    #[inline]
    pub fn get(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    /// Whether no more directions fit: time to flush the batch.
    pub(crate) fn is_full(&self) -> bool {
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

    /// `src`'s directions turned by `m` (the same arithmetic as `transform`).
    pub(crate) fn transform_from(&mut self, src: &Dirs, m: &glam::Mat3) {
        let n = src.len;
        let (c0, c1, c2) = (m.x_axis, m.y_axis, m.z_axis);
        for i in 0..n {
            let (a, b, c) = (src.x[i], src.y[i], src.z[i]);
            self.x[i] = c0.x * a + c1.x * b + c2.x * c;
            self.y[i] = c0.y * a + c1.y * b + c2.y * c;
            self.z[i] = c0.z * a + c1.z * b + c2.z * c;
        }
        self.len = n;
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
