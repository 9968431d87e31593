//! Order-2 real spherical harmonics (9 coefficients per channel) of a cube map's radiance, and
//! their convolution with the clamped cosine (Ramamoorthi and Hanrahan 2001).

#![warn(missing_docs)]

use crate::cube::{solid_angle_table, texel_dir, CubeMap, Faces};
use glam::{Vec3, Vec4};
use std::f64::consts::PI;

/// The normalisation constants of the real SH basis, in coefficient order.
pub const BASIS: [(&str, i32, i32, f64); 9] = [
    ("0.5 * sqrt(1/pi)", 0, 0, 0.282_094_791_773_878_1),
    ("0.5 * sqrt(3/pi) * y", 1, -1, 0.488_602_511_902_919_9),
    ("0.5 * sqrt(3/pi) * z", 1, 0, 0.488_602_511_902_919_9),
    ("0.5 * sqrt(3/pi) * x", 1, 1, 0.488_602_511_902_919_9),
    ("0.5 * sqrt(15/pi) * x * y", 2, -2, 1.092_548_430_592_079_2),
    ("0.5 * sqrt(15/pi) * y * z", 2, -1, 1.092_548_430_592_079_2),
    (
        "0.25 * sqrt(5/pi) * (3 z^2 - 1)",
        2,
        0,
        0.315_391_565_252_520_05,
    ),
    ("0.5 * sqrt(15/pi) * x * z", 2, 1, 1.092_548_430_592_079_2),
    (
        "0.25 * sqrt(15/pi) * (x^2 - y^2)",
        2,
        2,
        0.546_274_215_296_039_6,
    ),
];

/// The clamped-cosine convolution factors per band: pi, 2pi/3, pi/4.
pub(crate) const COSINE_BAND: [f64; 3] = [PI, 2.0 * PI / 3.0, PI / 4.0];

/// The 9 basis functions at unit direction `d`, in coefficient order.
pub fn basis(d: Vec3) -> [f64; 9] {
    let (x, y, z) = (d.x as f64, d.y as f64, d.z as f64);
    let k = |i: usize| BASIS[i].3;
    [
        k(0),
        k(1) * y,
        k(2) * z,
        k(3) * x,
        k(4) * x * y,
        k(5) * y * z,
        k(6) * (3.0 * z * z - 1.0),
        k(7) * x * z,
        k(8) * (x * x - y * y),
    ]
}

/// Projects level 0 of the cube map (RGB) onto the basis with exact texel solid angles.
/// Accumulates in f64 in a fixed order, so results do not depend on threads.
pub fn project(cube: &CubeMap) -> [[f64; 3]; 9] {
    project_faces(&cube.levels[0])
}

/// [`project`] for six faces: rows in parallel, each row's sums in f64 and the rows' added
/// in order (the same result on any thread count).
pub(crate) fn project_faces(faces: &Faces) -> [[f64; 3]; 9] {
    use rayon::prelude::*;
    let n = faces[0].width;
    let inv = 1.0 / n as f32;
    let angles = solid_angle_table(n);
    let rows: Vec<[[f64; 3]; 9]> = (0..6 * n)
        .into_par_iter()
        .map(|fy| {
            let (face, y) = (fy / n, fy % n);
            let mut c = [[0.0f64; 3]; 9];
            for x in 0..n {
                let d = texel_dir(face, x, y, inv);
                let v = faces[face].get(x, y);
                let sa = angles[y * n + x] as f64;
                for (i, yi) in basis(d).iter().enumerate() {
                    let w = yi * sa;
                    c[i][0] += v.x as f64 * w;
                    c[i][1] += v.y as f64 * w;
                    c[i][2] += v.z as f64 * w;
                }
            }
            c
        })
        .collect();
    let mut c = [[0.0f64; 3]; 9];
    for r in &rows {
        for (ci, ri) in c.iter_mut().zip(r) {
            for (a, b) in ci.iter_mut().zip(ri) {
                *a += b;
            }
        }
    }
    c
}

/// Band of coefficient i.
pub fn band(i: usize) -> usize {
    BASIS[i].1 as usize
}

/// Coefficients of irradiance E(n) = integral of L(l) max(0, n.l) dl: each band times pi,
/// 2pi/3 or pi/4.
pub fn irradiance(radiance: &[[f64; 3]; 9]) -> [[f64; 3]; 9] {
    std::array::from_fn(|i| radiance[i].map(|v| v * COSINE_BAND[band(i)]))
}

/// Coefficients of E(n) / pi, the diffuse light a white Lambertian surface reflects: what
/// shaders multiply by the albedo (the `sh.json` file's, the preview's, Babylon's polynomial's
/// source).
pub fn irradiance_over_pi(radiance: &[[f64; 3]; 9]) -> [[f64; 3]; 9] {
    let e = irradiance(radiance);
    std::array::from_fn(|i| e[i].map(|v| v / PI))
}

/// Evaluates coefficients at a direction.
pub(crate) fn eval(coeffs: &[[f64; 3]; 9], d: Vec3) -> Vec4 {
    let y = basis(d);
    let mut out = [0.0f64; 3];
    for i in 0..9 {
        for c in 0..3 {
            out[c] += coeffs[i][c] * y[i];
        }
    }
    Vec4::new(out[0] as f32, out[1] as f32, out[2] as f32, 1.0)
}
