//! Angular maps (Debevec's light-probe format): centre -Z, rim +Z, the radius proportional to
//! the angle from -Z, image right +X, up +Y.

#![warn(missing_docs)]

use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// (s, t) of a unit direction, t pointing up (row 0 is t = 1).
#[inline]
pub fn dir_to_st(d: Vec3) -> Vec2 {
    let len = (d.x * d.x + d.y * d.y).sqrt();
    // acos(-z) as atan2 (inlined, and better conditioned near the centre and the rim).
    let a = super::equirect::atan2(len, -d.z);
    if len <= 1e-12 {
        // -Z (centre) or +Z (any rim point).
        return if d.z < 0.0 {
            Vec2::splat(0.5)
        } else {
            Vec2::new(1.0, 0.5)
        };
    }
    let r = a / PI / len;
    Vec2::new(0.5 + 0.5 * d.x * r, 0.5 + 0.5 * d.y * r)
}

/// Solid angle per unit texel area at continuous texel coordinates (x, y) of a w x h angular
/// map, 0 outside the disc.
#[inline(always)]
pub(crate) fn texel_density(w: usize, h: usize, x: f32, y: f32) -> f32 {
    match super::ball::radius_and_area(w, h, x, y) {
        Some((r, area)) => {
            area * if r < 1e-6 {
                PI * PI
            } else {
                // Angle pi r: sin(pi r) / r times pi per unit of r.
                PI * (PI * r).sin() / r
            }
        }
        None => 0.0,
    }
}

/// The angle one texel of a w x h angular map spans, everywhere: the angle from -Z is pi r,
/// pi per unit radius, across and around.
#[inline]
pub(crate) fn footprint(w: usize) -> f32 {
    TAU * (1.0 / w as f32)
}

/// The direction at (s, t), or None outside the disc.
#[inline]
pub fn st_to_dir(s: f32, t: f32) -> Option<Vec3> {
    let x = 2.0 * s - 1.0;
    let y = 2.0 * t - 1.0;
    let rho = (x * x + y * y).sqrt();
    if rho > 1.0 {
        return None;
    }
    if rho <= 1e-12 {
        return Some(Vec3::NEG_Z);
    }
    let (sa, ca) = super::equirect::sin_cos(rho * PI);
    Some(Vec3::new(sa * x / rho, sa * y / rho, -ca))
}
