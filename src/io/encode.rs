//! What the codecs are told when they write ([`WriteOptions`]), and the checks a container
//! makes. Choosing the codec by format and the pixel work before it (RGBM/RGBD, the SH of a
//! .env, UltraHDR's SDR picture) is `output::encode`'s.

use super::{dds, gpu, ktx2, Decoded, FileFormat, GpuFormat, HdrEncoding, Limits};
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
