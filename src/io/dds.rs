//! DDS cube maps with every mip level (and 2D textures, read as their level 0 image).
//!
//! Writes a DX10-header cube map in any [`GpuFormat`] (DXGI R16G16B16A16_FLOAT,
//! R32G32B32A32_FLOAT, R8G8B8A8_UNORM_SRGB, R8G8B8A8_UNORM, BC6H_UF16, BC7_UNORM(_SRGB),
//! R9G9B9E5_SHAREDEXP, R11G11B10_FLOAT) with the cube-map caps and the TEXTURECUBE misc flag;
//! the texels follow face-major, as DDS wants: for each face +X -X +Y -Y +Z -Z, all its levels
//! (block formats in whole 4x4 blocks). DDS has no supercompression.
//!
//! Reads those DX10 formats and the legacy-header forms of the first four: FourCC 113
//! (A16B16G16R16F), FourCC 116 (A32B32G32R32F) and the 32-bit RGBA8 masks (A8B8G8R8, X8B8G8R8,
//! and the BGRA-ordered A8R8G8B8, X8R8G8B8), which have no colour-space flag and are read as
//! UNORM. The headers are parsed with `ddsfile`; the declared shape is checked against
//! [`Limits`] by [`super::container::Shape`] (shared with KTX2), and every size against the
//! file's length with checked arithmetic, before any texel is allocated.

#![warn(missing_docs)]

use super::container::Shape;
use super::guard::{caught, one_line};
use super::{Decoded, FileFormat, GpuFormat, Limits, Meta};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::image::Image;
use ddsfile::{
    AlphaMode, Caps2, D3D10ResourceDimension, D3DFormat, DxgiFormat, FourCC, Header, Header10,
    MiscFlag, PixelFormatFlags,
};
use std::path::Path;

const MAGIC: &[u8; 4] = b"DDS ";
/// Magic plus the 124-byte header.
const HEADER_END: usize = 4 + 124;
/// ... plus the 20-byte DX10 header.
const HEADER10_END: usize = HEADER_END + 20;

const SUPPORTED: &str =
    "cubeforge reads RGBA16F, RGBA32F, RGBA8 sRGB/UNORM, BC6H UF16, BC7 sRGB/UNORM, R9G9B9E5 and R11G11B10";

/// The DXGI format of `format`; None for ASTC, which DXGI does not define.
fn dxgi_format(format: GpuFormat) -> Option<DxgiFormat> {
    Some(match format {
        GpuFormat::Rgba16f => DxgiFormat::R16G16B16A16_Float,
        GpuFormat::Rgba32f => DxgiFormat::R32G32B32A32_Float,
        GpuFormat::Rgba8Srgb => DxgiFormat::R8G8B8A8_UNorm_sRGB,
        GpuFormat::Rgba8 => DxgiFormat::R8G8B8A8_UNorm,
        GpuFormat::Bc6h => DxgiFormat::BC6H_UF16,
        GpuFormat::Bc7 => DxgiFormat::BC7_UNorm,
        GpuFormat::Bc7Srgb => DxgiFormat::BC7_UNorm_sRGB,
        GpuFormat::Rgb9e5 => DxgiFormat::R9G9B9E5_SharedExp,
        GpuFormat::Rg11b10 => DxgiFormat::R11G11B10_Float,
        GpuFormat::AstcHdr4x4 | GpuFormat::AstcHdr6x6 | GpuFormat::UastcHdr4x4 => return None,
    })
}

fn from_dxgi(raw: u32) -> Option<GpuFormat> {
    GpuFormat::ALL
        .into_iter()
        .find(|&f| dxgi_format(f).is_some_and(|d| d as u32 == raw))
}

/// Encodes every level of `cube` as a DX10 DDS cube map in `format`; every face of every
/// level is encoded at once, in parallel.
pub fn encode(cube: &CubeMap, format: GpuFormat) -> std::result::Result<Vec<u8>, String> {
    use rayon::prelude::*;
    let size = cube.size();
    let edge = u32::try_from(size)
        .ok()
        .filter(|n| n.checked_mul(format.block_bytes() as u32).is_some())
        .ok_or_else(|| format!("faces of {size}x{size} pixels are too large for DDS"))?;
    let levels = u32::try_from(cube.levels.len()).map_err(|_| "too many mip levels for DDS")?;
    let dxgi = dxgi_format(format).ok_or_else(|| {
        format!(
            "DDS has no {} format (DXGI defines no ASTC): write .ktx2",
            format.name()
        )
    })?;
    let mut header = Header::new_dxgi(
        edge,
        edge,
        None,
        dxgi,
        Some(levels),
        Some(6),
        Some(Caps2::CUBEMAP | Caps2::CUBEMAP_ALLFACES),
    )
    .map_err(|e| format!("cannot write a DDS header: {e}"))?;
    // With a DX10 header the pixel format is the FourCC alone, as Microsoft's tools write it;
    // readers that look at DDPF_RGB before the FourCC would otherwise take it for bit masks.
    header.spf.flags = PixelFormatFlags::FOURCC;
    header.spf.rgb_bit_count = None;
    let header10 = Header10::new(
        dxgi,
        true,
        D3D10ResourceDimension::Texture2D,
        1,
        AlphaMode::Unknown,
    );

    // Face-major: for each face, all its levels.
    let images: Vec<&Image> = (0..6)
        .flat_map(|face| cube.levels.iter().map(move |l| &l[face]))
        .collect();
    let encoded: Vec<Vec<u8>> = images
        .par_iter()
        .map(|img| format.encode_image(img))
        .collect::<std::result::Result<_, String>>()?;
    let texels: usize = encoded.iter().map(Vec::len).sum();
    let mut out = Vec::with_capacity(HEADER10_END + texels);
    out.extend_from_slice(MAGIC);
    header
        .write(&mut out)
        .map_err(|e| format!("cannot write a DDS header: {e}"))?;
    header10
        .write(&mut out)
        .map_err(|e| format!("cannot write a DDS header: {e}"))?;
    for bytes in encoded {
        out.extend_from_slice(&bytes);
    }
    Ok(out)
}

/// How the stored bytes of an 8-bit legacy format map to RGBA.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Order {
    /// As stored (R, G, B, A).
    Rgba,
    /// R, G, B, then an unused byte: alpha is 1.
    Rgbx,
    /// B, G, R, A.
    Bgra,
    /// B, G, R, then an unused byte.
    Bgrx,
}

fn le_u32(bytes: &[u8], offset: usize) -> Option<u32> {
    let b = bytes.get(offset..offset.checked_add(4)?)?;
    Some(u32::from_le_bytes(b.try_into().ok()?))
}

/// The texel format, the order of its bytes, where the texels start and whether it is a
/// cube map: from the DX10 header, or the legacy pixel format's masks.
fn format_of(
    bytes: &[u8],
    header: &Header,
    path: &Path,
) -> Result<(GpuFormat, Order, usize, bool)> {
    let err = |msg: String| Error::file(path, msg);
    let file_len = bytes.len();
    let invalid = |e: String| err(format!("invalid DDS header: {}", one_line(&e)));
    let is_dx10 = header.spf.fourcc == Some(FourCC(FourCC::DX10));
    Ok(if is_dx10 {
        if file_len < HEADER10_END {
            return Err(err(format!(
                "truncated DDS file: {file_len} bytes, shorter than its {HEADER10_END}-byte DX10 header"
            )));
        }
        let raw = le_u32(bytes, HEADER_END).unwrap_or(0);
        let format = from_dxgi(raw)
            .ok_or_else(|| err(format!("unsupported DXGI format {raw} ({SUPPORTED})")))?;
        let invalid = |e: String| err(format!("invalid DDS DX10 header: {}", one_line(&e)));
        let h10 = caught(|| Header10::read(&bytes[HEADER_END..HEADER10_END]))
            .map_err(invalid)?
            .map_err(|e| invalid(e.to_string()))?;
        if h10.resource_dimension != D3D10ResourceDimension::Texture2D {
            return Err(err(format!(
                "a {:?} resource is not supported: cubeforge reads 2D textures and cube maps",
                h10.resource_dimension
            )));
        }
        let cube = h10.misc_flag.contains(MiscFlag::TEXTURECUBE);
        if h10.array_size > 1 {
            return Err(err(format!(
                "texture arrays are not supported (arraySize {})",
                h10.array_size
            )));
        }
        if h10.array_size == 0 {
            return Err(err("invalid DDS DX10 header: arraySize is 0".into()));
        }
        (format, Order::Rgba, HEADER10_END, cube)
    } else {
        let d3d = caught(|| D3DFormat::try_from_pixel_format(&header.spf)).map_err(invalid)?;
        let (format, order) = match d3d {
            Some(D3DFormat::A16B16G16R16F) => (GpuFormat::Rgba16f, Order::Rgba),
            Some(D3DFormat::A32B32G32R32F) => (GpuFormat::Rgba32f, Order::Rgba),
            Some(D3DFormat::A8B8G8R8) => (GpuFormat::Rgba8, Order::Rgba),
            Some(D3DFormat::X8B8G8R8) => (GpuFormat::Rgba8, Order::Rgbx),
            Some(D3DFormat::A8R8G8B8) => (GpuFormat::Rgba8, Order::Bgra),
            Some(D3DFormat::X8R8G8B8) => (GpuFormat::Rgba8, Order::Bgrx),
            Some(other) => {
                return Err(err(format!(
                    "unsupported DDS format {other:?} ({SUPPORTED})"
                )))
            }
            None => {
                return Err(err(format!(
                    "unsupported or unknown DDS pixel format ({SUPPORTED})"
                )))
            }
        };
        let cube = header.caps2.contains(Caps2::CUBEMAP);
        if cube && !header.caps2.contains(Caps2::CUBEMAP_ALLFACES) {
            return Err(err(
                "not a cube map (a partial cube map: some faces are missing)".into(),
            ));
        }
        (format, order, HEADER_END, cube)
    })
}

/// Reads a DDS cube map with all its levels, or level 0 of a 2D texture as an image.
pub fn decode(bytes: &[u8], path: &Path, limits: &Limits) -> Result<(Decoded, Meta)> {
    let err = |msg: String| Error::file(path, msg);
    let file_len = bytes.len();
    if !bytes.starts_with(MAGIC) && !MAGIC.starts_with(bytes) {
        return Err(err("not a DDS file (its signature is missing)".into()));
    }
    if file_len < HEADER_END {
        return Err(err(format!(
            "truncated DDS file: {file_len} bytes, shorter than the {HEADER_END}-byte header"
        )));
    }
    // ddsfile's parsing is caught like every third-party decoder's (`guard::caught`).
    let invalid = |e: String| err(format!("invalid DDS header: {}", one_line(&e)));
    let header = caught(|| Header::read(&bytes[4..HEADER_END]))
        .map_err(invalid)?
        .map_err(|e| invalid(e.to_string()))?;

    let (format, order, data_start, cube) = format_of(bytes, &header, path)?;
    if header.caps2.contains(Caps2::VOLUME) || header.depth.is_some_and(|d| d > 1) {
        return Err(err(
            "a volume texture is not supported: cubeforge reads 2D textures and cube maps".into(),
        ));
    }

    // The count as stored, whether or not DDSD_MIPMAPCOUNT is set (as Microsoft's reader
    // does); 0 means a single level.
    let level_field = le_u32(bytes, 28).unwrap_or(0);
    let shape = Shape::check(
        path,
        limits,
        format,
        cube,
        header.width,
        header.height,
        level_field,
        "mipMapCount",
    )?;

    // Everything the header promises must be in the file before anything is allocated: a
    // cube map's every level of six faces, a 2D texture's level 0 (its mips, when it has them,
    // follow and are not needed).
    let needed = if cube {
        shape.total_bytes()
    } else {
        shape.face_bytes(0) as u64
    };
    let have = (file_len - data_start) as u64;
    if have < needed {
        let what = if cube {
            format!("{} with {} levels need", shape.holds(0), shape.levels)
        } else {
            format!("{} needs", shape.holds(0))
        };
        return Err(err(format!(
            "truncated DDS file: {what} {needed} bytes of texels, but only {have} follow the header"
        )));
    }
    let data = &bytes[data_start..];
    let mut scratch = Vec::new();
    if !cube {
        let (w, h) = shape.level_size(0);
        let img = texels_image(&data[..needed as usize], w, h, format, order, &mut scratch)
            .map_err(err)?;
        let mut meta = meta(format);
        meta.stored_levels = shape.levels;
        return Ok((Decoded::Image(img), meta));
    }

    let mut levels: Vec<Vec<Image>> = (0..shape.levels).map(|_| Vec::with_capacity(6)).collect();
    let mut pos = 0usize;
    for _face in 0..6 {
        for (l, faces) in levels.iter_mut().enumerate() {
            let (w, h) = shape.level_size(l);
            let len = shape.face_bytes(l);
            let texels = &data[pos..pos + len];
            pos += len;
            faces.push(texels_image(texels, w, h, format, order, &mut scratch).map_err(err)?);
        }
    }
    let levels = levels
        .into_iter()
        .map(|faces| {
            <[Image; 6]>::try_from(faces)
                .map_err(|_| err("internal error: a level lost a face".into()))
        })
        .collect::<Result<Vec<_>>>()?;

    let mut meta = meta(format);
    meta.stored_levels = levels.len();
    Ok((Decoded::Cube(CubeMap { levels }), meta))
}

/// One stored image of `w` x `h` texels, put in RGBA order first when stored otherwise.
fn texels_image(
    texels: &[u8],
    w: usize,
    h: usize,
    format: GpuFormat,
    order: Order,
    scratch: &mut Vec<u8>,
) -> std::result::Result<Image, String> {
    let texels = if order == Order::Rgba {
        texels
    } else {
        scratch.clear();
        scratch.extend_from_slice(texels);
        for t in scratch.chunks_exact_mut(4) {
            if matches!(order, Order::Bgra | Order::Bgrx) {
                t.swap(0, 2);
            }
            if matches!(order, Order::Rgbx | Order::Bgrx) {
                t[3] = 255;
            }
        }
        &scratch[..]
    };
    format.decode_image(texels, w, h)
}

fn meta(format: GpuFormat) -> Meta {
    Meta::for_gpu(FileFormat::Dds, format, 1)
}
