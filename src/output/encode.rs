//! Encoding by format: an image or a cube map as the bytes of the format an output was
//! resolved to ([`super::Encoding::resolve`]). The pixel work a format needs before its codec
//! sits here, above `io`: RGBM/RGBD texels, the irradiance polynomial of a Babylon .env, and
//! UltraHDR's SDR picture and the light its gain-map fit is measured by.

use crate::cube::{CubeMap, EdgeFixup};
use crate::error::{Error, Result};
use crate::filter::sh_engines::SphericalPolynomial;
use crate::image::{linear_to_srgb, Image};
use crate::io::{
    babylon_env, dds, exr, hdr8, ktx1, ktx2, raster, rgbe, ultrahdr, unknown_ext, zstd_needs_ktx2,
    ExrFloat, FileFormat, GpuFormat, WriteOptions,
};
use crate::layout::Projection;
use crate::tonemap::Tonemap;
use rayon::prelude::*;
use std::path::Path;

/// Encodes an image in the format its name asks for ([`encode_image_as`]).
pub fn encode_image(path: &Path, img: &Image, opts: &WriteOptions) -> Result<Vec<u8>> {
    let format = FileFormat::from_extension(path).ok_or_else(|| unknown_ext(path))?;
    encode_image_as(format, path, img, opts)
}

/// Encodes an image as `format`, decided once by the output's resolution
/// ([`crate::output::Encoding::resolve`]); `path` names the file in errors only.
pub(crate) fn encode_image_as(
    format: FileFormat,
    path: &Path,
    img: &Image,
    opts: &WriteOptions,
) -> Result<Vec<u8>> {
    encode_image_with(format, path, img, opts, None)
}

/// [`encode_image_as`] with a JPEG written as UltraHDR, its SDR picture made by `gain_map`'s
/// curve ([`super::Target::gain_map`]).
pub(crate) fn encode_image_with(
    format: FileFormat,
    path: &Path,
    img: &Image,
    opts: &WriteOptions,
    gain_map: Option<Tonemap>,
) -> Result<Vec<u8>> {
    if let Some(e) = opts.hdr_encoding {
        let plain = hdr8::check(path, format, opts)?;
        let bytes = encode_image_with(format, path, &e.encode_image(img), &plain, gain_map)?;
        return Ok(hdr8::marked(format, bytes, e));
    }
    match format {
        FileFormat::Exr => {
            exr::encode(img, opts.exr_float == ExrFloat::F32).map_err(|e| Error::file(path, e))
        }
        FileFormat::Hdr => Ok(rgbe::encode(img)),
        FileFormat::UltraHdr => {
            let curve = gain_map.unwrap_or_default();
            ultrahdr_encode(img, curve, ultrahdr::Reader::Format, false)
                .map(|(bytes, _)| bytes)
                .map_err(|e| Error::file(path, e))
        }
        f => match f.container() {
            Some(c) => Err(Error::file(
                path,
                format!(
                    "{} holds cube maps: write a cube map ({} {})",
                    f.name(),
                    crate::error::param("to"),
                    c.name()
                ),
            )),
            None if f == FileFormat::Jpeg && gain_map.is_some() => {
                encode_image_with(FileFormat::UltraHdr, path, img, opts, gain_map)
            }
            None => raster::encode(img, f, opts).map_err(|e| Error::file(path, e)),
        },
    }
}

/// Encodes a cube map (every level) as KTX2, DDS or KTX in `format`, or as a Babylon env
/// (RGBD, with the irradiance polynomial of its level 0), by the name's extension.
pub fn encode_cube(path: &Path, cube: &CubeMap, format: GpuFormat) -> Result<Vec<u8>> {
    encode_cube_with(
        path,
        cube,
        &WriteOptions {
            gpu_format: format,
            ..WriteOptions::default()
        },
        &[],
    )
}

/// Encodes a cube map (every level) as KTX2 or DDS, by the name's extension, in
/// `opts.gpu_format`, with KTX2 key/value entries `extra` ([`encode_cube_as`]).
pub fn encode_cube_with(
    path: &Path,
    cube: &CubeMap,
    opts: &WriteOptions,
    extra: &[(&str, &[u8])],
) -> Result<Vec<u8>> {
    match FileFormat::from_extension(path) {
        Some(f) => encode_cube_as(f, path, cube, opts, extra),
        None => Err(not_a_container(path)),
    }
}

/// Encodes a cube map (every level) as the container `format` (KTX2, DDS, KTX or .env), in
/// `opts.gpu_format`, with KTX2 key/value entries `extra` (the caller's: cubeforge's own
/// only with `opts.cubeforge_keys`); `path` names the file in errors only. Zstandard supercompression (`opts.zstd`) is KTX2's: another container with it is
/// refused.
pub(crate) fn encode_cube_as(
    format: FileFormat,
    path: &Path,
    cube: &CubeMap,
    opts: &WriteOptions,
    extra: &[(&str, &[u8])],
) -> Result<Vec<u8>> {
    if let Some(e) = opts.hdr_encoding {
        let plain = hdr8::check(path, format, opts)?;
        let mut kv = extra.to_vec();
        if opts.cubeforge_keys {
            kv.push((hdr8::KTX2_KEY, e.name().as_bytes()));
        }
        return encode_cube_as(format, path, &hdr8::encode_cube(cube, e), &plain, &kv);
    }
    match format {
        FileFormat::Ktx2 => {
            let fixup = opts.edge_fixup.name().as_bytes();
            let mut kv = extra.to_vec();
            if opts.cubeforge_keys && opts.edge_fixup != EdgeFixup::None {
                kv.push((ktx2::EDGE_FIXUP_KEY, fixup));
            }
            ktx2::encode_cube_with(cube, opts.gpu_format, opts.zstd, &kv)
                .map_err(|e| Error::file(path, e))
        }
        FileFormat::Dds | FileFormat::Ktx1 | FileFormat::Env if opts.zstd.is_some() => {
            Err(zstd_needs_ktx2(path))
        }
        FileFormat::Dds => dds::encode(cube, opts.gpu_format).map_err(|e| Error::file(path, e)),
        FileFormat::Ktx1 => {
            let format = ktx1::Ktx1Format::from_gpu(opts.gpu_format)
                .map_err(|e| Error::unsupported(path, e))?;
            ktx1::encode(cube, format, &[]).map_err(|e| Error::file(path, e))
        }
        FileFormat::Env => {
            let sh = crate::filter::sh::project(cube);
            let poly = SphericalPolynomial::from_radiance_sh(&sh);
            babylon_env::encode(
                cube,
                Some(&poly.coefficients()),
                babylon_env::DEFAULT_LOD_GENERATION_SCALE,
            )
            .map_err(|e| Error::file(path, e))
        }
        _ => Err(not_a_container(path)),
    }
}

fn not_a_container(path: &Path) -> Error {
    Error::file(
        path,
        "a cube-map container must be named .ktx2, .dds, .ktx or .env",
    )
}

/// `img` (linear radiance) as an UltraHDR JPEG ([`ultrahdr::encode`]) whose SDR picture is
/// `curve` of the radiance (ACES for `None`), its light weighed as an equirect's where
/// `equirect` says the image is one.
pub fn ultrahdr_encode(
    img: &Image,
    curve: Tonemap,
    reader: ultrahdr::Reader,
    equirect: bool,
) -> std::result::Result<(Vec<u8>, ultrahdr::GainStats), String> {
    let light = move |img: &Image| {
        if equirect {
            let grid = crate::flux::Grid::Projection(Projection::Equirect, img.width, img.height);
            return crate::flux::mean_radiance(grid, &[img]);
        }
        img.pixels
            .par_iter()
            .map(|p| [p.x as f64, p.y as f64, p.z as f64])
            .reduce(|| [0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
    };
    ultrahdr::encode(img, &sdr_picture(img, curve), reader, &light)
}

/// The SDR picture of an UltraHDR file: `curve` (ACES for `None`) of the radiance as sRGB
/// RGB8. The curve scales each texel by what it does to its largest channel: hues kept, so
/// the three channels' gains are alike (a grey gain map, which the JPEG keeps well: its chroma
/// is coarse) and a sun stays yellow in the picture.
fn sdr_picture(img: &Image, curve: Tonemap) -> Vec<u8> {
    let curve = if curve == Tonemap::None {
        Tonemap::Aces
    } else {
        curve
    };
    img.pixels
        .par_iter()
        .flat_map_iter(|p| {
            let top = p.x.max(p.y).max(p.z).max(0.0);
            let k = if top > 0.0 {
                curve.curve(top) / top
            } else {
                0.0
            };
            [p.x, p.y, p.z].map(|v| crate::io::unorm8(linear_to_srgb(v.max(0.0) * k)))
        })
        .collect()
}
