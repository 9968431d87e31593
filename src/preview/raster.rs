//! The per-vertex pipeline's rasterizer: the tessellated sphere's vertex outputs, its visible
//! triangles binned by row, and per sample the nearest covering triangle, so section 7.2.5's
//! interpolation artefacts appear as on a GPU.

#![warn(missing_docs)]

use super::camera::Camera;
use super::shader::{Shader, Varyings};
use super::sphere;
use crate::cube::Environment;
use glam::Vec3;

/// One triangle of the per-vertex mesh set up for rasterization: edge functions giving the
/// screen-space barycentrics directly, 1/z per vertex for perspective correction.
pub(super) struct Tri {
    idx: [u32; 3],
    ea: Vec3,
    eb: Vec3,
    ec: Vec3,
    inv_z: Vec3,
    ymin: f32,
    ymax: f32,
    xmin: f32,
    xmax: f32,
}

impl Tri {
    #[inline]
    fn bary(&self, x: f32, y: f32) -> Vec3 {
        self.ea * x + self.eb * y + self.ec
    }
    /// Perspective-correct barycentrics at (x, y), extrapolated outside the triangle as a
    /// GPU does for helper pixels.
    #[inline]
    pub(super) fn persp(&self, x: f32, y: f32) -> Vec3 {
        let q = self.bary(x, y) * self.inv_z;
        q / (q.x + q.y + q.z)
    }
}

/// A rasterized sample: the triangle and its 1/depth.
#[derive(Clone, Copy)]
pub(super) struct Frag {
    pub(super) tri: u32,
    pub(super) inv_z: f32,
}

pub(super) const NO_TRI: u32 = u32::MAX;

/// The per-vertex pipeline's data: vertex outputs, visible triangles, triangles per row.
pub(super) struct Raster {
    varyings: Vec<Varyings>,
    pub(super) tris: Vec<Tri>,
    row_start: Vec<u32>,
    row_tris: Vec<u32>,
}

pub(super) fn setup_raster<E: Environment + ?Sized>(
    shader: &Shader<'_, E>,
    cam: &Camera,
    tessellation: usize,
    offsets: &[(f32, f32)],
) -> Raster {
    use rayon::prelude::*;
    let mesh = sphere::tessellate(tessellation);
    // The vertex program at every vertex (normal = position on the unit sphere).
    let varyings: Vec<Varyings> = mesh
        .positions
        .par_iter()
        .zip(mesh.uvs.par_iter())
        .map(|(&p, &uv)| shader.vertex(p, p, uv))
        .collect();
    let screen: Vec<(f32, f32, f32)> = mesh.positions.iter().map(|&p| cam.project(p)).collect();
    let mut tris = Vec::with_capacity(mesh.triangles.len() / 2 + 1);
    for t in &mesh.triangles {
        let [p0, p1, p2] = t.map(|i| mesh.positions[i as usize]);
        let mut n = (p1 - p0).cross(p2 - p0);
        if n.dot(p0 + p1 + p2) < 0.0 {
            n = -n;
        }
        // Back faces are hidden by the front ones (the mesh is convex): cull them.
        if n.length_squared() < 1e-20 || (p0 - cam.eye).dot(n) >= 0.0 {
            continue;
        }
        let [s0, s1, s2] = t.map(|i| screen[i as usize]);
        let area2 = (s1.0 - s0.0) * (s2.1 - s0.1) - (s2.0 - s0.0) * (s1.1 - s0.1);
        if area2.abs() < 1e-12 {
            continue;
        }
        // e_i = E(a, b, p) / area2 for the edge a -> b opposite vertex i.
        let edge = |a: (f32, f32, f32), b: (f32, f32, f32)| {
            (
                -(b.1 - a.1) / area2,
                (b.0 - a.0) / area2,
                ((b.1 - a.1) * a.0 - (b.0 - a.0) * a.1) / area2,
            )
        };
        let (e0, e1, e2) = (edge(s1, s2), edge(s2, s0), edge(s0, s1));
        tris.push(Tri {
            idx: *t,
            ea: Vec3::new(e0.0, e1.0, e2.0),
            eb: Vec3::new(e0.1, e1.1, e2.1),
            ec: Vec3::new(e0.2, e1.2, e2.2),
            inv_z: Vec3::new(1.0 / s0.2, 1.0 / s1.2, 1.0 / s2.2),
            ymin: s0.1.min(s1.1).min(s2.1),
            ymax: s0.1.max(s1.1).max(s2.1),
            xmin: s0.0.min(s1.0).min(s2.0),
            xmax: s0.0.max(s1.0).max(s2.0),
        });
    }
    // Bin triangles by the pixel rows whose samples they may cover.
    let h = cam.height;
    let (oy_min, oy_max) = offsets
        .iter()
        .fold((1.0f32, 0.0f32), |(lo, hi), o| (lo.min(o.1), hi.max(o.1)));
    let rows_of = |t: &Tri| {
        let r0 = (t.ymin - oy_max).ceil().max(0.0);
        let r1 = (t.ymax - oy_min).floor().min(h as f32 - 1.0);
        (r0 as usize, r1)
    };
    let mut count = vec![0u32; h + 1];
    for t in &tris {
        let (r0, r1) = rows_of(t);
        if r1 >= r0 as f32 {
            for c in &mut count[r0..=r1 as usize] {
                *c += 1;
            }
        }
    }
    let mut row_start = vec![0u32; h + 1];
    for r in 0..h {
        row_start[r + 1] = row_start[r] + count[r];
    }
    let mut fill = row_start.clone();
    let mut row_tris = vec![0u32; row_start[h] as usize];
    for (ti, t) in tris.iter().enumerate() {
        let (r0, r1) = rows_of(t);
        if r1 >= r0 as f32 {
            for r in r0..=r1 as usize {
                row_tris[fill[r] as usize] = ti as u32;
                fill[r] += 1;
            }
        }
    }
    Raster {
        varyings,
        tris,
        row_start,
        row_tris,
    }
}

impl Raster {
    /// Rasterizes row `y`'s samples into `buf` (pixel-major, `offsets.len()` per pixel):
    /// for each sample the nearest covering triangle.
    pub(super) fn rasterize_row(
        &self,
        y: usize,
        width: usize,
        offsets: &[(f32, f32)],
        buf: &mut [Frag],
    ) {
        let s = offsets.len();
        buf.fill(Frag {
            tri: NO_TRI,
            inv_z: 0.0,
        });
        let list = &self.row_tris[self.row_start[y] as usize..self.row_start[y + 1] as usize];
        for (k, &(ox, oy)) in offsets.iter().enumerate() {
            let ys = y as f32 + oy;
            for &ti in list {
                let t = &self.tris[ti as usize];
                if ys < t.ymin || ys > t.ymax {
                    continue;
                }
                // The x interval where all three edge functions are >= 0 on this scanline.
                let (mut lo, mut hi) = (t.xmin, t.xmax);
                let c = t.eb * ys + t.ec;
                for i in 0..3 {
                    let a = t.ea[i];
                    if a > 0.0 {
                        lo = lo.max(-c[i] / a);
                    } else if a < 0.0 {
                        hi = hi.min(-c[i] / a);
                    } else if c[i] < 0.0 {
                        hi = f32::NEG_INFINITY;
                    }
                }
                if lo > hi {
                    continue;
                }
                let x0 = (lo - ox).ceil().max(0.0) as usize;
                let x1 = (hi - ox).floor();
                if x1 < 0.0 {
                    continue;
                }
                let x1 = (x1 as usize).min(width - 1);
                for px in x0..=x1 {
                    let sx = px as f32 + ox;
                    let b = t.bary(sx, ys);
                    if b.min_element() < -1e-5 {
                        continue;
                    }
                    let iz = b.dot(t.inv_z);
                    let slot = &mut buf[px * s + k];
                    if slot.tri == NO_TRI || iz > slot.inv_z {
                        *slot = Frag { tri: ti, inv_z: iz };
                    }
                }
            }
        }
    }

    #[inline]
    pub(super) fn interpolate(&self, t: &Tri, l: Vec3) -> Varyings {
        let [a, b, c] = t.idx.map(|i| &self.varyings[i as usize]);
        Varyings::blend(a, b, c, l)
    }
}
