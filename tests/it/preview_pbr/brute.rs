//! The brute-force side: the preview's camera and sphere, an analytic sky (with and without a
//! sun) and the BRDF integrated over it in double precision, by the midpoint rule on grids
//! fine enough that doubling their steps changes no result by 1e-4.

use glam::DVec3;
use std::f64::consts::TAU;

/// The camera of the preview (distance 4, fov 30): eye and direction through the centre of
/// pixel (x, y) of an n x n image (image right is -X).
pub(super) fn pixel_ray(x: usize, y: usize, n: usize) -> (DVec3, DVec3) {
    let th = (15f64).to_radians().tan();
    let sx = (2.0 * (x as f64 + 0.5) / n as f64 - 1.0) * th;
    let sy = (1.0 - 2.0 * (y as f64 + 0.5) / n as f64) * th;
    (DVec3::new(0.0, 0.0, 4.0), DVec3::new(-sx, sy, -1.0))
}

/// Nearest hit of a ray with the unit sphere.
pub(super) fn hit_sphere(eye: DVec3, dir: DVec3) -> Option<DVec3> {
    let (a, b, c) = (dir.dot(dir), eye.dot(dir), eye.dot(eye) - 1.0);
    let disc = b * b - a * c;
    (disc >= 0.0).then(|| eye + dir * ((-b - disc.sqrt()) / a))
}

/// The pixel whose centre sees the sphere nearest normal `n` (facing the camera).
pub(super) fn pixel_of(n: DVec3, size: usize) -> (usize, usize) {
    let d = n - DVec3::new(0.0, 0.0, 4.0);
    let th = (15f64).to_radians().tan();
    let sx = -d.x / -d.z / th;
    let sy = d.y / -d.z / th;
    let px = ((sx + 1.0) / 2.0 * size as f64).floor() as usize;
    let py = ((1.0 - sy) / 2.0 * size as f64).floor() as usize;
    (px.min(size - 1), py.min(size - 1))
}

pub(super) fn sun() -> DVec3 {
    DVec3::new(0.45, 0.5, 0.74).normalize()
}

/// A sky that varies with direction (all channels positive), smooth.
pub(super) fn sky(d: DVec3) -> DVec3 {
    DVec3::new(
        0.35 + 0.25 * d.y,
        0.45 + 0.2 * d.y + 0.05 * d.x,
        0.6 + 0.25 * d.y - 0.1 * d.z,
    )
}

/// The sky and a soft sun of peak 20, Gaussian in angle with sigma 0.1 rad (5.7 degrees),
/// 40 times the sky's brightness.
pub(super) fn sky_sun(d: DVec3) -> DVec3 {
    let c = d.dot(sun());
    sky(d) + DVec3::new(1.0, 0.9, 0.75) * 20.0 * ((c - 1.0) / 0.01).exp()
}

/// An environment as the tests integrate it.
pub(super) type Env = fn(DVec3) -> DVec3;

/// An orthonormal frame with `n` as its third axis.
pub(super) fn frame(n: DVec3) -> (DVec3, DVec3) {
    let t = if n.z.abs() < 0.9 { DVec3::Z } else { DVec3::X };
    let t = t.cross(n).normalize();
    (t, n.cross(t))
}

pub(super) fn v_smith(nv: f64, nl: f64, a: f64) -> f64 {
    let a2 = a * a;
    0.5 / (nl * (nv * nv * (1.0 - a2) + a2).sqrt() + nv * (nl * nl * (1.0 - a2) + a2).sqrt())
}

/// Quadrature steps in t (u = 1 - t^2, the GGX CDF of the half vector's angle) and phi.
pub(super) const STEPS_T: usize = 512;
pub(super) const STEPS_PHI: usize = 256;

/// The half vectors of a GGX lobe of `alpha` about `axis`, midpoint rule in (t, phi) with
/// u = 1 - t^2 (as the LUT samples them): `visit(h, n.h, weight)`, weights summing to 1 over
/// the distribution D(h) n.h.
pub(super) fn ggx_grid(axis: DVec3, alpha: f64, mut visit: impl FnMut(DVec3, f64, f64)) {
    let (tx, ty) = frame(axis);
    let a2m1 = (alpha - 1.0) * (alpha + 1.0);
    let cells = (STEPS_T * STEPS_PHI) as f64;
    for i in 0..STEPS_T {
        let t = (i as f64 + 0.5) / STEPS_T as f64;
        let u = 1.0 - t * t;
        let ct = ((1.0 - u) / (1.0 + a2m1 * u)).sqrt();
        let st = (1.0 - ct * ct).max(0.0).sqrt();
        for j in 0..STEPS_PHI {
            let phi = TAU * (j as f64 + 0.5) / STEPS_PHI as f64;
            let h = tx * (st * phi.cos()) + ty * (st * phi.sin()) + axis * ct;
            visit(h, ct, 2.0 * t / cells);
        }
    }
}

/// The specular integral of the GGX BRDF over the environment at normal `n`, view `v`, as two
/// terms of F0: (integral of L (1 - Fc) f n.l, integral of L Fc f n.l), and the same with
/// L = 1 (the exact A and B of the DFG), per channel.
pub(super) fn brute_specular(sky: Env, n: DVec3, v: DVec3, alpha: f64) -> (DVec3, DVec3, f64, f64) {
    let nv = n.dot(v);
    let (mut sa, mut sb, mut a, mut b) = (DVec3::ZERO, DVec3::ZERO, 0.0, 0.0);
    ggx_grid(n, alpha, |h, nh, w| {
        let vh = v.dot(h);
        let l = 2.0 * vh * h - v;
        let nl = n.dot(l);
        if vh <= 0.0 || nl <= 0.0 {
            return;
        }
        // D cancels: D V F n.l / (D n.h / (4 v.h)).
        let g = w * 4.0 * v_smith(nv, nl, alpha) * nl * vh / nh;
        let fc = (1.0 - vh).powi(5);
        let env = sky(l);
        sa += env * ((1.0 - fc) * g);
        sb += env * (fc * g);
        a += (1.0 - fc) * g;
        b += fc * g;
    });
    (sa, sb, a, b)
}

/// The split-sum's prefiltered radiance, exactly: the environment weighed by D(h) n.l about
/// `r` with n = v = r (what a GGX chain level holds).
pub(super) fn exact_prefiltered(sky: Env, r: DVec3, alpha: f64) -> DVec3 {
    let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
    ggx_grid(r, alpha, |h, nh, w| {
        let l = 2.0 * nh * h - r;
        let nl = r.dot(l);
        if nl <= 0.0 {
            return;
        }
        sum += sky(l) * (w * nl);
        weight += w * nl;
    });
    sum / weight
}

/// Irradiance over pi at normal `n`: the mean of the environment over cosine-distributed
/// directions (midpoint rule in (u, phi), u = sin^2 of the angle to n).
pub(super) fn brute_irradiance_over_pi(sky: Env, n: DVec3) -> DVec3 {
    let (tx, ty) = frame(n);
    let steps = 256;
    let mut sum = DVec3::ZERO;
    for i in 0..steps {
        let u = (i as f64 + 0.5) / steps as f64;
        let (s, c) = (u.sqrt(), (1.0 - u).sqrt());
        for j in 0..steps {
            let phi = TAU * (j as f64 + 0.5) / steps as f64;
            sum += sky(tx * (s * phi.cos()) + ty * (s * phi.sin()) + n * c);
        }
    }
    sum / (steps * steps) as f64
}
