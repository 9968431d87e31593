//! Equirectangular (lat-long) panoramas, 2:1: centre +Z, +X a quarter turn to the right, top row up.

#![warn(missing_docs)]

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
#[inline(always)]
pub fn uv_to_dir(u: f32, v: f32) -> Vec3 {
    let phi = (u - 0.5) * TAU;
    let theta = (0.5 - v) * PI;
    let (sp, cp) = sin_cos(phi);
    let (st, ct) = sin_cos(theta);
    Vec3::new(ct * sp, st, ct * cp)
}

/// Solid angle per unit texel area at continuous texel row coordinate `y` of a w x h
/// panorama (the same along a row): the weight of a point when a texel is cut into sub-cells.
#[inline(always)]
pub(crate) fn texel_density(w: usize, h: usize, y: f32) -> f32 {
    let (iw, ih) = (1.0 / w as f32, 1.0 / h as f32);
    let lat = (0.5 - y * ih) * PI;
    TAU * iw * PI * ih * lat.cos().max(0.0)
}

/// A w x h panorama's texel weights, one per row: `texel_density` at the row's centre.
pub(crate) fn row_weights(w: usize, h: usize) -> Vec<f32> {
    (0..h)
        .map(|y| texel_density(w, h, y as f32 + 0.5))
        .collect()
}

/// Solid angle of one texel of row `y` of a w x h panorama: its longitude span times the
/// difference of the sines of its edges' latitudes.
pub(crate) fn texel_solid_angle(w: usize, h: usize, y: usize) -> f64 {
    use std::f64::consts::PI;
    let lat = |v: usize| (0.5 - v as f64 / h as f64) * PI;
    2.0 * PI / w as f64 * (lat(y).sin() - lat(y + 1).sin())
}

/// The angle one texel of a panorama `h` texels high spans, everywhere: a row's height (its
/// width is less, away from the equator).
#[inline]
pub(crate) fn footprint(h: usize) -> f32 {
    PI * (1.0 / h as f32)
}

/// (sin a, cos a) within 2e-7 of libm's for |a| <= pi (panorama angles), inlined and
/// branch-free: two libm calls per texel were most of the cost of writing a panorama.
/// Angles beyond a right angle fold back (sin(pi - a) = sin a, cos(pi - a) = -cos a), then
/// Taylor series to the 11th and 12th power (truncation error under 6e-8 at pi/2).
#[inline(always)]
pub(crate) fn sin_cos(a: f32) -> (f32, f32) {
    use std::f32::consts::FRAC_PI_2;
    let fold = a.abs() > FRAC_PI_2;
    let x = if fold { PI.copysign(a) - a } else { a };
    let z = x * x;
    let s = x
        * (1.0
            + z * (-1.0 / 6.0
                + z * (1.0 / 120.0
                    + z * (-1.0 / 5040.0 + z * (1.0 / 362_880.0 + z * (-1.0 / 39_916_800.0))))));
    let c = 1.0
        + z * (-0.5
            + z * (1.0 / 24.0
                + z * (-1.0 / 720.0
                    + z * (1.0 / 40_320.0
                        + z * (-1.0 / 3_628_800.0 + z * (1.0 / 479_001_600.0))))));
    (s, if fold { -c } else { c })
}

#[cfg(test)]
mod tests {
    #[test]
    fn sin_cos_matches_libm() {
        let mut worst = 0.0f32;
        for i in -200_000..=200_000 {
            let a = i as f32 / 200_000.0 * std::f32::consts::PI;
            let (s, c) = super::sin_cos(a);
            worst = worst.max((s - a.sin()).abs()).max((c - a.cos()).abs());
        }
        assert!(worst < 2e-7, "{worst}");
        assert_eq!(super::sin_cos(0.0), (0.0, 1.0));
    }

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
