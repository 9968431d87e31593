//! Sphere maps (mirror balls): the ball photographed by a camera looking along +Z, image right
//! +X, up +Y. The OpenGL sphere-map formula with the eye looking along +Z: the centre shows -Z,
//! the rim +Z.

#![warn(missing_docs)]

use glam::{Vec2, Vec3};

/// (s, t) of a unit direction, t pointing up (row 0 is t = 1).
#[inline]
pub fn dir_to_st(r: Vec3) -> Vec2 {
    let m = 2.0 * (r.x * r.x + r.y * r.y + (1.0 - r.z) * (1.0 - r.z)).sqrt();
    if m <= 1e-12 {
        // Exactly +Z: the whole rim; any rim point will do.
        return Vec2::new(1.0, 0.5);
    }
    Vec2::new(0.5 + r.x / m, 0.5 + r.y / m)
}

/// Solid angle per unit texel area at continuous texel coordinates (x, y) of a w x h mirror
/// ball, 0 outside the disc.
#[inline(always)]
pub(crate) fn texel_density(w: usize, h: usize, x: f32, y: f32) -> f32 {
    match super::ball::radius_and_area(w, h, x, y) {
        // A mirror ball is equal-area: the angle from -Z is 2 asin r.
        Some((_, area)) => area * 4.0,
        None => 0.0,
    }
}

/// The angle one texel of a w x h mirror ball spans at continuous texel coordinates (x, y):
/// the angle from -Z is 2 asin r, 2 / sqrt(1 - r^2) across the rings, more than the
/// 2 sqrt(1 - r^2) around them; taken at most [`super::ball::rim`] out, for the texels the
/// rim cuts.
#[inline(always)]
/// `iw`, `ih`: 1 / w and 1 / h, worked out once per image by the caller.
pub(crate) fn footprint(iw: f32, ih: f32, x: f32, y: f32) -> f32 {
    // The rim of super::ball::rim(w).
    let rim = 1.0 - iw;
    let (sx, sy) = (2.0 * x * iw - 1.0, 2.0 * y * ih - 1.0);
    let rr = (sx * sx + sy * sy).min(rim * rim);
    4.0 * iw / (1.0 - rr).sqrt()
}

/// The reflected direction seen at (s, t), or None outside the ball.
#[inline]
pub fn st_to_dir(s: f32, t: f32) -> Option<Vec3> {
    let x = 2.0 * s - 1.0;
    let y = 2.0 * t - 1.0;
    let rr = x * x + y * y;
    if rr > 1.0 {
        return None;
    }
    // Ball normal facing the camera, reflecting the view ray (0, 0, 1).
    let nz = -(1.0 - rr).sqrt();
    Some(Vec3::new(-2.0 * nz * x, -2.0 * nz * y, 1.0 - 2.0 * nz * nz))
}
