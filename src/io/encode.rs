//! Encoding by format: an image or a cube map as the bytes of the format an output was
//! resolved to ([`crate::output::Encoding::resolve`]), and the checks a container makes.

use super::{
    babylon_env, dds, exr, gpu, hdr8, ktx1, ktx2, raster, rgbe, ultrahdr, unknown_ext, Decoded,
    FileFormat, GpuFormat, HdrEncoding, Limits,
};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::image::Image;
use std::path::Path;

/// How to write single images.
#[derive(Clone, Copy, Debug, Default)]
pub struct WriteOptions {
    /// Store 8- and 16-bit values as data: no sRGB encode.
    pub linear: bool,
    /// 16 bits per channel for PNG.
    pub png16: bool,
    /// Texel format of KTX2 and DDS.
    pub gpu_format: GpuFormat,
    /// Zstandard level (1 to 22) of KTX2 supercompression; None writes the levels plain.
    pub zstd: Option<i32>,
    /// Sample type of EXR output.
    pub exr_float: ExrFloat,
    /// JPEG outputs as UltraHDR (a gain map over an SDR picture made by this curve; `None`
    /// means ACES there): radiance kept, not clipped.
    pub gain_map: Option<crate::tonemap::Tonemap>,
    /// Texel centres moved for per-face samplers (cube outputs; KTX2 records it under
    /// [`ktx2::EDGE_FIXUP_KEY`] with `cubeforge_keys`).
    pub edge_fixup: crate::cube::EdgeFixup,
    /// 8-bit PNG or RGBA8 KTX2/DDS texels as RGBM or RGBD: HDR in 8 bits.
    pub hdr_encoding: Option<HdrEncoding>,
    /// KTX2 outputs also carry cubeforge's own keys (encoding, edge fixup, chain levels):
    /// off by default, since `ktx validate -e` rejects every key the KTX2 specification does
    /// not define (warning 7010).
    pub cubeforge_keys: bool,
}

/// The sample type of EXR output: half floats (what tools expect, largest 65504) or 32-bit
/// floats (twice the size, for radiance beyond that: an unclipped sun reaches 1e5 and more).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum ExrFloat {
    /// 16-bit half floats.
    #[default]
    Half,
    /// 32-bit floats.
    F32,
}

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
    if let Some(e) = opts.hdr_encoding {
        let plain = hdr8::check(path, format, opts)?;
        let bytes = encode_image_as(format, path, &e.encode_image(img), &plain)?;
        return Ok(hdr8::marked(format, bytes, e));
    }
    match format {
        FileFormat::Exr => {
            exr::encode(img, opts.exr_float == ExrFloat::F32).map_err(|e| Error::file(path, e))
        }
        FileFormat::Hdr => Ok(rgbe::encode(img)),
        FileFormat::UltraHdr => {
            let curve = opts.gain_map.unwrap_or_default();
            ultrahdr::encode(img, curve, ultrahdr::Reader::Format, false)
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
            None if f == FileFormat::Jpeg && opts.gain_map.is_some() => {
                encode_image_as(FileFormat::UltraHdr, path, img, opts)
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
            if opts.cubeforge_keys && opts.edge_fixup != crate::cube::EdgeFixup::None {
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
            let poly = babylon_env::SphericalPolynomial::from_radiance_sh(&sh);
            babylon_env::encode(cube, Some(&poly), babylon_env::DEFAULT_LOD_GENERATION_SCALE)
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

/// Refuses `format` for a `container` file (named `path`) that cannot hold it, or that this
/// build cannot encode: ASTC goes into KTX2 only (DXGI and cubeforge's KTX 1 define none) and
/// needs the cargo feature `astc`. Jobs call it in `validate`, before any work.
pub fn check_gpu_format(path: &Path, container: FileFormat, format: GpuFormat) -> Result<()> {
    if !format.is_astc() {
        return Ok(());
    }
    if container != FileFormat::Ktx2 {
        return Err(Error::file(
            path,
            format!(
                "{} holds no {}: write .ktx2",
                container.name(),
                format.name()
            ),
        ));
    }
    format.check_built().map_err(Error::usage)
}

/// The error for `--zstd` with an output that is not KTX2.
pub fn zstd_needs_ktx2(path: &Path) -> Error {
    Error::file(
        path,
        format!(
            "{z} supercompresses KTX2 only (DDS has no supercompression): write .ktx2 or leave out {z}",
            z = crate::error::param("zstd")
        ),
    )
}

/// How close level 0 of a KTX2 or DDS file's `bytes` is to `original` (the faces of a cube
/// map, or a 2D texture's image), in dB by [`gpu::psnr`]; None when they cannot be compared.
pub fn container_psnr(bytes: &[u8], format: GpuFormat, original: &[&Image]) -> Option<f64> {
    let name = Path::new("encoded");
    let limits = Limits {
        max_pixels: u64::MAX,
        max_dimension: u32::MAX,
        max_memory: u64::MAX,
        session: Default::default(),
    };
    let (decoded, _) = match FileFormat::from_magic(bytes)? {
        FileFormat::Ktx2 => ktx2::decode(bytes, name, &limits).ok()?,
        FileFormat::Dds => dds::decode(bytes, name, &limits).ok()?,
        _ => return None,
    };
    let level0: Vec<&Image> = match &decoded {
        Decoded::Cube(c) => c.levels.first()?.iter().collect(),
        Decoded::Image(img) => vec![img],
    };
    (level0.len() == original.len())
        .then(|| gpu::psnr(format, original.iter().copied(), level0.iter().copied()))
}
