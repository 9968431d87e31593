//! The unit sphere at the origin: ray intersection and texture coordinates for per-fragment
//! shading, and the tessellated mesh (latitude bands x longitude segments) for per-vertex
//! shading.
//!
//! Texture coordinates are the equirect layout's ([`crate::layout::equirect`]), so a decal or
//! control map painted as a panorama wraps the sphere as that panorama wraps the environment:
//! u = 0.5 + atan2(x, z) / 2pi goes around +Y, +Z (the default camera's side) at u = 0.5, +X at
//! 0.75, the seam (u = 0 / 1) at the back, -Z; v = acos(y) / pi runs from the north pole (+Y,
//! v = 0) to the south pole (v = 1). Row 0 of a decal or control map is v = 0.

#![warn(missing_docs)]

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// The nearest point where the ray from `origin` (outside the sphere) along `dir` (any
/// length) meets the unit sphere. Computed from the ray's closest approach to the centre
/// (Haines et al., Ray Tracing Gems ch. 7), so a distant camera keeps full precision.
#[inline]
pub fn hit(origin: Vec3, dir: Vec3) -> Option<Vec3> {
    let dn = dir.normalize();
    let b = origin.dot(dn);
    if b >= 0.0 {
        return None;
    }
    // The point of the line nearest the centre, and its squared distance from it.
    let w = origin - dn * b;
    let h2 = w.length_squared();
    if h2 > 1.0 {
        return None;
    }
    Some(w - dn * (1.0 - h2).sqrt())
}

/// Texture coordinates of a point on (or radially projected onto) the sphere: those of its
/// direction in an equirect panorama (libm's atan2 and acos, for the reference renderer).
#[inline]
pub fn uv(p: Vec3) -> Vec2 {
    let u = 0.5 + p.x.atan2(p.z) / (2.0 * PI);
    let r = p.length();
    let v = (p.y / r).clamp(-1.0, 1.0).acos() / PI;
    Vec2::new(u.min(1.0 - f32::EPSILON * 0.5), v)
}

/// A triangle mesh approximating the sphere, vertices on the sphere (so its normal there is
/// the position), with texture coordinates seamed at u = 0 / 1 (at -Z, where atan2 jumps) like
/// a real mesh.
#[derive(Clone, Debug)]
pub(crate) struct Mesh {
    /// Vertex positions, which are also the normals.
    pub positions: Vec<Vec3>,
    /// Texture coordinates, one per vertex.
    pub uvs: Vec<Vec2>,
    /// Counter-clockwise seen from outside, as indices into the vertices.
    pub triangles: Vec<[u32; 3]>,
}

/// `bands` latitude bands and 2 x `bands` longitude segments: each band-segment cell is two
/// triangles, one at the poles (where the cell's top or bottom edge is a point). Column j is
/// at longitude 2pi j / 2n - pi from +Z (u = j / 2n): columns 0 and 2n both lie on the seam.
pub(crate) fn tessellate(bands: usize) -> Mesh {
    let n = bands.max(2);
    let m = 2 * n;
    let cols = m + 1;
    let mut positions = Vec::with_capacity((n + 1) * cols);
    let mut uvs = Vec::with_capacity((n + 1) * cols);
    for i in 0..=n {
        let theta = PI * i as f32 / n as f32;
        let (st, ct) = theta.sin_cos();
        for j in 0..=m {
            let phi = 2.0 * PI * j as f32 / m as f32 - PI;
            let (sp, cp) = phi.sin_cos();
            let p = if i == 0 {
                Vec3::Y
            } else if i == n {
                Vec3::NEG_Y
            } else {
                Vec3::new(st * sp, ct, st * cp)
            };
            positions.push(p);
            // A pole vertex belongs to one cell: give it that cell's middle u.
            let u = if (i == 0 || i == n) && j < m {
                (j as f32 + 0.5) / m as f32
            } else {
                j as f32 / m as f32
            };
            uvs.push(Vec2::new(u, i as f32 / n as f32));
        }
    }
    let idx = |i: usize, j: usize| (i * cols + j) as u32;
    let mut triangles = Vec::with_capacity(2 * n * m);
    for i in 0..n {
        for j in 0..m {
            let (a, b, c, d) = (idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1));
            if i == 0 {
                triangles.push([a, c, d]);
            } else if i == n - 1 {
                triangles.push([a, c, b]);
            } else {
                triangles.push([a, c, d]);
                triangles.push([a, d, b]);
            }
        }
    }
    Mesh {
        positions,
        uvs,
        triangles,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_is_the_panoramas() {
        assert!((uv(Vec3::Z) - Vec2::new(0.5, 0.5)).length() < 1e-6);
        assert!((uv(Vec3::X).x - 0.75).abs() < 1e-6);
        assert!((uv(Vec3::NEG_X).x - 0.25).abs() < 1e-6);
        for i in 0..40 {
            for j in 1..20 {
                let (lon, lat) = (i as f32 / 40.0 * 6.2, j as f32 / 20.0 * 3.0 - 1.5);
                let p = Vec3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos());
                let want = crate::layout::equirect::dir_to_uv(p);
                assert!((uv(p) - want).length() < 1e-5, "{p}: {} vs {want}", uv(p));
            }
        }
    }

    #[test]
    fn the_mesh_agrees_with_uv_and_seams_at_the_back() {
        let n = 6;
        let mesh = tessellate(n);
        let cols = 2 * n + 1;
        for (k, (&p, &t)) in mesh.positions.iter().zip(&mesh.uvs).enumerate() {
            let (i, j) = (k / cols, k % cols);
            assert!((p.length() - 1.0).abs() < 1e-6);
            assert!((t.y - i as f32 / n as f32).abs() < 1e-6);
            if i == 0 || i == n {
                continue; // a pole: u of its cell
            }
            if j == 0 || j == cols - 1 {
                // The seam: -Z's meridian, u = 0 on one side, 1 on the other.
                assert!(p.x.abs() < 1e-6 && p.z < 0.0, "{p}");
                assert_eq!(t.x, if j == 0 { 0.0 } else { 1.0 });
            } else {
                assert!((uv(p).x - t.x).abs() < 1e-5, "{p}: {} vs {}", uv(p).x, t.x);
            }
        }
    }
}
