//! Edge fixup for samplers that filter each face on its own (GLES 2, WebGL 1, DX9-class
//! hardware, some mobile drivers): a bilinear tap near a face's edge clamps to that face, so
//! the two sides of an edge read different texels and the seam shows. Both fixups move the
//! texel centres so that the outermost texels of neighbouring faces stand for the same
//! direction, the edge itself: a clamped tap there reads the same value from either side.
//!
//! With t = (2i + 1) / n - 1 the texel centre of a face of edge n (in -1..1), the texel
//! holds the radiance at face coordinate s(t):
//! - `stretch` (Castaño, "Seamless cube map filtering", 2010): s = t n / (n - 1), the centres
//!   spread evenly from edge to edge. The shader looks up with its direction's two minor
//!   components scaled by (n - 1) / n (n the level's edge), or it reads everything shifted by
//!   up to half a texel.
//! - `warp` (cmft's `--edgeFixup warp`, after NVTT): s = t + a t^3 with a = n^2 / (n - 1)^3, the
//!   centres pulled outward most near the edges and barely at the middle. Shaders may look up
//!   unchanged (the error is at most half a texel at the edge, nothing at the centre) or undo
//!   the warp by solving t + a t^3 = s (Newton's steps from t = s; two are plenty).
//!
//! A face of edge 1 is left alone (its one texel already stands for the whole face).

#![warn(missing_docs)]

use super::{face_dir, CubeMap, CubeSampler, Faces};
use crate::image::Image;
use serde::Serialize;

/// How a cube map's texel centres are placed for per-face (non-seamless) samplers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum EdgeFixup {
    /// Texel centres where every seamless sampler expects them (the default).
    #[default]
    None,
    /// cmft's warp: s = t + a t^3, a = n^2 / (n - 1)^3.
    Warp,
    /// Castaño's stretch: s = t n / (n - 1); shaders scale their minor components by
    /// (n - 1) / n.
    Stretch,
}

impl EdgeFixup {
    /// The fixup a KTX2's metadata value names (None: unknown).
    pub fn from_name(name: &[u8]) -> Option<EdgeFixup> {
        let name = name.strip_suffix(&[0]).unwrap_or(name);
        [EdgeFixup::Warp, EdgeFixup::Stretch]
            .into_iter()
            .find(|m| m.name().as_bytes() == name)
    }

    /// The name on the command line and in files' metadata.
    pub fn name(self) -> &'static str {
        match self {
            EdgeFixup::None => "none",
            EdgeFixup::Warp => "warp",
            EdgeFixup::Stretch => "stretch",
        }
    }

    /// The face coordinate (-1..1) the texel centred at `t` holds on a face of edge `n`.
    pub fn coordinate(self, t: f64, n: usize) -> f64 {
        if n < 2 {
            return t;
        }
        let nf = n as f64;
        match self {
            EdgeFixup::None => t,
            EdgeFixup::Stretch => t * nf / (nf - 1.0),
            EdgeFixup::Warp => t + warp_factor(n) * t * t * t,
        }
    }

    /// Where a shader with true face coordinate `s` must look up on a face of edge `n` so
    /// that it reads the texels around `s`: the inverse of [`EdgeFixup::coordinate`] (for
    /// warp, Newton's steps on t + a t^3 = s, which rises everywhere).
    pub fn lookup(self, s: f64, n: usize) -> f64 {
        if n < 2 {
            return s;
        }
        let nf = n as f64;
        match self {
            EdgeFixup::None => s,
            EdgeFixup::Stretch => s * (nf - 1.0) / nf,
            EdgeFixup::Warp => {
                let a = warp_factor(n);
                let mut t = s;
                for _ in 0..8 {
                    t -= (t + a * t * t * t - s) / (1.0 + 3.0 * a * t * t);
                }
                t
            }
        }
    }
}

/// cmft's warp factor for a face of edge `n`: the a that takes the outermost texel centre,
/// t = (n - 1) / n, to the edge, s = 1.
pub fn warp_factor(n: usize) -> f64 {
    let nf = n as f64;
    nf * nf / ((nf - 1.0) * (nf - 1.0) * (nf - 1.0))
}

/// `faces` with their texels moved as `mode` places them: each texel is the seamless
/// bilinear lookup of the faces at the direction it now stands for (rows in parallel; the
/// same bytes on every thread count). `None` and faces of edge 1 come back unchanged.
pub fn apply(faces: &Faces, mode: EdgeFixup) -> Faces {
    let n = faces[0].width;
    if mode == EdgeFixup::None || n < 2 {
        return faces.clone();
    }
    let sampler = CubeSampler::with_box_mips(faces, Some(1));
    // The moved coordinate of each texel column (and row: the same numbers).
    let at: Vec<f32> = (0..n)
        .map(|i| {
            let t = (2 * i + 1) as f64 / n as f64 - 1.0;
            (0.5 * (mode.coordinate(t, n) + 1.0)) as f32
        })
        .collect();
    std::array::from_fn(|face| {
        Image::from_fn(n, n, |x, y| {
            let d = face_dir(face, at[x], at[y]);
            let alpha = faces[face].get(x, y).w;
            sampler.bilinear(d, 0).truncate().extend(alpha)
        })
    })
}

/// `faces` written with `mode` brought back to the usual texel centres: each texel is read,
/// per face and clamped (exactly how the fixup meant the faces to be sampled), where `mode`
/// stored its direction ([`EdgeFixup::lookup`]). What reading such a file does.
pub fn undo(faces: &Faces, mode: EdgeFixup) -> Faces {
    let n = faces[0].width;
    if mode == EdgeFixup::None || n < 2 {
        return faces.clone();
    }
    // Each column's (and row's) place in the stored grid, in pixel units (centres at i + 0.5).
    let at: Vec<f32> = (0..n)
        .map(|i| {
            let t = (2 * i + 1) as f64 / n as f64 - 1.0;
            ((mode.lookup(t, n) + 1.0) * 0.5 * n as f64) as f32
        })
        .collect();
    // The image's own bilinear lookup clamps at the face's edges.
    std::array::from_fn(|face| {
        Image::from_fn(n, n, |x, y| faces[face].bilinear(at[x], at[y], false))
    })
}

/// Every level of `cube` through [`apply`], each on its own grid (level k's edge is its n);
/// `None` hands the cube back untouched, no copy made.
pub fn apply_cube(cube: CubeMap, mode: EdgeFixup) -> CubeMap {
    if mode == EdgeFixup::None {
        return cube;
    }
    CubeMap {
        levels: cube.levels.iter().map(|faces| apply(faces, mode)).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outermost_centres_reach_the_edge_and_lookups_invert() {
        for n in [2, 3, 8, 256] {
            let edge = (n as f64 - 1.0) / n as f64;
            for mode in [EdgeFixup::Warp, EdgeFixup::Stretch] {
                assert!(
                    (mode.coordinate(edge, n) - 1.0).abs() < 1e-12,
                    "{mode:?} {n}"
                );
                for s in [-1.0, -0.3, 0.0, 0.7, 1.0] {
                    let t = mode.lookup(s, n);
                    assert!((mode.coordinate(t, n) - s).abs() < 1e-6, "{mode:?} {n} {s}");
                }
            }
        }
    }

    #[test]
    fn undo_brings_a_fixed_map_back() {
        use glam::Vec4;
        let n = 32;
        let f = |d: glam::Vec3| {
            Vec4::new(
                1.0 + 0.5 * (2.0 * d.x).sin() + 0.3 * d.y * d.z,
                1.0,
                1.0,
                1.0,
            )
        };
        let plain = CubeMap::from_fn(n, f).levels.remove(0);
        for mode in [EdgeFixup::Warp, EdgeFixup::Stretch] {
            let back = undo(&apply(&plain, mode), mode);
            let mut worst = 0.0f32;
            for (b, p) in back.iter().zip(&plain) {
                for (x, y) in b.pixels.iter().zip(&p.pixels) {
                    worst = worst.max((*x - *y).abs().max_element());
                }
            }
            assert!(worst < 0.01, "{mode:?}: {worst}");
        }
    }
}
