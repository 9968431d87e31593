//! DDS cube maps with every mip level (and 2D textures, read as their level 0 image).
//!
//! Writes a DX10-header cube map (DXGI R16G16B16A16_FLOAT, R32G32B32A32_FLOAT,
//! R8G8B8A8_UNORM_SRGB or R8G8B8A8_UNORM) with the cube-map caps and the TEXTURECUBE misc flag;
//! the texels follow face-major, as DDS wants: for each face +X -X +Y -Y +Z -Z, all its levels.
//!
//! Reads those four DX10 formats and their legacy-header forms: FourCC 113 (A16B16G16R16F),
//! FourCC 116 (A32B32G32R32F) and the 32-bit RGBA8 masks (A8B8G8R8, X8B8G8R8, and the
//! BGRA-ordered A8R8G8B8, X8R8G8B8), which have no colour-space flag and are read as UNORM.
//! The headers are parsed with `ddsfile`; every size is checked here, with checked arithmetic,
//! against the file's length and against [`Limits`] before any texel is allocated.

#![warn(missing_docs)]

use super::guard::{caught, one_line};
use super::{Decoded, FileFormat, GpuFormat, Limits, Meta};
use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
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

const SUPPORTED: &str = "cubeforge reads RGBA16F, RGBA32F, RGBA8 sRGB/UNORM";

fn dxgi_format(format: GpuFormat) -> DxgiFormat {
    match format {
        GpuFormat::Rgba16f => DxgiFormat::R16G16B16A16_Float,
        GpuFormat::Rgba32f => DxgiFormat::R32G32B32A32_Float,
        GpuFormat::Rgba8Srgb => DxgiFormat::R8G8B8A8_UNorm_sRGB,
        GpuFormat::Rgba8 => DxgiFormat::R8G8B8A8_UNorm,
    }
}

fn from_dxgi(raw: u32) -> Option<GpuFormat> {
    Some(match raw {
        x if x == DxgiFormat::R16G16B16A16_Float as u32 => GpuFormat::Rgba16f,
        x if x == DxgiFormat::R32G32B32A32_Float as u32 => GpuFormat::Rgba32f,
        x if x == DxgiFormat::R8G8B8A8_UNorm_sRGB as u32 => GpuFormat::Rgba8Srgb,
        x if x == DxgiFormat::R8G8B8A8_UNorm as u32 => GpuFormat::Rgba8,
        _ => return None,
    })
}

/// Encodes every level of `cube` as a DX10 DDS cube map in `format`.
pub fn encode(cube: &CubeMap, format: GpuFormat) -> std::result::Result<Vec<u8>, String> {
    let size = cube.size();
    let bpt = format.bytes_per_texel();
    let edge = u32::try_from(size)
        .ok()
        .filter(|n| n.checked_mul(bpt as u32).is_some())
        .ok_or_else(|| format!("faces of {size}x{size} pixels are too large for DDS"))?;
    let levels = u32::try_from(cube.levels.len()).map_err(|_| "too many mip levels for DDS")?;
    let dxgi = dxgi_format(format);
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

    let texels: usize = cube
        .levels
        .iter()
        .map(|l| 6 * l[0].width * l[0].width)
        .sum();
    let mut out = Vec::with_capacity(HEADER10_END + texels * bpt);
    out.extend_from_slice(MAGIC);
    header
        .write(&mut out)
        .map_err(|e| format!("cannot write a DDS header: {e}"))?;
    header10
        .write(&mut out)
        .map_err(|e| format!("cannot write a DDS header: {e}"))?;
    for face in 0..6 {
        for level in &cube.levels {
            format.encode_into(&level[face].pixels, &mut out);
        }
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

    let is_dx10 = header.spf.fourcc == Some(FourCC(FourCC::DX10));
    let (format, order, data_start, cube) = if is_dx10 {
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
    };
    if header.caps2.contains(Caps2::VOLUME) || header.depth.is_some_and(|d| d > 1) {
        return Err(err(
            "a volume texture is not supported: cubeforge reads 2D textures and cube maps".into(),
        ));
    }

    let (width, height) = (header.width, header.height);
    if !cube {
        limits.check(path, width as u64, height as u64)?;
        let size = (width as usize, height as usize);
        // As for cube maps, the count as stored; 0 means a single level.
        let levels = (le_u32(bytes, 28).unwrap_or(0) as usize).max(1);
        let (decoded, mut meta) = decode_2d(bytes, path, size, format, order, data_start)?;
        meta.stored_levels = levels;
        return Ok((decoded, meta));
    }
    limits.check_cube(path, width as u64, height as u64)?;
    if width != height {
        return Err(err(format!(
            "invalid cube map: faces must be square, but they are {width}x{height}"
        )));
    }
    let size = width as usize;
    // The count as stored, whether or not DDSD_MIPMAPCOUNT is set (as Microsoft's reader does);
    // 0 means a single level.
    let level_count = (le_u32(bytes, 28).unwrap_or(0) as usize).max(1);
    let max_levels = CubeMap::full_chain_len(size);
    if level_count > max_levels {
        return Err(err(format!(
            "invalid DDS header: it claims {level_count} mip levels, but a {size}x{size} face has at most {max_levels}"
        )));
    }

    // Everything the header promises must be in the file before anything is allocated.
    let bpt = format.bytes_per_texel() as u64;
    let mut chain_len: u64 = 0;
    for l in 0..level_count {
        let n = (size >> l).max(1) as u64;
        chain_len = n
            .checked_mul(n)
            .and_then(|t| t.checked_mul(bpt))
            .and_then(|t| t.checked_add(chain_len))
            .ok_or_else(|| err("invalid DDS header: sizes overflow".into()))?;
    }
    let needed = chain_len
        .checked_mul(6)
        .ok_or_else(|| err("invalid DDS header: sizes overflow".into()))?;
    let have = (file_len - data_start) as u64;
    if have < needed {
        return Err(err(format!(
            "truncated DDS file: six {size}x{size} {} faces with {level_count} levels need {needed} bytes of texels, but only {have} follow the header",
            format.name()
        )));
    }

    let data = &bytes[data_start..];
    let mut levels: Vec<Vec<Image>> = (0..level_count).map(|_| Vec::with_capacity(6)).collect();
    let mut pos = 0usize;
    let mut scratch = Vec::new();
    for _face in 0..6 {
        for (l, faces) in levels.iter_mut().enumerate() {
            let n = (size >> l).max(1);
            let len = n * n * bpt as usize;
            let texels = &data[pos..pos + len];
            pos += len;
            faces.push(texels_image(texels, n, n, format, order, &mut scratch));
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

/// Level 0 of a 2D texture (its size checked against the limits), as an image: its mips, when
/// it has them, follow and are not needed.
fn decode_2d(
    bytes: &[u8],
    path: &Path,
    (width, height): (usize, usize),
    format: GpuFormat,
    order: Order,
    data_start: usize,
) -> Result<(Decoded, Meta)> {
    let needed = (width as u64)
        .checked_mul(height as u64)
        .and_then(|t| t.checked_mul(format.bytes_per_texel() as u64))
        .ok_or_else(|| Error::file(path, "invalid DDS header: sizes overflow"))?;
    let have = (bytes.len() - data_start) as u64;
    if have < needed {
        return Err(Error::file(
            path,
            format!(
                "truncated DDS file: a {width}x{height} {} texture needs {needed} bytes of texels, but only {have} follow the header",
                format.name()
            ),
        ));
    }
    let texels = &bytes[data_start..data_start + needed as usize];
    let img = texels_image(texels, width, height, format, order, &mut Vec::new());
    Ok((Decoded::Image(img), meta(format)))
}

/// One stored image of `w` x `h` texels, put in RGBA order first when stored otherwise.
fn texels_image(
    texels: &[u8],
    w: usize,
    h: usize,
    format: GpuFormat,
    order: Order,
    scratch: &mut Vec<u8>,
) -> Image {
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
    Image {
        width: w,
        height: h,
        pixels: format.decode(texels, w * h),
    }
}

fn meta(format: GpuFormat) -> Meta {
    Meta {
        file_format: FileFormat::Dds,
        pixel_format: format.name().into(),
        color_space: if format == GpuFormat::Rgba8Srgb {
            ColorSpace::Srgb
        } else {
            ColorSpace::Linear
        },
        hdr: matches!(format, GpuFormat::Rgba16f | GpuFormat::Rgba32f),
        replaced_values: 0,
        stored_levels: 1,
    }
}
