//! Equirectangular (lat-long) panoramas, 2:1: centre +Z, +X a quarter turn to the right, top row up.

use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Image coordinates (u, v) in 0..1 of a unit direction, v = 0 the top row.
#[inline]
pub fn dir_to_uv(d: Vec3) -> Vec2 {
    Vec2::new(
        0.5 + d.x.atan2(d.z) / TAU,
        0.5 - d.y.clamp(-1.0, 1.0).asin() / PI,
    )
}

/// The unit direction at image coordinates (u, v).
#[inline]
pub fn uv_to_dir(u: f32, v: f32) -> Vec3 {
    let phi = (u - 0.5) * TAU;
    let theta = (0.5 - v) * PI;
    let (sp, cp) = phi.sin_cos();
    let (st, ct) = theta.sin_cos();
    Vec3::new(ct * sp, st, ct * cp)
}
