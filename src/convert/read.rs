//! Reading a file whole: `io` decodes it as stored, and what the file says of its texels is
//! undone here, above the codecs (issue 46): OpenEXR's own layouts resampled into
//! cubeforge's, RGBM/RGBD in 8 bits decoded to radiance, and a KTX2 written with an edge
//! fixup has its texels moved back to the usual centres.

use super::envmap;
use crate::cube::{fixup, CubeMap, EdgeFixup};
use crate::error::{param, Error, Result};
use crate::image::Image;
use crate::io::{
    self, hdr8::KTX2_KEY, Decoded, Envmap, FileFormat, HdrEncoding, Meta, ReadOptions,
};
use rayon::prelude::*;
use std::path::Path;

/// Reads any supported file, its texels as radiance: NaN, infinite and negative values
/// replaced by 0 (counted in `Meta::replaced_values`), RGBM/RGBD decoded, an edge fixup
/// undone.
pub fn read(path: &Path, opts: &ReadOptions) -> Result<(Decoded, Meta)> {
    let (decoded, meta) = io::decode_file(path, opts)?;
    undo(path, decoded, meta)
}

/// [`read`] without the sanitizing pass: the values as the file stores them (`info`).
pub fn read_raw(path: &Path, opts: &ReadOptions) -> Result<(Decoded, Meta)> {
    let (decoded, meta) = io::decode_file_raw(path, opts)?;
    undo(path, decoded, meta)
}

/// What `meta.undo` names, undone.
fn undo(path: &Path, decoded: Decoded, meta: Meta) -> Result<(Decoded, Meta)> {
    let decoded = match (meta.undo.envmap, decoded) {
        (Some(Envmap::LatLong), Decoded::Image(img)) => Decoded::Image(envmap::latlong(&img)),
        (Some(Envmap::Cube), Decoded::Image(img)) => Decoded::Cube(CubeMap {
            levels: vec![envmap::cube(&img).map_err(|e| Error::file(path, e))?],
        }),
        (_, decoded) => decoded,
    };
    let (decoded, mut meta) = match meta.undo.hdr_encoding {
        Some((e, given)) => hdr8(path, e, given, decoded, meta)?,
        None => (decoded, meta),
    };
    let decoded = match (meta.undo.edge_fixup, decoded) {
        (Some(mode), Decoded::Cube(cube)) => Decoded::Cube(fixed_back(&mut meta, mode, cube)),
        (_, decoded) => decoded,
    };
    meta.undo = Default::default();
    Ok((decoded, meta))
}

/// A KTX2 written with an edge fixup, its texels moved back where every other reader of
/// cube maps expects them (and `info` says so).
fn fixed_back(meta: &mut Meta, mode: EdgeFixup, cube: CubeMap) -> CubeMap {
    meta.declared = Some(format!(
        "edge fixup {}: texels read back to the usual centres",
        mode.name()
    ));
    let levels = cube.levels.iter().map(|f| fixup::undo(f, mode)).collect();
    CubeMap { levels }
}

/// An image read as stored (values k / 255) decoded in place.
fn decode_image(e: HdrEncoding, img: &mut Image) {
    img.pixels.par_iter_mut().for_each(|p| {
        let b = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        *p = e.decode([b(p.x), b(p.y), b(p.z), b(p.w)]);
    });
}

/// A file read as stored, decoded: its 8-bit texels become radiance, and `meta` says so. A
/// float file, or one read through sRGB, is refused: its values are not the encoding's bytes.
/// `given`: the encoding was asked for (`--decode`), not named by the file's own metadata.
fn hdr8(
    path: &Path,
    e: HdrEncoding,
    given: bool,
    decoded: Decoded,
    mut meta: Meta,
) -> Result<(Decoded, Meta)> {
    let eight_bit = matches!(
        meta.file_format,
        FileFormat::Png | FileFormat::Tga | FileFormat::Ktx2 | FileFormat::Dds
    ) && !meta.hdr
        && meta.color_space == crate::image::ColorSpace::Linear
        && !meta.pixel_format.contains("16");
    if !eight_bit {
        let asked = if given {
            format!("{} {}: this file holds", param("decode"), e.name())
        } else {
            format!("its metadata ({KTX2_KEY}) names {}, but it holds", e.name())
        };
        return Err(Error::file(
            path,
            format!(
                "{asked} {} {}, not 8-bit RGBA data (a PNG, or a KTX2/DDS of rgba8)",
                meta.file_format.name(),
                meta.pixel_format
            ),
        ));
    }
    let decoded = match decoded {
        Decoded::Image(mut img) => {
            decode_image(e, &mut img);
            Decoded::Image(img)
        }
        Decoded::Cube(mut cube) => {
            for faces in &mut cube.levels {
                faces.iter_mut().for_each(|f| decode_image(e, f));
            }
            Decoded::Cube(cube)
        }
    };
    meta.hdr = true;
    meta.pixel_format = format!("{} as {}", meta.pixel_format, e.name().to_uppercase());
    Ok((decoded, meta))
}
