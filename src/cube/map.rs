//! The stored cube map: six square faces per level, built from images or a function, and its
//! solid-angle-weighted box mips.

#![warn(missing_docs)]

use super::face::{solid_angle_table, texel_dir, FACE_NAMES};
use crate::error::{Error, Result};
use crate::image::Image;
use glam::{Vec3, Vec4};

/// Six square faces of one size.
pub type Faces = [Image; 6];

/// A cube map with one or more mip levels (level 0 the largest).
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap {
    /// The six faces of each level, in [`FACE_NAMES`] order; each level halves the edge of
    /// the one before.
    pub levels: Vec<Faces>,
}

impl CubeMap {
    /// Checks that six faces are square and of one size.
    pub fn from_faces(faces: Faces) -> crate::Result<CubeMap> {
        misfit(&faces, |i| format!("face {}", FACE_NAMES[i]))
            .map(|(i, why)| Err(crate::Error::usage(format!("face {} {why}", FACE_NAMES[i]))))
            .unwrap_or(Ok(CubeMap {
                levels: vec![faces],
            }))
    }

    /// Edge of level 0's faces.
    pub fn size(&self) -> usize {
        self.levels[0][0].width
    }

    /// Fills every texel of a `size` cube with `f(direction of its centre)`.
    pub fn from_fn(size: usize, f: impl Fn(Vec3) -> Vec4 + Sync) -> CubeMap {
        let inv = 1.0 / size as f32;
        let faces = std::array::from_fn(|face| {
            Image::from_fn(size, size, |x, y| f(texel_dir(face, x, y, inv)))
        });
        CubeMap {
            levels: vec![faces],
        }
    }

    /// Number of levels in a full chain for a face edge: down to 1 x 1.
    pub fn full_chain_len(size: usize) -> usize {
        (usize::BITS - size.max(1).leading_zeros()) as usize
    }

    /// Keeps level 0 and rebuilds `count` levels (None: the full chain) as plain mipmaps,
    /// each texel the solid-angle-weighted mean of the 2x2 texels above it.
    pub fn with_box_mips(mut self, count: Option<usize>) -> CubeMap {
        let full = Self::full_chain_len(self.size());
        let count = count.unwrap_or(full).clamp(1, full);
        self.levels.truncate(1);
        while self.levels.len() < count {
            let prev = self.levels.last().unwrap();
            let n = prev[0].width;
            let weights = solid_angle_table(n);
            let next =
                std::array::from_fn(|f| box_reduce_face(&prev[f], n, &weights, Vec4::INFINITY));
            self.levels.push(next);
        }
        self
    }
}

/// Each texel the mean of the 2x2 above it (each first clamped to `ceiling`), weighted by
/// their solid angles (`weights`, one face's table) so the mean radiance over the sphere is kept.
pub(crate) fn box_reduce_face(src: &Image, n: usize, weights: &[f32], ceiling: Vec4) -> Image {
    let m = (n / 2).max(1);
    if n == 1 {
        return src.clone();
    }
    Image::from_fn(m, m, |x, y| {
        let mut acc = Vec4::ZERO;
        let mut wsum = 0.0;
        for dy in 0..2 {
            for dx in 0..2 {
                let (sx, sy) = (2 * x + dx, 2 * y + dy);
                let w = weights[sy * n + sx];
                acc += src.get(sx, sy).min(ceiling) * w;
                wsum += w;
            }
        }
        acc / wsum
    })
}

/// Six faces made by a fallible `f` (face index 0..6), the first error returned.
pub(crate) fn try_faces<E>(
    mut f: impl FnMut(usize) -> std::result::Result<Image, E>,
) -> std::result::Result<Faces, E> {
    let [a, b, c, d, e, g] = [0, 1, 2, 3, 4, 5];
    Ok([f(a)?, f(b)?, f(c)?, f(d)?, f(e)?, f(g)?])
}

/// Reads a cube map from six same-size images, naming the file of a face that does not fit.
pub(crate) fn faces_from_images(
    images: Vec<Image>,
    names: &[std::path::PathBuf],
) -> Result<CubeMap> {
    if let Some((i, why)) = misfit(&images, |i| names[i].display().to_string()) {
        return Err(Error::file(&names[i], format!("face {why}")));
    }
    let faces: Faces = images
        .try_into()
        .map_err(|_| Error::usage("a cube map needs exactly six faces"))?;
    Ok(CubeMap {
        levels: vec![faces],
    })
}

/// The first face that is empty, not square, or not the size of the first, with why; `name`
/// says how the first face is called (a face name, a file).
fn misfit(faces: &[Image], name: impl Fn(usize) -> String) -> Option<(usize, String)> {
    let n = faces.first().map_or(0, |f| f.width);
    faces.iter().enumerate().find_map(|(i, f)| {
        let (w, h) = (f.width, f.height);
        if w != h {
            Some((i, format!("is {w}x{h}, not square")))
        } else if w != n {
            Some((
                i,
                format!(
                    "is {w}x{h} but {} is {n}x{n}: all six faces must be the same size",
                    name(0)
                ),
            ))
        } else if n == 0 {
            Some((i, "is empty".to_string()))
        } else {
            None
        }
    })
}
