//! Octahedral maps, square: the sphere pushed onto the octahedron |x| + |y| + |z| = 1, its upper
//! half (+Y) flattened into the diamond inside the square, its lower half folded out over the
//! diamond's edges into the four corners.
//!
//! The encoding is Cigolle et al. 2014 ("A Survey of Efficient Representations for Independent
//! Unit Vectors", as Blender's EEVEE and many engines' probes use it) with its centre axis +Z
//! renamed to our up axis +Y (Blender's up is +Z: its centre is up too): p = (d.x, d.z) / (|d.x| + |d.y| + |d.z|); below the horizon
//! (d.y < 0) p becomes (1 - |p.z|, 1 - |p.x|) * sign(p), sign(0) = +1. Then u = (p.x + 1) / 2,
//! v = (p.z + 1) / 2, row 0 at v = 0. So the centre is +Y (up), the edges' midpoints are the
//! horizon's +X (right), +Z (bottom), -X (left), -Z (top), the corners all -Y; the upper half
//! reads like the +Y cube face (x = sc, z = tc): the sky seen from inside, not mirrored. Up at
//! the centre keeps a probe's sky, where most light comes from, in one unfolded piece.
//!
//! Every texel shows part of the sphere. Each edge meets itself mirrored about its midpoint
//! (the texel past column w - 1 at row y is column w - 1 at row h - 1 - y), which bilinear and
//! bicubic lookups follow.

#![warn(missing_docs)]

use glam::{Vec2, Vec3};

/// Image coordinates (u, v) in 0..1 of a direction (any length), v = 0 the top row. Every
/// branch is a select, so loops over many directions vectorise.
#[inline(always)]
pub fn dir_to_uv(d: Vec3) -> Vec2 {
    let l1 = d.x.abs() + d.y.abs() + d.z.abs();
    let inv = if l1 > 0.0 { 1.0 / l1 } else { 0.0 };
    let (px, pz) = (d.x * inv, d.z * inv);
    let sx = if px >= 0.0 { 1.0 } else { -1.0 };
    let sz = if pz >= 0.0 { 1.0 } else { -1.0 };
    let below = d.y < 0.0;
    let qx = if below { (1.0 - pz.abs()) * sx } else { px };
    let qz = if below { (1.0 - px.abs()) * sz } else { pz };
    Vec2::new(0.5 + 0.5 * qx, 0.5 + 0.5 * qz)
}

/// The unit direction at image coordinates (u, v).
#[inline]
pub fn uv_to_dir(u: f32, v: f32) -> Vec3 {
    let p = octahedron_point(2.0 * u - 1.0, 2.0 * v - 1.0);
    p / p.length()
}

/// The point of the octahedron |x| + |y| + |z| = 1 at square coordinates (a, b) in -1..1
/// (a = 2u - 1, b = 2v - 1): (a, 1 - |a| - |b|, b), each corner triangle (|a| + |b| > 1)
/// folded back under the diamond's edge it lies beyond.
#[inline]
pub(crate) fn octahedron_point(a: f32, b: f32) -> Vec3 {
    let y = 1.0 - a.abs() - b.abs();
    let t = (-y).max(0.0);
    let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    Vec3::new(a - t * sign(a), y, b - t * sign(b))
}

/// Solid angle per unit area of the square's (a, b) at a point: |P . (dP/da x dP/db)| / |P|^3
/// for its octahedron point P, and the triple product is 1 on every face, folded or not. So
/// 1 / |P|^3: 1 at the six vertices, 3 sqrt 3 at the faces' centres.
#[inline]
pub(crate) fn density(a: f32, b: f32) -> f32 {
    let p = octahedron_point(a, b);
    let r2 = p.length_squared();
    1.0 / (r2 * r2.sqrt())
}

/// The largest angle per unit of (a, b) at a point: the larger singular value of the map from
/// the square to directions. 1 at the centre, 3 at most (at the faces' centres).
#[inline]
pub(crate) fn stretch(a: f32, b: f32) -> f32 {
    let p = octahedron_point(a, b);
    let sa = if a >= 0.0 { 1.0 } else { -1.0 };
    let sb = if b >= 0.0 { 1.0 } else { -1.0 };
    // dP/da and dP/db of the octahedron point, inside the diamond or in a folded corner.
    let (da, db) = if a.abs() + b.abs() <= 1.0 {
        (Vec3::new(1.0, -sa, 0.0), Vec3::new(0.0, -sb, 1.0))
    } else {
        (Vec3::new(0.0, -sa, -sa * sb), Vec3::new(-sa * sb, -sb, 0.0))
    };
    // Their parts across the direction, per unit of (a, b), and the Gram matrix's larger
    // eigenvalue.
    let len = p.length();
    let d = p / len;
    let ta = (da - d * d.dot(da)) / len;
    let tb = (db - d * d.dot(db)) / len;
    let (g11, g22, g12) = (ta.dot(ta), tb.dot(tb), ta.dot(tb));
    let half = 0.5 * (g11 + g22);
    let diff = 0.5 * (g11 - g22);
    (half + (diff * diff + g12 * g12).sqrt()).sqrt()
}

/// Solid angle per unit texel area at continuous texel coordinates (x, y) of a w x h
/// octahedral map (`density` scaled to texels).
#[inline(always)]
pub(crate) fn texel_density(w: usize, h: usize, x: f32, y: f32) -> f32 {
    let (iw, ih) = (1.0 / w as f32, 1.0 / h as f32);
    let (a, b) = (2.0 * x * iw - 1.0, 2.0 * y * ih - 1.0);
    4.0 * iw * ih * density(a, b)
}

/// The angle one texel of a w x h octahedral map spans at continuous texel coordinates
/// (x, y): `stretch` times the texel's size in units of (a, b).
#[inline(always)]
/// `iw`, `ih`: 1 / w and 1 / h, worked out once per image by the caller (a division per
/// texel cost 15% of an octahedral conversion on 2 cores).
pub(crate) fn footprint(iw: f32, ih: f32, x: f32, y: f32) -> f32 {
    let (a, b) = (2.0 * x * iw - 1.0, 2.0 * y * ih - 1.0);
    2.0 * iw * stretch(a, b)
}

/// The exact solid angle of texel (x, y) of a w x h octahedral map. The texel is cut where the
/// map folds (the axes and the diamond's edges); each piece is a planar polygon on one face of
/// the octahedron, whose solid angle is a sum of triangles' (Van Oosterom and Strackee).
pub(crate) fn texel_solid_angle(w: usize, h: usize, x: usize, y: usize) -> f64 {
    let at = |i: usize, n: usize| 2.0 * i as f64 / n as f64 - 1.0;
    let (a0, a1, b0, b1) = (at(x, w), at(x + 1, w), at(y, h), at(y + 1, h));
    let split = |lo: f64, hi: f64| {
        if lo < 0.0 && hi > 0.0 {
            [(lo, 0.0), (0.0, hi)]
        } else {
            [(lo, hi), (hi, hi)]
        }
    };
    let mut total = 0.0;
    for (alo, ahi) in split(a0, a1) {
        for (blo, bhi) in split(b0, b1) {
            if ahi <= alo || bhi <= blo {
                continue;
            }
            // One quadrant: |a| + |b| = sa a + sb b there.
            let sa = if alo + ahi >= 0.0 { 1.0 } else { -1.0 };
            let sb = if blo + bhi >= 0.0 { 1.0 } else { -1.0 };
            let rect = Poly::rect(alo, ahi, blo, bhi);
            let inside = rect.clip(|[a, b]| 1.0 - sa * a - sb * b);
            let folded = rect.clip(|[a, b]| sa * a + sb * b - 1.0);
            total += inside.solid_angle() + folded.solid_angle();
        }
    }
    total
}

/// A convex polygon of the square, at most 8 vertices (a rectangle cut by one line has 5).
#[derive(Clone, Copy)]
struct Poly {
    v: [[f64; 2]; 8],
    n: usize,
}

impl Poly {
    fn rect(a0: f64, a1: f64, b0: f64, b1: f64) -> Poly {
        let mut v = [[0.0; 2]; 8];
        v[..4].copy_from_slice(&[[a0, b0], [a1, b0], [a1, b1], [a0, b1]]);
        Poly { v, n: 4 }
    }

    /// The part where the affine `f` is >= 0 (Sutherland-Hodgman against one line).
    fn clip(&self, f: impl Fn([f64; 2]) -> f64) -> Poly {
        let mut out = Poly {
            v: [[0.0; 2]; 8],
            n: 0,
        };
        for i in 0..self.n {
            let (p, q) = (self.v[i], self.v[(i + 1) % self.n]);
            let (fp, fq) = (f(p), f(q));
            if fp >= 0.0 {
                out.push(p);
            }
            if (fp >= 0.0) != (fq >= 0.0) {
                let t = fp / (fp - fq);
                out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
            }
        }
        out
    }

    fn push(&mut self, p: [f64; 2]) {
        if self.n < self.v.len() {
            self.v[self.n] = p;
            self.n += 1;
        }
    }

    /// Solid angle seen from the origin of the polygon lifted onto the octahedron (one face,
    /// so the lift is affine and the polygon stays planar and convex): a fan of triangles.
    fn solid_angle(&self) -> f64 {
        if self.n < 3 {
            return 0.0;
        }
        let lift = |[a, b]: [f64; 2]| {
            let y = 1.0 - a.abs() - b.abs();
            let t = (-y).max(0.0);
            [a - t * a.signum(), y, b - t * b.signum()]
        };
        let first = lift(self.v[0]);
        (1..self.n - 1)
            .map(|i| triangle_solid_angle(first, lift(self.v[i]), lift(self.v[i + 1])))
            .sum()
    }
}

/// Solid angle of the triangle (p, q, r) seen from the origin (Van Oosterom and Strackee 1983).
fn triangle_solid_angle(p: [f64; 3], q: [f64; 3], r: [f64; 3]) -> f64 {
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let (lp, lq, lr) = (dot(p, p).sqrt(), dot(q, q).sqrt(), dot(r, r).sqrt());
    let num = dot(p, cross(q, r)).abs();
    let den = lp * lq * lr + dot(p, q) * lr + dot(p, r) * lq + dot(q, r) * lp;
    2.0 * num.atan2(den)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips_and_conventions() {
        let uv = dir_to_uv(Vec3::Y);
        assert_eq!(uv, Vec2::splat(0.5));
        for (d, u, v) in [
            (Vec3::X, 1.0, 0.5),
            (Vec3::NEG_X, 0.0, 0.5),
            (Vec3::Z, 0.5, 1.0),
            (Vec3::NEG_Z, 0.5, 0.0),
            (Vec3::NEG_Y, 1.0, 1.0),
        ] {
            assert_eq!(dir_to_uv(d), Vec2::new(u, v), "{d}");
        }
        for i in 0..64 {
            for j in 0..64 {
                let (u, v) = ((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0);
                let d = uv_to_dir(u, v);
                assert!((d.length() - 1.0).abs() < 1e-6);
                let back = dir_to_uv(d * 3.0);
                assert!(
                    (back - Vec2::new(u, v)).length() < 1e-5,
                    "{u} {v} -> {back}"
                );
            }
        }
    }

    #[test]
    fn edges_meet_themselves_mirrored() {
        for k in 1..16 {
            let s = k as f32 / 16.0;
            let (a, b) = (uv_to_dir(1.0, s), uv_to_dir(1.0, 1.0 - s));
            assert!((a - b).length() < 1e-6, "right edge at {s}");
            let (a, b) = (uv_to_dir(s, 0.0), uv_to_dir(1.0 - s, 0.0));
            assert!((a - b).length() < 1e-6, "top edge at {s}");
        }
    }

    #[test]
    fn solid_angles_sum_to_the_sphere_and_match_the_density() {
        for n in [1, 2, 3, 7, 16, 33] {
            let sum: f64 = (0..n)
                .flat_map(|y| (0..n).map(move |x| texel_solid_angle(n, n, x, y)))
                .sum();
            assert!(
                (sum / (4.0 * std::f64::consts::PI) - 1.0).abs() < 1e-12,
                "{n}: {sum}"
            );
        }
        // A fine midpoint sum of the density agrees with the exact texel.
        let n = 16;
        for (x, y) in [(0, 0), (3, 5), (7, 7), (12, 2)] {
            let k = 64;
            let mut sum = 0.0f64;
            for j in 0..k {
                for i in 0..k {
                    let a = 2.0 * (x as f32 + (i as f32 + 0.5) / k as f32) / n as f32 - 1.0;
                    let b = 2.0 * (y as f32 + (j as f32 + 0.5) / k as f32) / n as f32 - 1.0;
                    sum += density(a, b) as f64;
                }
            }
            let mid = sum / (k * k) as f64 * (2.0 / n as f64).powi(2);
            let exact = texel_solid_angle(n, n, x, y);
            assert!(
                (mid / exact - 1.0).abs() < 1e-4,
                "({x}, {y}): {mid} vs {exact}"
            );
        }
    }

    #[test]
    fn stretch_is_the_largest_rate() {
        assert!((stretch(0.0, 0.0) - 1.0).abs() < 1e-6);
        assert!((stretch(1.0 / 3.0, -1.0 / 3.0) - 3.0).abs() < 1e-5);
        let most = (0..=100)
            .flat_map(|i| (0..=100).map(move |j| (i as f32 / 50.0 - 1.0, j as f32 / 50.0 - 1.0)))
            .map(|(a, b)| stretch(a, b))
            .fold(0.0f32, f32::max);
        assert!(most <= 3.0 + 1e-5, "{most}");
        // Numerical derivatives along many directions never beat it.
        for &(a, b) in &[
            (0.3, 0.2),
            (-0.6, 0.1),
            (0.7, 0.8),
            (-0.9, -0.5),
            (0.33, 0.33),
        ] {
            let s = stretch(a, b);
            let at = |a: f32, b: f32| {
                let p = octahedron_point(a, b);
                p / p.length()
            };
            let mut most = 0.0f32;
            for k in 0..64 {
                let t = k as f32 / 64.0 * std::f32::consts::TAU;
                let h = 1e-3;
                let (da, db) = (t.cos() * h, t.sin() * h);
                most = most.max((at(a + da, b + db) - at(a - da, b - db)).length() / (2.0 * h));
            }
            assert!((most / s - 1.0).abs() < 2e-2, "({a}, {b}): {most} vs {s}");
        }
    }
}
