//! py360convert's `e2p`: a perspective view of a panorama, with its camera and grid (an image
//! plane at z = 1 whose texel grid runs edge to edge, `linspace(-tan(fov/2), tan(fov/2))`,
//! turned by its three rotations) and its sampler (compat's padded panorama), so the view is
//! its view texel for texel. Rows run in parallel; each texel is computed in place.

use crate::compat::{atan2, E2c};
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use rayon::prelude::*;

type Mat = [[f64; 3]; 3];

/// The rotation of `rad` about the unit `axis` (scipy's `Rotation.from_rotvec(rad * axis)`,
/// Rodrigues' formula).
fn rotation(rad: f64, axis: [f64; 3]) -> Mat {
    let (s, c) = rad.sin_cos();
    let [x, y, z] = axis;
    let t = 1.0 - c;
    [
        [c + x * x * t, x * y * t - z * s, x * z * t + y * s],
        [y * x * t + z * s, c + y * y * t, y * z * t - x * s],
        [z * x * t - y * s, z * y * t + x * s, c + z * z * t],
    ]
}

fn mul(a: &Mat, b: &Mat) -> Mat {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

/// The row vector `p` times `m` (py360convert's `out.dot(m)`).
fn row_times(p: [f64; 3], m: &Mat) -> [f64; 3] {
    std::array::from_fn(|j| p[0] * m[0][j] + p[1] * m[1][j] + p[2] * m[2][j])
}

/// numpy's `linspace(-max, max, n, dtype=float32)`: computed in f64, the last one exact.
fn linspace(max: f64, n: usize) -> Vec<f32> {
    let step = if n > 1 {
        2.0 * max / (n - 1) as f64
    } else {
        0.0
    };
    (0..n)
        .map(|i| {
            if n > 1 && i == n - 1 {
                max as f32
            } else {
                (i as f64 * step - max) as f32
            }
        })
        .collect()
}

/// py360convert's `xyzpers` camera: row vectors times Rx(v), Ry(u) and the in-plane turn
/// about the view axis (the z axis carried by the first two).
fn camera(u: f64, v: f64, in_rot: f64) -> Mat {
    let rx = rotation(v, [1.0, 0.0, 0.0]);
    let ry = rotation(u, [0.0, 1.0, 0.0]);
    let rxy = mul(&rx, &ry);
    let ri = rotation(in_rot, row_times([0.0, 0.0, 1.0], &rxy));
    mul(&rxy, &ri)
}

/// A perspective view (out_h, out_w, c) of the panorama `e_img` (h, w, c), as
/// py360convert's `e2p` after its conversions: fields of view, `u` (already negated, as it
/// negates `u_deg`), `v` and `in_rot` in radians.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
pub fn e2p_view<'py>(
    py: Python<'py>,
    e_img: PyReadonlyArray3<'py, f32>,
    h_fov: f64,
    v_fov: f64,
    u: f64,
    v: f64,
    in_rot: f64,
    out_h: usize,
    out_w: usize,
    nearest: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let shape = [e_img.shape()[0], e_img.shape()[1], e_img.shape()[2]];
    if shape.contains(&0) || out_h == 0 || out_w == 0 {
        return Err(crate::bad_arg(
            py,
            "e2p: an empty panorama or out_hw with a zero",
        ));
    }
    let src = e_img
        .as_slice()
        .map_err(|e| crate::bad_arg(py, e.to_string()))?;
    if ![h_fov, v_fov, u, v, in_rot].iter().all(|a| a.is_finite()) {
        return Err(crate::bad_arg(
            py,
            "e2p: fov_deg, u_deg, v_deg and in_rot_deg must be finite numbers",
        ));
    }
    let c = shape[2];
    // Zeroed by the allocator; every texel is written once below.
    let what = format!("e2p: out_hw=({out_h}, {out_w})");
    let mut out = crate::zeroed(py, &what, &[out_h, out_w, c])?;
    py.detach(|| {
        let e = E2c::bare(src, shape, nearest);
        let m = camera(u, v, in_rot);
        let xs = linspace((h_fov / 2.0).tan(), out_w);
        let ys = linspace((v_fov / 2.0).tan(), out_h);
        out.par_chunks_mut(out_w * c)
            .zip(ys.par_iter())
            .for_each(|(line, &y)| {
                for (texel, &x) in line.chunks_exact_mut(c).zip(&xs) {
                    // Its grid is float32, the rotation float64, the direction float32 again.
                    let d = row_times([x as f64, -y as f64, 1.0], &m).map(|a| a as f32);
                    let lon = atan2(d[0], d[2]);
                    let lat = atan2(d[1], (d[0] * d[0] + d[2] * d[2]).sqrt());
                    e.sample(e.to_cx(lon), e.to_cy(lat), texel);
                }
            });
    });
    Ok(PyArray1::from_vec(py, out)
        .reshape([out_h, out_w, c])?
        .into_any())
}
