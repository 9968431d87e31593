//! The preview camera: a pinhole at distance D from the origin looking at it, with a square
//! image, a vertical field of view and an orbit (yaw about +Y, then pitch towards +Y).
//!
//! Image right is `up x forward`: the camera sees the environment as the cube map's face
//! images show it (cube-map space is the OpenGL/RenderMan table, which reads correctly from
//! inside), so with yaw 180 the "L" on +Z of the demo sky reads as an L. With yaw = pitch = 0
//! the camera sits at (0, 0, D), looks along -Z, and image right is -X, image up +Y.

#![warn(missing_docs)]

use glam::Vec3;

/// A pinhole camera; screen coordinates are in pixels, x right, y down, pixel (i, j) covering
/// [i, i + 1) x [j, j + 1) so its centre is (i + 0.5, j + 0.5).
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// The pinhole's position, at the orbit distance from the origin.
    pub eye: Vec3,
    /// Unit view direction (towards the origin).
    pub forward: Vec3,
    /// Unit image-right direction.
    pub right: Vec3,
    /// Unit image-up direction.
    pub up: Vec3,
    /// tan(fov / 2), vertical.
    pub tan_half: f32,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
}

impl Camera {
    /// Camera at distance `distance` orbiting the origin: `yaw` (degrees) turns it about +Y
    /// (90 puts it on +X), `pitch` (degrees) raises it towards +Y (90 looks straight down).
    pub fn new(
        distance: f32,
        fov_deg: f32,
        yaw_deg: f32,
        pitch_deg: f32,
        width: usize,
        height: usize,
    ) -> Camera {
        let (sy, cy) = yaw_deg.to_radians().sin_cos();
        let (sp, cp) = pitch_deg.to_radians().sin_cos();
        let dir = Vec3::new(cp * sy, sp, cp * cy);
        // The derivative of the orbit position by pitch: +Y at pitch 0, never parallel to dir.
        let up = Vec3::new(-sp * sy, cp, -sp * cy);
        let forward = -dir;
        Camera {
            eye: dir * distance,
            forward,
            right: up.cross(forward),
            up,
            tan_half: (fov_deg.to_radians() * 0.5).tan(),
            width,
            height,
        }
    }

    /// Direction of the ray through screen point (sx, sy): forward plus the image-plane
    /// offset at distance 1 (not normalised).
    #[inline]
    pub(crate) fn ray(&self, sx: f32, sy: f32) -> Vec3 {
        let aspect = self.width as f32 / self.height as f32;
        let x = (2.0 * sx / self.width as f32 - 1.0) * self.tan_half * aspect;
        let y = (1.0 - 2.0 * sy / self.height as f32) * self.tan_half;
        self.forward + self.right * x + self.up * y
    }

    /// Screen position (sx, sy) and depth along `forward` of a world point.
    #[inline]
    pub fn project(&self, p: Vec3) -> (f32, f32, f32) {
        let c = p - self.eye;
        let z = c.dot(self.forward);
        let aspect = self.width as f32 / self.height as f32;
        let x = c.dot(self.right) / z / (self.tan_half * aspect);
        let y = c.dot(self.up) / z / self.tan_half;
        (
            (x + 1.0) * 0.5 * self.width as f32,
            (1.0 - y) * 0.5 * self.height as f32,
            z,
        )
    }
}

/// Sub-pixel sample positions (offsets in [0, 1) from the pixel's corner) for `s` samples per
/// pixel: one sample is the pixel centre; more form a rank-1 lattice, stratified along both
/// axes (each of the s columns and s rows of the pixel holds exactly one sample; for 4 it is a
/// rotated grid like a GPU's 4x MSAA). Deterministic: the same for every pixel and run.
pub fn sample_offsets(s: usize) -> Vec<(f32, f32)> {
    let s = s.max(1);
    if s == 1 {
        return vec![(0.5, 0.5)];
    }
    let gcd = |mut a: usize, mut b: usize| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    // The generator coprime with s closest to s / golden ratio spreads the rows best.
    let target = s as f32 * 0.618_034;
    let g = (1..s)
        .filter(|&g| gcd(g, s) == 1)
        .min_by(|a, b| {
            (*a as f32 - target)
                .abs()
                .total_cmp(&(*b as f32 - target).abs())
        })
        .unwrap_or(1);
    (0..s)
        .map(|k| {
            (
                (k as f32 + 0.5) / s as f32,
                ((k * g) % s) as f32 / s as f32 + 0.5 / s as f32,
            )
        })
        .collect()
}
