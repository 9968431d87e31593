//! py360convert's geometry, texel for texel, so that `cubeforge.e2c` and `cubeforge.c2e` give
//! its faces and panoramas (its face grids run edge to edge, `linspace(-0.5, 0.5, w)`, not
//! through texel centres as cubeforge's do, and its padding and face masks are its own).
//! Faces are F R B L U D in one horizontal row, as its `cube_format="horizon"`; the Python
//! half lays them out as dice, list or dict.

use numpy::ndarray::ArrayView3;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray3, PyUntypedArrayMethods};
use pyo3::prelude::*;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Bilinear (or nearest) taps of `get(y, x)` at (y, x), as scipy's `map_coordinates` with
/// order 1 (0) inside the image; `sum` receives each tap's weight.
fn taps(y: f32, x: f32, nearest: bool, mut sum: impl FnMut(usize, usize, f32)) {
    if nearest {
        sum(y.round() as usize, x.round() as usize, 1.0);
        return;
    }
    let (y0, x0) = (y.floor(), x.floor());
    let (fy, fx) = (y - y0, x - x0);
    let (y0, x0) = (y0 as usize, x0 as usize);
    sum(y0, x0, (1.0 - fy) * (1.0 - fx));
    if fx > 0.0 {
        sum(y0, x0 + 1, (1.0 - fy) * fx);
    }
    if fy > 0.0 {
        sum(y0 + 1, x0, fy * (1.0 - fx));
        if fx > 0.0 {
            sum(y0 + 1, x0 + 1, fy * fx);
        }
    }
}

/// atan2 for f32 within a few units of the last place (Cephes' atanf after its range
/// reduction), without libm's special cases.
pub(crate) fn atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let q = if ax == 0.0 { f32::INFINITY } else { ay / ax };
    let (base, t) = if q > 2.414_213_5 {
        (FRAC_PI_2, -1.0 / q)
    } else if q > 0.414_213_57 {
        (FRAC_PI_4, (q - 1.0) / (q + 1.0))
    } else {
        (0.0, q)
    };
    let z = t * t;
    let p = (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z;
    let r = if ay == 0.0 && ax == 0.0 {
        0.0
    } else {
        base + (p * t + t)
    };
    let r = if x.is_sign_negative() { PI - r } else { r };
    if y.is_sign_negative() {
        -r
    } else {
        r
    }
}

/// Face texel (row, col) of face `f` (F R B L U D) as py360convert's `xyzcube` places it.
fn cube_dir(f: usize, row: usize, col: usize, n: usize) -> [f32; 3] {
    let step = if n > 1 { 1.0 / (n - 1) as f32 } else { 0.0 };
    let rng = |i: usize| -0.5 + i as f32 * step;
    let (x, y) = (rng(col), -rng(row));
    let (x_flip, y_flip) = (rng(n - 1 - col), -rng(n - 1 - row));
    match f {
        0 => [x, y, 0.5],
        1 => [0.5, y, x_flip],
        2 => [x_flip, y, -0.5],
        3 => [-0.5, y, x],
        4 => [x, 0.5, y_flip],
        _ => [x, -0.5, y],
    }
}

/// py360convert's e2c sampler of one panorama: its geometry computed once.
pub(crate) struct E2c<'a> {
    src: &'a [f32],
    h: usize,
    w: usize,
    c: usize,
    n: usize,
    nearest: bool,
    /// The side faces' columns (face * n + col): the panorama column and the distance from
    /// the axis, the same on every row; the distance is the same on all four faces (their
    /// grids are one grid turned), so a row's v is one atan2 a column for the four.
    side: Vec<(f32, f32)>,
    /// U's (u, v) a texel; D's row r is U's row n - 1 - r with v negated.
    up: Vec<(f32, f32)>,
}

impl E2c<'_> {
    pub(crate) fn to_cx(&self, u: f32) -> f32 {
        (u * (0.5 / std::f32::consts::PI) + 0.5) * self.w as f32 + 0.5
    }

    pub(crate) fn to_cy(&self, v: f32) -> f32 {
        (-v * std::f32::consts::FRAC_1_PI + 0.5) * self.h as f32 + 0.5
    }

    /// The panorama alone, for [`E2c::sample`] (no faces' geometry).
    pub(crate) fn bare(src: &[f32], [h, w, c]: [usize; 3], nearest: bool) -> E2c<'_> {
        E2c {
            src,
            h,
            w,
            c,
            n: 0,
            nearest,
            side: Vec::new(),
            up: Vec::new(),
        }
    }

    fn new(src: &[f32], shape: [usize; 3], n: usize, nearest: bool) -> E2c<'_> {
        let mut e = E2c::bare(src, shape, nearest);
        e.n = n;
        e.up = vec![(0.0, 0.0); n * n];
        e.side = (0..4 * n)
            .map(|i| {
                let [x, _, z] = cube_dir(i / n, 0, i % n, n);
                (e.to_cx(atan2(x, z)), (x * x + z * z).sqrt())
            })
            .collect();
        e.up.par_chunks_mut(n).enumerate().for_each(|(row, line)| {
            for (col, uv) in line.iter_mut().enumerate() {
                let [x, y, z] = cube_dir(4, row, col, n);
                *uv = (atan2(x, z), atan2(y, (x * x + z * z).sqrt()));
            }
        });
        e
    }

    /// A texel of py360convert's padded panorama (a texel more each side: its top and
    /// bottom rows turned half a turn, its columns wrapped).
    fn at(&self, py_: usize, px: usize) -> &[f32] {
        let (h, w) = (self.h, self.w);
        let px = match px {
            0 => w,
            p if p == w + 1 => 1,
            p => p,
        };
        let ix = px - 1;
        let (row, col) = match py_ {
            0 => (0, (ix + w - w / 2) % w),
            p if p == h + 1 => (h - 1, (ix + w - w / 2) % w),
            p => (p - 1, ix),
        };
        &self.src[(row * w + col) * self.c..][..self.c]
    }

    /// The side faces' v on face row `row`, a column each.
    fn side_row(&self, row: usize) -> Vec<f32> {
        let y = cube_dir(0, row, 0, self.n)[1];
        self.side[..self.n]
            .iter()
            .map(|&(_, r)| self.to_cy(atan2(y, r)))
            .collect()
    }

    /// Row `row` of face `face` into `seg` (n texels); `side_cy` from [`E2c::side_row`].
    fn fill(&self, face: usize, row: usize, seg: &mut [f32], side_cy: &[f32]) {
        let (n, c) = (self.n, self.c);
        for (col, texel) in seg.chunks_exact_mut(c).enumerate() {
            let (cx, cy) = match face {
                0..=3 => (self.side[face * n + col].0, side_cy[col]),
                4 => {
                    let (u, v) = self.up[row * n + col];
                    (self.to_cx(u), self.to_cy(v))
                }
                _ => {
                    let (u, v) = self.up[(n - 1 - row) * n + col];
                    (self.to_cx(u), self.to_cy(-v))
                }
            };
            self.sample(cx, cy, texel);
        }
    }

    /// The texel of py360convert's padded panorama at (cx, cy) (padded coordinates, each
    /// from 0.5 to the padded side less 0.5) into `texel`: bilinear or nearest, as its
    /// `map_coordinates`.
    pub(crate) fn sample(&self, cx: f32, cy: f32, texel: &mut [f32]) {
        let (c, w) = (self.c, self.w);
        let (wf, hf) = (w as f32, self.h as f32);
        // cx and cy are at least 0.5: truncation is the floor.
        let (x0, y0) = ((cx as usize) as f32, (cy as usize) as f32);
        // Inside the image (padded texels 1..=w, 1..=h): read it directly.
        if !self.nearest && x0 >= 1.0 && x0 < wf && y0 >= 1.0 && y0 < hf {
            let (fx, fy) = (cx - x0, cy - y0);
            let i = ((y0 as usize - 1) * w + x0 as usize - 1) * c;
            let (a, b) = (
                &self.src[i..i + 2 * c],
                &self.src[i + w * c..i + w * c + 2 * c],
            );
            for (k, o) in texel.iter_mut().enumerate() {
                let top = a[k] + fx * (a[c + k] - a[k]);
                let bottom = b[k] + fx * (b[c + k] - b[k]);
                *o = top + fy * (bottom - top);
            }
            return;
        }
        let mut tapped: [(&[f32], f32); 4] = [(&[], 0.0); 4];
        let mut count = 0;
        taps(cy, cx, self.nearest, |ty, tx, wt| {
            tapped[count] = (self.at(ty.min(self.h + 1), tx.min(w + 1)), wt);
            count += 1;
        });
        for (k, o) in texel.iter_mut().enumerate() {
            *o = tapped[..count].iter().map(|(t, wt)| wt * t[k]).sum();
        }
    }
}

/// A panorama (h, w, c) to six faces of edge `face_w` in one row (face_w, 6 face_w, c), or
/// laid out as py360convert's dice (3 face_w, 4 face_w, c) with `dice`.
#[pyfunction]
pub fn e2c_faces<'py>(
    py: Python<'py>,
    e_img: PyReadonlyArray3<'py, f32>,
    face_w: usize,
    nearest: bool,
    dice: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let shape = [e_img.shape()[0], e_img.shape()[1], e_img.shape()[2]];
    if face_w == 0 || shape[0] == 0 || shape[1] == 0 {
        return Err(crate::bad_arg(py, "e2c: an empty panorama or face_w=0"));
    }
    let src = e_img
        .as_slice()
        .map_err(|e| crate::bad_arg(py, e.to_string()))?;
    let (n, c) = (face_w, shape[2]);
    let cell = n * c;
    // Zeroed by the allocator (fresh pages, zero until written): a dice's empty cells are
    // never touched.
    let dims = [if dice { 12 } else { 6 }, n, n, c];
    let mut out = crate::zeroed(py, &format!("e2c: face_w={face_w}"), &dims)?;
    py.detach(|| {
        let e = E2c::new(src, shape, n, nearest);
        if dice {
            // py360convert's dice: U above F, then L F R B, then D below F.
            out.par_chunks_mut(4 * cell)
                .enumerate()
                .for_each(|(r, line)| {
                    let (band, row) = (r / n, r % n);
                    match band {
                        0 => e.fill(4, row, &mut line[cell..2 * cell], &[]),
                        1 => {
                            let cy = e.side_row(row);
                            for (i, face) in [3, 0, 1, 2].into_iter().enumerate() {
                                e.fill(face, row, &mut line[i * cell..(i + 1) * cell], &cy);
                            }
                        }
                        _ => e.fill(5, row, &mut line[cell..2 * cell], &[]),
                    }
                });
        } else {
            out.par_chunks_mut(6 * cell)
                .enumerate()
                .for_each(|(row, line)| {
                    let cy = e.side_row(row);
                    for (face, seg) in line.chunks_exact_mut(cell).enumerate() {
                        e.fill(face, row, seg, &cy);
                    }
                });
        }
    });
    let shape = if dice {
        [3 * n, 4 * n, c]
    } else {
        [n, 6 * n, c]
    };
    Ok(PyArray1::from_vec(py, out).reshape(shape)?.into_any())
}

/// The side face (0 F, 1 R, 2 B, 3 L) of panorama column `j` of `w` in py360convert's masks.
fn band_of(j: usize, w: usize) -> u8 {
    let (w4, w8) = (w / 4, w / 8);
    if j < w8 {
        2
    } else {
        [3, 0, 1, 2][((j - w8) / w4.max(1)).min(3)]
    }
}

/// py360convert's `equirect_facetype`: which face (0 F, 1 R, 2 B, 3 L, 4 U, 5 D) each
/// panorama texel reads (its rounded ceiling, to the texel).
fn facetype(h: usize, w: usize) -> Vec<u8> {
    let (w4, w8, h3) = (w / 4, w / 8, h / 3);
    let idx: Vec<i64> = (0..w4)
        .map(|k| {
            let t = if w4 > 1 {
                -PI + 2.0 * PI * k as f64 / (w4 - 1) as f64
            } else {
                -PI
            };
            (h as f64 / 2.0 - (t / 4.0).cos().atan() * h as f64 / PI).round_ties_even() as i64
        })
        .collect();
    let mut tp = vec![0u8; h * w];
    for j in 0..w {
        let band = band_of(j, w);
        let k = (j + w4 - w8 % w4.max(1)) % w4.max(1);
        for r in 0..h {
            let mut f = band;
            if r < h3 && (r as i64) < idx[k] {
                f = 4;
            }
            if r + h3 >= h && ((h - 1 - r) as i64) < idx[k] {
                f = 5;
            }
            tp[r * w + j] = f;
        }
    }
    tp
}

/// py360convert's `CubeFaceSampler._pad`: each face (F R B L U D) with a ring of its
/// neighbours' texels, assigned in its order (later assignments overwrite the corners).
/// The faces are read where they lie (a dice's cells, a horizon's slices: any strides).
fn padded_faces(faces: &[ArrayView3<'_, f32>], n: usize, c: usize) -> Vec<f32> {
    let m = n + 2;
    let mut p = vec![0f32; 6 * m * m * c];
    let idx = move |f: usize, r: usize, col: usize| ((f * m + r) * m + col) * c;
    for (f, face) in faces.iter().enumerate() {
        for (r, row) in face.outer_iter().enumerate() {
            let to = &mut p[idx(f, r + 1, 1)..][..n * c];
            match row.as_slice() {
                Some(s) => to.copy_from_slice(s),
                None => to.iter_mut().zip(row.iter()).for_each(|(o, v)| *o = *v),
            }
        }
    }
    // A row or column of the padded faces, read or written whole (m texels).
    let line = |p: &[f32], f: usize, row: Option<usize>, col: Option<usize>, rev: bool| {
        let mut v: Vec<f32> = Vec::with_capacity(m * c);
        for i in 0..m {
            let i = if rev { m - 1 - i } else { i };
            let at = idx(f, row.unwrap_or(i), col.unwrap_or(i));
            v.extend_from_slice(&p[at..at + c]);
        }
        v
    };
    let put = |p: &mut [f32], f: usize, row: Option<usize>, col: Option<usize>, v: &[f32]| {
        for i in 0..m {
            let at = idx(f, row.unwrap_or(i), col.unwrap_or(i));
            p[at..at + c].copy_from_slice(&v[i * c..][..c]);
        }
    };
    let (top, bottom, left, right, one, last) =
        (Some(0), Some(m - 1), Some(0), Some(m - 1), Some(1), Some(n));
    const F: usize = 0;
    const R: usize = 1;
    const B: usize = 2;
    const L: usize = 3;
    const U: usize = 4;
    const D: usize = 5;
    // (face, row or column written, source face, source row, source column, reversed)
    let rows = [
        (F, top, U, last, None, false),
        (F, bottom, D, one, None, false),
        (R, top, U, None, last, true),
        (R, bottom, D, None, last, false),
        (B, top, U, one, None, true),
        (B, bottom, D, last, None, true),
        (L, top, U, None, one, false),
        (L, bottom, D, None, one, true),
        (U, top, B, one, None, true),
        (U, bottom, F, one, None, false),
        (D, top, F, last, None, false),
        (D, bottom, B, last, None, true),
    ];
    for (f, row, sf, sr, sc, rev) in rows {
        let v = line(&p, sf, sr, sc, rev);
        put(&mut p, f, row, None, &v);
    }
    let cols = [
        (F, left, L, None, last, false),
        (F, right, R, None, one, false),
        (R, left, F, None, last, false),
        (R, right, B, None, one, false),
        (B, left, R, None, last, false),
        (B, right, L, None, one, false),
        (L, left, B, None, last, false),
        (L, right, F, None, one, false),
        (U, left, L, one, None, false),
        (U, right, R, one, None, true),
        (D, left, L, last, None, true),
        (D, right, R, last, None, false),
    ];
    for (f, col, sf, sr, sc, rev) in cols {
        let v = line(&p, sf, sr, sc, rev);
        put(&mut p, f, None, col, &v);
    }
    p
}

/// Six faces (n, n, c) in F R B L U D order, each read where it lies (no copy of a dice or
/// a horizon into a stack of faces), to a panorama (h, w, c).
#[pyfunction]
pub fn c2e_faces<'py>(
    py: Python<'py>,
    faces: Vec<PyReadonlyArray3<'py, f32>>,
    h: usize,
    w: usize,
    nearest: bool,
) -> PyResult<Bound<'py, PyAny>> {
    let views: Vec<ArrayView3<'_, f32>> = faces.iter().map(|f| f.as_array()).collect();
    let (n, c) = views.first().map_or((0, 0), |v| (v.dim().0, v.dim().2));
    let square = views.iter().all(|v| v.dim() == (n, n, c));
    if views.len() != 6 || !square || n == 0 || h == 0 || w == 0 || !w.is_multiple_of(8) {
        return Err(crate::bad_arg(
            py,
            "c2e: six square faces, and w a multiple of 8",
        ));
    }
    let mut out = crate::zeroed(py, &format!("c2e: h={h}, w={w}"), &[h, w, c])?;
    py.detach(|| {
        let p = padded_faces(&views, n, c);
        let tp = facetype(h, w);
        let m = n + 2;
        let half = n as f64 / 2.0;
        // Every sine, cosine and tangent depends on the column alone (u, its side face) or on
        // the row alone (v): computed once each, as py360convert computes them.
        let cols: Vec<[f64; 4]> = (0..w)
            .map(|col| {
                let u = if w > 1 {
                    -PI + 2.0 * PI * col as f64 / (w - 1) as f64
                } else {
                    -PI
                };
                let u = u as f32 as f64;
                let a = u - PI / 2.0 * band_of(col, w) as f64;
                [half * a.tan(), a.cos(), u.sin(), u.cos()]
            })
            .collect();
        out.par_chunks_mut(w * c)
            .enumerate()
            .for_each(|(row, line)| {
                let v = if h > 1 {
                    PI / 2.0 - PI * row as f64 / (h - 1) as f64
                } else {
                    PI / 2.0
                };
                let v = v as f32 as f64;
                let tan_v = (v as f32).tan() as f64;
                let (r_up, r_down) = (
                    half * (PI / 2.0 - v).tan(),
                    half * (PI / 2.0 - v.abs()).tan(),
                );
                for (col, texel) in line.chunks_exact_mut(c).enumerate() {
                    let [x_side, cos_a, sin_u, cos_u] = cols[col];
                    let f = tp[row * w + col] as usize;
                    let (x, y) = match f {
                        0..=3 => (x_side, -half * tan_v / cos_a),
                        4 => (r_up * sin_u, r_up * cos_u),
                        _ => (r_down * sin_u, -r_down * cos_u),
                    };
                    let cx = ((x + half) as f32).clamp(0.0, n as f32) + 1.0;
                    let cy = ((y + half) as f32).clamp(0.0, n as f32) + 1.0;
                    taps(cy, cx, nearest, |ty, tx, wt| {
                        let at = ((f * m + ty.min(m - 1)) * m + tx.min(m - 1)) * c;
                        for (o, s) in texel.iter_mut().zip(&p[at..at + c]) {
                            *o += wt * s;
                        }
                    });
                }
            });
    });
    Ok(PyArray1::from_vec(py, out).reshape([h, w, c])?.into_any())
}
