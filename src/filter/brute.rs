//! Brute-force convolution: every output texel integrates a lobe over every source texel,
//! weighted by exact texel solid angles. Slow (output x source texels) but exact: the
//! reference the fast filters are measured against, and the irradiance default at small sizes.

#![warn(missing_docs)]

use super::lobe::Lobe;
use crate::cube::{solid_angle_table, texel_dir, CubeMap};
use crate::image::Image;
use glam::{Vec3, Vec4};

/// Directions and solid angles of every texel of a face size, in face order.
pub(crate) fn texel_table(n: usize) -> Vec<(Vec3, f32)> {
    let inv = 1.0 / n as f32;
    let angles = solid_angle_table(n);
    let mut out = Vec::with_capacity(6 * n * n);
    for face in 0..6 {
        for y in 0..n {
            for x in 0..n {
                let d = texel_dir(face, x, y, inv);
                out.push((d, angles[y * n + x]));
            }
        }
    }
    out
}

/// Convolves level 0 of `src` with `lobe` into faces of edge `size`, normalised by the lobe's
/// own discrete integral (so a constant environment stays exactly constant).
pub fn convolve(src: &CubeMap, lobe: Lobe, size: usize) -> [Image; 6] {
    convolve_with_progress(src, lobe, size, &|_| {})
}

/// The exact reference of a prefiltered chain's level of edge `size`: [`convolve`], where a
/// level smaller than 16 texels is convolved at its size doubled until it is at least 16 and
/// each texel is then the solid-angle-weighted mean of those it covers, as
/// [`super::prefilter`] makes such levels.
pub fn convolve_level(src: &CubeMap, lobe: Lobe, size: usize) -> [Image; 6] {
    let fine = super::fine_size_for(size, Some(lobe));
    super::reduce_to(convolve(src, lobe, fine), size)
}

/// [`convolve`], calling `progress(1)` as each of the 6 x `size` output rows is done.
pub(crate) fn convolve_with_progress(
    src: &CubeMap,
    lobe: Lobe,
    size: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> [Image; 6] {
    let n = src.size();
    let table = texel_table(n);
    let values: Vec<Vec4> = src.levels[0]
        .iter()
        .flat_map(|f| f.pixels.iter().copied())
        .collect();
    let inv = 1.0 / size as f32;
    std::array::from_fn(|face| {
        Image::from_rows(size, size, |y, row| {
            for (x, out) in row.iter_mut().enumerate() {
                let r = texel_dir(face, x, y, inv);
                let mut acc = Vec4::ZERO;
                let mut wsum = 0.0f32;
                for ((d, sa), v) in table.iter().zip(&values) {
                    let w = lobe.weight(r.dot(*d)) * sa;
                    if w > 0.0 {
                        acc += *v * w;
                        wsum += w;
                    }
                }
                *out = if wsum > 0.0 { acc / wsum } else { Vec4::ZERO };
            }
            progress(1);
        })
    })
}
