//! Face addressing, written once: the OpenGL face-selection convention between directions and
//! face coordinates, and the angles texels span, so every layout and filter agrees on them.

#![warn(missing_docs)]

use glam::Vec3;

/// Faces in file and container order: +X -X +Y -Y +Z -Z.
pub const FACE_NAMES: [&str; 6] = ["px", "nx", "py", "ny", "pz", "nz"];
/// Long names some tools use for the same faces.
pub const FACE_LONG_NAMES: [&str; 6] = ["posx", "negx", "posy", "negy", "posz", "negz"];

/// How a face image's file name says which face it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaceNaming {
    /// `px nx py ny pz nz`, `posx negx ...` or `positivex negativex ...` (Unity's
    /// `CubemapFace` names), alone or after `NAME_`: the axes themselves, in OpenGL's face
    /// table.
    Axes,
    /// OpenEXR's `exrenvmap` split faces, `NAME+X NAME-X ... NAME-Z` (its `%` replaced by the
    /// axis): each face oriented as OpenEXR's `CubeMap::pixelPosition` says, which is not the
    /// OpenGL table, so the six are read as OpenEXR's cube.
    OpenExr,
    /// Skybox packs' words (`right left top bottom front back`, or `up down`) or their
    /// two-letter suffixes (`_rt _lf _up _dn _ft _bk`): read in OpenGL's order, right +X,
    /// left -X, top +Y, bottom -Y, front +Z, back -Z (as LearnOpenGL loads its skybox).
    Skybox,
}

/// OpenEXR's `exrenvmap` face suffixes, lower case (+X -X +Y -Y +Z -Z).
const OPENEXR_AXES: [&str; 6] = ["+x", "-x", "+y", "-y", "+z", "-z"];

/// Unity's `CubemapFace` names, lower case, as scripts that save a cube's faces name them.
const UNITY_AXES: [&str; 6] = [
    "positivex",
    "negativex",
    "positivey",
    "negativey",
    "positivez",
    "negativez",
];

/// The face namings a folder of faces may use, for messages that list them.
pub const FACE_NAMINGS: &str = "px nx py ny pz nz or posx negx ... (alone or as NAME_px ...), \
     NAME_+X NAME_-X ... (OpenEXR's exrenvmap), NAME_PositiveX ... (Unity), or a skybox pack's \
     right left top bottom front back (or NAME_rt NAME_lf NAME_up NAME_dn NAME_ft NAME_bk)";

/// Skybox words for each face (+X -X +Y -Y +Z -Z), whole or after `_`, `-`, `.` or a space.
pub(crate) const SKYBOX_WORDS: [&[&str]; 6] = [
    &["right", "rt"],
    &["left", "lf"],
    &["top", "up"],
    &["bottom", "down", "dn"],
    &["front", "ft"],
    &["back", "bk"],
];

/// Which face a file's stem names (case-insensitive), and how: `px`/`posx` for +X; `right`,
/// `sky_right` or `sky_rt` for +X in a skybox pack. Two-letter words count only as suffixes
/// (`rt` alone is no face).
pub fn face_of_stem(stem: &str) -> Option<(usize, FaceNaming)> {
    let stem = stem.to_ascii_lowercase();
    if let Some(i) = (0..6).find(|&i| stem.ends_with(OPENEXR_AXES[i])) {
        return Some((i, FaceNaming::OpenExr));
    }
    let last = stem.rsplit(['_', '-', '.', ' ']).next().unwrap_or_default();
    let suffixed = last.len() < stem.len();
    let axis = |w: &str| {
        (0..6).find(|&i| w == FACE_NAMES[i] || w == FACE_LONG_NAMES[i] || w == UNITY_AXES[i])
    };
    if let Some(i) = axis(&stem).or_else(|| axis(last).filter(|_| suffixed)) {
        return Some((i, FaceNaming::Axes));
    }
    (0..6)
        .find(|&i| {
            SKYBOX_WORDS[i]
                .iter()
                .any(|w| last == *w && (w.len() > 2 || suffixed))
        })
        .map(|i| (i, FaceNaming::Skybox))
}

/// The direction through face coordinates (s, t) (0..1, row 0 is t = 0). Values outside
/// 0..1 continue the face's plane, which is how border texels find their neighbours.
#[inline]
pub fn face_dir(face: usize, s: f32, t: f32) -> Vec3 {
    let sc = 2.0 * s - 1.0;
    let tc = 2.0 * t - 1.0;
    match face {
        0 => Vec3::new(1.0, -tc, -sc),
        1 => Vec3::new(-1.0, -tc, sc),
        2 => Vec3::new(sc, 1.0, tc),
        3 => Vec3::new(sc, -1.0, -tc),
        4 => Vec3::new(sc, -tc, 1.0),
        _ => Vec3::new(-sc, -tc, -1.0),
    }
}

/// The unit direction through the centre of texel (x, y) of `face`, `inv` being 1 / the face's
/// edge: what every per-texel loop over a cube's faces looks up or sums around.
#[inline(always)]
pub fn texel_dir(face: usize, x: usize, y: usize, inv: f32) -> Vec3 {
    face_dir(face, (x as f32 + 0.5) * inv, (y as f32 + 0.5) * inv).normalize()
}

/// The face a direction selects (largest component; ties go to X, then Y) and its (s, t).
#[inline(always)]
pub fn dir_face(d: Vec3) -> (usize, f32, f32) {
    let (face, s, t) = dir_face_lanes(d.x, d.y, d.z);
    (face as usize, s, t)
}

/// Angle one texel of a face of edge `size` spans on average: a quarter turn over the edge.
pub(crate) fn texel_angle(size: usize) -> f32 {
    std::f32::consts::FRAC_PI_2 / size.max(1) as f32
}

/// Solid angle of texel (x, y) on a face of edge `n` (exact, from the area of a projected
/// rectangle), so averages over the sphere weight texels by the part of the sphere they cover.
pub(crate) fn texel_solid_angle(n: usize, x: usize, y: usize) -> f32 {
    let c = |i: usize| corner(n, i);
    (corner_area(c(x), c(y)) - corner_area(c(x), c(y + 1)) - corner_area(c(x + 1), c(y))
        + corner_area(c(x + 1), c(y + 1))) as f32
}

/// Solid angle per unit texel area at continuous texel coordinates (x, y) of a face of edge
/// `n`: the weight of a point when a texel is cut into sub-cells.
#[inline(always)]
pub(crate) fn texel_density(n: usize, x: f32, y: f32) -> f32 {
    let inv = 2.0 / n as f32;
    let (sc, tc) = (x * inv - 1.0, y * inv - 1.0);
    let q = 1.0 + sc * sc + tc * tc;
    inv * inv / (q * q.sqrt())
}

/// The angle one texel spans at continuous texel coordinates (x, y) of a face of edge `n`,
/// along the larger axis: an output texel's footprint. `inv`: 1 / n, worked out once per
/// face by the caller (not a division per texel).
#[inline(always)]
pub(crate) fn texel_footprint(inv: f32, x: f32, y: f32) -> f32 {
    // Angle of one texel at (sc, tc) on the face plane, the larger axis.
    let sc = 2.0 * x * inv - 1.0;
    let tc = 2.0 * y * inv - 1.0;
    let q = 1.0 + sc * sc + tc * tc;
    2.0 * inv * (1.0 + sc.abs().max(tc.abs()).powi(2)).sqrt() / q
}

/// `texel_solid_angle` for every texel of a face (the same on all six), row by row: one
/// arctangent per texel corner instead of four per texel. Remembered for the last few sizes:
/// one command asks for the same size several times (its resample, bright split, mips), and
/// a 512 face's table is 263 000 double-precision arctangents.
pub fn solid_angle_table(n: usize) -> Vec<f32> {
    use std::sync::Mutex;
    static RECENT: Mutex<Vec<(usize, Vec<f32>)>> = Mutex::new(Vec::new());
    let lock = || RECENT.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, t)) = lock().iter().find(|(m, _)| *m == n) {
        return t.clone();
    }
    let table = compute_solid_angle_table(n);
    // Larger tables are held for no one: a 4096 face's is 64 MB.
    if n <= 2048 {
        let mut recent = lock();
        if !recent.iter().any(|(m, _)| *m == n) {
            if recent.len() >= 4 {
                recent.remove(0);
            }
            recent.push((n, table.clone()));
        }
    }
    table
}

fn compute_solid_angle_table(n: usize) -> Vec<f32> {
    use rayon::prelude::*;
    let row = |j: usize| -> Vec<f64> {
        (0..=n)
            .map(|i| corner_area(corner(n, i), corner(n, j)))
            .collect()
    };
    // Rows of corners, then rows of texels, each in parallel for large faces (a 512 face
    // has 263 000 corners: a serial step of 10 ms otherwise). Pure functions: the same
    // values on any thread count.
    let corners: Vec<Vec<f64>> = if n >= 64 {
        (0..=n).into_par_iter().map(row).collect()
    } else {
        (0..=n).map(row).collect()
    };
    let texel_row = |y: usize| -> Vec<f32> {
        let (above, below) = (&corners[y], &corners[y + 1]);
        (0..n)
            .map(|x| (above[x] - below[x] - above[x + 1] + below[x + 1]) as f32)
            .collect()
    };
    if n >= 64 {
        (0..n).into_par_iter().flat_map_iter(texel_row).collect()
    } else {
        (0..n).flat_map(texel_row).collect()
    }
}

/// Face-plane coordinate (-1..1) of texel corner `i` on a face of edge `n`.
#[inline]
fn corner(n: usize, i: usize) -> f64 {
    i as f64 * (2.0 / n as f64) - 1.0
}

/// Solid angle of the face-plane rectangle from the face centre to (x, y).
#[inline]
fn corner_area(x: f64, y: f64) -> f64 {
    (x * y).atan2((x * x + y * y + 1.0).sqrt())
}

/// `dir_face`, written with every branch a select so loops over batches vectorise (the face
/// as a byte keeps the lanes narrow).
#[inline(always)]
pub(super) fn dir_face_lanes(x: f32, y: f32, z: f32) -> (u8, f32, f32) {
    let (ax, ay, az) = (x.abs(), y.abs(), z.abs());
    let xmaj = ax >= ay && ax >= az;
    let ymaj = !xmaj && ay >= az;
    let f = if xmaj {
        if x >= 0.0 {
            0
        } else {
            1
        }
    } else if ymaj {
        if y >= 0.0 {
            2
        } else {
            3
        }
    } else if z >= 0.0 {
        4
    } else {
        5
    };
    let sc = if xmaj {
        if x >= 0.0 {
            -z
        } else {
            z
        }
    } else if ymaj || z >= 0.0 {
        x
    } else {
        -x
    };
    let tc = if ymaj {
        if y >= 0.0 {
            z
        } else {
            -z
        }
    } else {
        -y
    };
    let ma = if xmaj {
        ax
    } else if ymaj {
        ay
    } else {
        az
    };
    let inv = if ma > 0.0 { 0.5 / ma } else { 0.0 };
    (f, sc * inv + 0.5, tc * inv + 0.5)
}

#[cfg(test)]
mod tests {
    #[test]
    fn solid_angle_table_matches_texel_solid_angle() {
        for n in [1, 2, 5, 64] {
            let table = super::solid_angle_table(n);
            let mut sum = 0.0f64;
            for y in 0..n {
                for x in 0..n {
                    assert_eq!(table[y * n + x], super::texel_solid_angle(n, x, y));
                    sum += table[y * n + x] as f64;
                }
            }
            assert!(
                (sum - 4.0 * std::f64::consts::PI / 6.0).abs() < 1e-5,
                "{n}: {sum}"
            );
        }
    }
}
