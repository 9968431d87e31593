//! Environments defined as functions of direction: exact ground truth for tests, and the
//! source of the project's own fixtures.

#![warn(missing_docs)]

use glam::{Vec3, Vec4};

/// Colour from direction (each axis and its sign visible) plus a small bright marker above and
/// to the right of +Z's centre, which no rotation-free mirroring can keep in place.
pub fn marker(d: Vec3) -> Vec4 {
    let m = Vec3::new(0.3, 0.3, 1.0).normalize();
    if d.dot(m) > 0.995 {
        Vec4::new(4.0, 4.0, 4.0, 1.0)
    } else {
        (d * 0.5 + Vec3::splat(0.5)).extend(1.0)
    }
}

/// A smooth environment (no edges), for error bounds that do not depend on where edges fall.
pub fn smooth(d: Vec3) -> Vec4 {
    Vec4::new(
        0.5 + 0.4 * d.x + 0.1 * d.y * d.z,
        0.5 + 0.4 * d.y - 0.1 * d.x * d.z,
        0.5 + 0.4 * d.z + 0.1 * d.x * d.y,
        1.0,
    )
}

/// The bundled demo sky: a direction-tinted sphere with grid lines every 15 degrees, coloured
/// dots on the axes (+X red, +Y green, +Z blue, -X cyan, -Y magenta, -Z yellow), an "L" made
/// of dots on +Z that reads correctly only when handedness is kept, and an HDR sun.
pub fn demo_sky(d: Vec3) -> Vec4 {
    let d = d.normalize();
    let lat = d.y.clamp(-1.0, 1.0).asin().to_degrees();
    let lon = d.x.atan2(d.z).to_degrees();
    let near = |v: f32, step: f32, w: f32| {
        let r = (v / step).round() * step;
        (v - r).abs() < w
    };
    let mut c = (d * 0.35 + Vec3::splat(0.45)) * if d.y > 0.0 { 1.0 } else { 0.6 };
    if near(lat, 15.0, 0.4) || (lat.abs() < 76.0 && near(lon, 15.0, 0.4 / lat.to_radians().cos())) {
        c *= 0.35;
    }
    let dots = [
        (Vec3::X, Vec3::new(1.0, 0.1, 0.1)),
        (Vec3::Y, Vec3::new(0.1, 1.0, 0.1)),
        (Vec3::Z, Vec3::new(0.1, 0.2, 1.0)),
        (Vec3::NEG_X, Vec3::new(0.1, 1.0, 1.0)),
        (Vec3::NEG_Y, Vec3::new(1.0, 0.1, 1.0)),
        (Vec3::NEG_Z, Vec3::new(1.0, 1.0, 0.1)),
    ];
    for (axis, colour) in dots {
        if d.dot(axis) > 0.9985 {
            c = colour;
        }
    }
    // An "L" on +Z: a bar going up and a foot going right (towards +X).
    for k in 1..=4 {
        let up = Vec3::new(-0.15, -0.12 + 0.07 * k as f32, 1.0).normalize();
        let foot = Vec3::new(-0.15 + 0.07 * k as f32, -0.12, 1.0).normalize();
        if d.dot(up) > 0.9994 || d.dot(foot) > 0.9994 {
            c = Vec3::splat(1.0);
        }
    }
    let sun = Vec3::new(0.5, 0.55, -0.67).normalize();
    if d.dot(sun) > 0.9995 {
        c = Vec3::new(60.0, 55.0, 45.0);
    }
    c.extend(1.0)
}
