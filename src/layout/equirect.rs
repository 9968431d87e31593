//! Equirectangular (lat-long) panoramas, 2:1: centre +Z, +X a quarter turn to the right, top row up.

use glam::{Vec2, Vec3};
use std::f32::consts::{PI, TAU};

/// Image coordinates (u, v) in 0..1 of a unit direction, v = 0 the top row.
/// (asin(d.y) is taken as atan2(d.y, |d.xz|), which also tolerates unnormalised input.)
#[inline(always)]
pub fn dir_to_uv(d: Vec3) -> Vec2 {
    let horizontal = (d.x * d.x + d.z * d.z).sqrt();
    Vec2::new(
        0.5 + atan2(d.x, d.z) / TAU,
        0.5 - atan2(d.y, horizontal) / PI,
    )
}

/// atan2 within 6e-7 rad (2 ulp near pi) of libm's, inlined: the libm call dominated panorama lookups.
/// Octant reduction to [0, 1], then to |t| <= tan(pi/8), then the classic odd polynomial.
/// Every branch is a select, so loops over many directions vectorise.
#[inline(always)]
pub fn atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    let a = if hi > 0.0 { lo / hi } else { 0.0 };
    let big = a > 0.414_213_57;
    let t = if big { (a - 1.0) / (a + 1.0) } else { a };
    let base = if big { FRAC_PI_4 } else { 0.0 };
    let z = t * t;
    let p =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * t
            + t;
    let r = base + p;
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    if y < 0.0 {
        -r
    } else {
        r
    }
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

#[cfg(test)]
mod tests {
    #[test]
    fn atan2_matches_libm() {
        let mut worst = 0.0f32;
        for i in 0..2000 {
            for j in 0..50 {
                let a = i as f32 / 2000.0 * std::f32::consts::TAU;
                let r = 0.01 + j as f32 * 0.37;
                let (y, x) = (a.sin() * r, a.cos() * r);
                worst = worst.max((super::atan2(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 6e-7, "{worst}");
        assert_eq!(super::atan2(0.0, 1.0), 0.0);
        assert!((super::atan2(1.0, 0.0) - std::f32::consts::FRAC_PI_2).abs() < 1e-7);
        assert!((super::atan2(0.0, -1.0) - std::f32::consts::PI).abs() < 1e-7);
    }
}
