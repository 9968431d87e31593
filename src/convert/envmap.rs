//! OpenEXR's own environment maps: files whose header attribute `envmap` says how their pixels
//! map directions (OpenEXR's `ImfEnvmap`: `LatLongMap` and `CubeMap`), read by those
//! definitions into cubeforge's layouts, so a texel OpenEXR says holds direction d lands at d.
//!
//! The two differ from cubeforge's in orientation and in where texels sit: OpenEXR spans each
//! axis edge to edge in pixel centres (position p of n pixels is at p / (n - 1) of the way),
//! cubeforge puts texel centres half a texel in. So the file is resampled (bilinearly, at the
//! positions OpenEXR's functions give) rather than relabelled:
//! - `latlong`: longitude atan2(x, z) runs from +pi at the left edge to -pi at the right, so
//!   +X is a quarter turn left of the centre +Z (cubeforge's equirect has it right); latitude
//!   from +pi/2 at the top row to -pi/2 at the bottom. Read into a 2:1 equirect of the file's
//!   height, or half its width where that is less (never more texels than the file's, which
//!   the memory plans counted).
//! - `cube`: six faces +X -X +Y -Y +Z -Z stacked top to bottom, each face `min(width, height
//!   / 6)` square, oriented by `CubeMap::pixelPosition`. Read into a cube map of that size.

use crate::cube::{texel_dir, Faces};
use crate::image::Image;
use crate::layout::equirect;
use glam::Vec2;
use rayon::prelude::*;

/// An OpenEXR `latlong` map as a cubeforge equirect panorama, 2k x k for a file h pixels high
/// and w wide, k = min(h, w / 2).
pub(crate) fn latlong(img: &Image) -> Image {
    let (w, h) = (img.width as f32, img.height as f32);
    let k = img.height.min(img.width / 2).max(1);
    let (ow, oh) = (2 * k, k);
    Image::from_rows(ow, oh, |y, row| {
        for (x, out) in row.iter_mut().enumerate() {
            let u = (x as f32 + 0.5) / ow as f32;
            let v = (y as f32 + 0.5) / oh as f32;
            let d = equirect::uv_to_dir(u, v);
            let lat = d.y.clamp(-1.0, 1.0).asin();
            let lon = d.x.atan2(d.z);
            // LatLongMap::pixelPosition, pixel centres at integers.
            let px = (lon / (-2.0 * std::f32::consts::PI) + 0.5) * (w - 1.0);
            let py = (lat / -std::f32::consts::PI + 0.5) * (h - 1.0);
            *out = img.bilinear(px + 0.5, py + 0.5, false);
        }
    })
}

/// OpenEXR's position in its face `face` (0..6, +X -X +Y -Y +Z -Z) of direction `d` on that
/// face (`CubeMap::faceAndPixelPosition`), for faces of `sof` pixels.
fn position_in_face(face: usize, d: glam::Vec3, sof: f32) -> Vec2 {
    let m = (sof - 1.0) / 2.0;
    let (a, b, major) = match face / 2 {
        0 => (d.y, d.z, d.x.abs()),
        1 => (d.x, d.z, d.y.abs()),
        _ => (d.x, d.y, d.z.abs()),
    };
    Vec2::new((a / major + 1.0) * m, (b / major + 1.0) * m)
}

/// Where OpenEXR stores position `pif` of face `face` within that face's square
/// (`CubeMap::pixelPosition` less the face's row offset).
fn pixel_in_face(face: usize, pif: Vec2, sof: f32) -> Vec2 {
    let last = sof - 1.0;
    match face {
        0 => Vec2::new(pif.y, last - pif.x),
        1 => Vec2::new(last - pif.y, last - pif.x),
        2 => Vec2::new(pif.x, last - pif.y),
        3 => Vec2::new(pif.x, pif.y),
        4 => Vec2::new(last - pif.x, last - pif.y),
        _ => Vec2::new(pif.x, last - pif.y),
    }
}

/// An OpenEXR `cube` map as cubeforge's six faces, or why it holds none.
pub(crate) fn cube(img: &Image) -> Result<Faces, String> {
    let sof = img.width.min(img.height / 6);
    if sof == 0 {
        return Err(format!(
            "its envmap attribute says cube, but {}x{} pixels hold no six square faces",
            img.width, img.height
        ));
    }
    let stored: Vec<Image> = (0..6)
        .map(|f| {
            Image::from_rows(sof, sof, |y, row| {
                let src = &img.pixels[(f * sof + y) * img.width..][..sof];
                row.copy_from_slice(src);
            })
        })
        .collect();
    from_stored(&stored)
}

/// OpenEXR's six faces (+X -X +Y -Y +Z -Z, each square, of one size, as `exrenvmap` splits
/// them into `NAME+X.exr` ...) as cubeforge's faces, or why they are none.
pub(crate) fn split_cube(faces: &[Image]) -> Result<Faces, String> {
    let sof = faces.first().map_or(0, |f| f.width);
    if faces.len() != 6 || faces.iter().any(|f| f.width != sof || f.height != sof) || sof == 0 {
        return Err("OpenEXR's split faces must be six square images of one size".into());
    }
    from_stored(faces)
}

/// The faces as OpenEXR stores them, resampled into cubeforge's.
fn from_stored(stored: &[Image]) -> Result<Faces, String> {
    let sof = stored[0].width;
    let inv = 1.0 / sof as f32;
    let faces: Vec<Image> = (0..6)
        .into_par_iter()
        .map(|face| {
            Image::from_rows(sof, sof, |y, row| {
                for (x, out) in row.iter_mut().enumerate() {
                    let d = texel_dir(face, x, y, inv);
                    let p = pixel_in_face(face, position_in_face(face, d, sof as f32), sof as f32);
                    *out = stored[face].bilinear(p.x + 0.5, p.y + 0.5, false);
                }
            })
        })
        .collect();
    faces
        .try_into()
        .map_err(|_| "internal error: a cube lost a face".to_string())
}
