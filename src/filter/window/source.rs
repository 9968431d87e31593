//! A source level laid out for gathering: every texel's direction, solid angle and value in
//! flat arrays, and blocks with bounding cones, so a tile finds its few hundred candidates
//! without testing the whole level.

use super::sum::Candidates;
use crate::cube::{solid_angle_table, texel_dir, CubeSampler};
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::f32::consts::PI;

/// One source level prepared for gathering: every texel's direction, solid angle and value
/// (face by face, row by row), and blocks of texels with bounding cones.
pub(super) struct Source {
    n: usize,
    dirs: Vec<Vec3>,
    /// The directions' components apart, for tests four texels at a time.
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    solid_angles: Vec<f32>,
    values: Vec<Vec4>,
    /// Block edge in texels; blocks per face edge.
    block: usize,
    per_edge: usize,
    /// Per face, its blocks four at a time: axes (x, y, z) and the cosine below which a
    /// block holds no texel within the level's largest reach (the lobe's plus a tile's
    /// radius) of a tile's axis; padding is never reached.
    cones: Vec<Vec<[Vec4; 4]>>,
    /// The cosine to a face's normal below which a tile reaches none of the face.
    face_limit: f32,
}

impl Source {
    pub(super) fn new(src: &CubeSampler, level: usize, max_reach: f32) -> Source {
        let n = src.level_size(level);
        let inv = 1.0 / n as f32;
        let angles = solid_angle_table(n);
        // Every texel's direction (and its components apart), solid angle and value, row by
        // row in parallel straight into place.
        let count = 6 * n * n;
        let mut dirs = vec![Vec3::ZERO; count];
        let (mut xs, mut ys, mut zs) = (vec![0.0; count], vec![0.0; count], vec![0.0; count]);
        let mut solid_angles = vec![0.0; count];
        let mut values = vec![Vec4::ZERO; count];
        let w = n.max(1);
        dirs.par_chunks_mut(w)
            .zip(xs.par_chunks_mut(w))
            .zip(ys.par_chunks_mut(w))
            .zip(zs.par_chunks_mut(w))
            .zip(solid_angles.par_chunks_mut(w))
            .zip(values.par_chunks_mut(w))
            .enumerate()
            .for_each(|(fy, (((((d, x), y), z), sa), v))| {
                let (face, row) = (fy / n, fy % n);
                for (i, d) in d.iter_mut().enumerate() {
                    *d = texel_dir(face, i, row, inv);
                    (x[i], y[i], z[i]) = (d.x, d.y, d.z);
                }
                sa.copy_from_slice(&angles[row * n..(row + 1) * n]);
                v.copy_from_slice(src.row(level, face, row));
            });
        // About 16 blocks per face edge: few enough to test them all per tile.
        let block = n.div_ceil(16).max(1);
        let per_edge = n.div_ceil(block);
        let cones: Vec<(Vec3, f32)> = (0..6 * per_edge * per_edge)
            .into_par_iter()
            .map(|b| {
                let (face, by, bx) = (
                    b / (per_edge * per_edge),
                    (b / per_edge) % per_edge,
                    b % per_edge,
                );
                let texels = || {
                    (by * block..((by + 1) * block).min(n)).flat_map(move |y| {
                        (bx * block..((bx + 1) * block).min(n)).map(move |x| (face * n + y) * n + x)
                    })
                };
                let axis = texels().map(|i| dirs[i]).sum::<Vec3>().normalize();
                let radius = texels()
                    .map(|i| axis.dot(dirs[i]).clamp(-1.0, 1.0).acos())
                    .fold(0.0f32, f32::max);
                let limit = max_reach + radius + 1e-4;
                (axis, if limit < PI { limit.cos() } else { -2.0 })
            })
            .collect();
        let cones = cones
            .chunks(per_edge * per_edge)
            .map(|face| {
                face.chunks(4)
                    .map(|c| {
                        let at = |l: usize| c.get(l).copied().unwrap_or((Vec3::ZERO, 2.0));
                        let lanes = |f: &dyn Fn((Vec3, f32)) -> f32| {
                            Vec4::new(f(at(0)), f(at(1)), f(at(2)), f(at(3)))
                        };
                        [
                            lanes(&|c| c.0.x),
                            lanes(&|c| c.0.y),
                            lanes(&|c| c.0.z),
                            lanes(&|c| c.1),
                        ]
                    })
                    .collect()
            })
            .collect();
        // Every direction of a face is within acos(1 / sqrt(3)) of its normal.
        let face_reach = (1.0f32 / 3f32.sqrt()).acos() + max_reach + 1e-3;
        let face_limit = if face_reach < PI {
            face_reach.cos()
        } else {
            -2.0
        };
        Source {
            n,
            xs,
            ys,
            zs,
            dirs,
            solid_angles,
            values,
            block,
            per_edge,
            cones,
            face_limit,
        }
    }

    /// Appends every texel whose centre lies within `reach` (at most the level's largest) of
    /// `axis` to `out`.
    pub(super) fn gather(&self, axis: Vec3, reach: f32, out: &mut Candidates) {
        // Past pi the cosine turns back: everything is within reach.
        let cos_reach = if reach >= PI { -2.0 } else { reach.cos() };
        let (n, block, per_edge) = (self.n, self.block, self.per_edge);
        let (ax, ay, az) = (
            Vec4::splat(axis.x),
            Vec4::splat(axis.y),
            Vec4::splat(axis.z),
        );
        for (face, quads) in self.cones.iter().enumerate() {
            if axis.dot(crate::cube::face_dir(face, 0.5, 0.5)) < self.face_limit {
                continue;
            }
            for (j, [x, y, z, limit]) in quads.iter().enumerate() {
                let mut hit = (ax * *x + ay * *y + az * *z).cmpge(*limit).bitmask();
                while hit != 0 {
                    let b = 4 * j + hit.trailing_zeros() as usize;
                    hit &= hit - 1;
                    let (by, bx) = (b / per_edge, b % per_edge);
                    let (x0, x1) = (bx * block, ((bx + 1) * block).min(n));
                    for y in by * block..((by + 1) * block).min(n) {
                        let row = (face * n + y) * n;
                        // Four texels of the row at a time, the tail one by one.
                        let mut x = x0;
                        while x + 4 <= x1 {
                            let i = row + x;
                            let lanes = |a: &[f32]| Vec4::from_slice(&a[i..i + 4]);
                            let c =
                                ax * lanes(&self.xs) + ay * lanes(&self.ys) + az * lanes(&self.zs);
                            let mut m = c.cmpge(Vec4::splat(cos_reach)).bitmask();
                            while m != 0 {
                                let k = i + m.trailing_zeros() as usize;
                                m &= m - 1;
                                out.push(self.dirs[k], self.solid_angles[k], self.values[k]);
                            }
                            x += 4;
                        }
                        for i in row + x..row + x1 {
                            let c = axis.x * self.xs[i] + axis.y * self.ys[i] + axis.z * self.zs[i];
                            if c >= cos_reach {
                                out.push(self.dirs[i], self.solid_angles[i], self.values[i]);
                            }
                        }
                    }
                }
            }
        }
    }
}
