//! The cube-map containers ([`Container`]: file formats that hold six faces; `MapKind`, a
//! layout or a container, is `convert`'s, the lowest layer that knows layouts and files), and
//! what KTX2 and DDS readers check alike, in one place: a container's declared face size
//! against [`Limits`] (square faces for a cube map), its level count against the full chain, and
//! every level's byte size in its texel format, with checked arithmetic, before any texel is
//! allocated.

#![warn(missing_docs)]

use super::{FileFormat, GpuFormat, Limits};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use std::path::Path;

/// The cube-map containers: file formats that hold six faces and their mip levels, so a map
/// written as one has the faces layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Container {
    /// KTX2 cube-map container.
    Ktx2,
    /// DDS cube-map container.
    Dds,
    /// KTX 1 cube-map container (Filament).
    Ktx,
    /// Babylon.js .env prefiltered environment.
    Env,
}

impl Container {
    /// The name on the command line (`--to`) and in `info`: the extension it is written with.
    pub fn name(self) -> &'static str {
        match self {
            Container::Ktx2 => "ktx2",
            Container::Dds => "dds",
            Container::Ktx => "ktx",
            Container::Env => "env",
        }
    }

    /// The file format that stores it.
    pub fn format(self) -> FileFormat {
        match self {
            Container::Ktx2 => FileFormat::Ktx2,
            Container::Dds => FileFormat::Dds,
            Container::Ktx => FileFormat::Ktx1,
            Container::Env => FileFormat::Env,
        }
    }
}

/// A container's shape as its header declares it, checked.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shape {
    /// Six faces (a cube map) or one (a 2D texture).
    pub cube: bool,
    /// Level 0's width in texels.
    pub width: usize,
    /// Level 0's height in texels.
    pub height: usize,
    /// Levels stored (at least 1).
    pub levels: usize,
    /// The texel format.
    pub format: GpuFormat,
}

impl Shape {
    /// Checks a header's declaration: `width` x `height` against `limits` (a cube map's faces
    /// square), `level_field` (the count as stored, 0 meaning one level; `field` names it in
    /// messages) against the longest chain the size has, and the total bytes for overflow.
    #[allow(clippy::too_many_arguments)]
    pub fn check(
        path: &Path,
        limits: &Limits,
        format: GpuFormat,
        cube: bool,
        width: u32,
        height: u32,
        level_field: u32,
        field: &str,
    ) -> Result<Shape> {
        if cube {
            limits.check_cube(path, width as u64, height as u64)?;
            if width != height {
                return Err(Error::file(
                    path,
                    format!(
                        "invalid cube map: faces must be square, but they are {width}x{height}"
                    ),
                ));
            }
        } else {
            limits.check(path, width as u64, height as u64)?;
        }
        // Both fit the limits, so in usize.
        let (w, h) = (width as usize, height as usize);
        let levels = (level_field as usize).max(1);
        let most = CubeMap::full_chain_len(w.max(h));
        if levels > most {
            let what = if cube { "cube map" } else { "2D texture" };
            return Err(Error::file(
                path,
                format!(
                    "invalid header: {field} is {level_field}, but a {w}x{h} {what} has at most {most} mip levels"
                ),
            ));
        }
        let shape = Shape {
            cube,
            width: w,
            height: h,
            levels,
            format,
        };
        (0..levels)
            .try_fold(0u64, |sum, l| {
                sum.checked_add(shape.level_bytes_checked(l)?)
            })
            .ok_or_else(|| Error::file(path, "invalid header: level sizes overflow"))?;
        Ok(shape)
    }

    /// Faces per level: 6 or 1.
    pub fn faces(&self) -> usize {
        if self.cube {
            6
        } else {
            1
        }
    }

    /// Width and height of level `l`.
    pub fn level_size(&self, l: usize) -> (usize, usize) {
        ((self.width >> l).max(1), (self.height >> l).max(1))
    }

    fn level_bytes_checked(&self, l: usize) -> Option<u64> {
        let (w, h) = self.level_size(l);
        self.format
            .image_bytes(w as u64, h as u64)?
            .checked_mul(self.faces() as u64)
    }

    /// Bytes of one face of level `l` (whole blocks); fits, as [`check`](Self::check) summed them.
    pub fn face_bytes(&self, l: usize) -> usize {
        let (w, h) = self.level_size(l);
        self.format.image_bytes(w as u64, h as u64).unwrap_or(0) as usize
    }

    /// Bytes of all faces of level `l`.
    pub fn level_bytes(&self, l: usize) -> u64 {
        self.level_bytes_checked(l).unwrap_or(0)
    }

    /// Bytes of every level.
    pub fn total_bytes(&self) -> u64 {
        (0..self.levels).map(|l| self.level_bytes(l)).sum()
    }

    /// What level `l` holds, for messages: "six 8x8 RGBA16F faces", "an 8x8 BC7 UNORM image".
    pub fn holds(&self, l: usize) -> String {
        let (w, h) = self.level_size(l);
        if self.cube {
            format!("six {w}x{h} {} faces", self.format.name())
        } else {
            format!("a {w}x{h} {} image", self.format.name())
        }
    }
}
