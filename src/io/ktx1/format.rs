//! The texel formats of KTX 1 files, by their OpenGL enumerants, and how faces are stored in them.

use super::super::{finite, GpuFormat, HALF_MAX};
use crate::image::Image;
use glam::Vec4;

// OpenGL enumerants of the formats read and written.
const GL_UNSIGNED_BYTE: u32 = 0x1401;
const GL_FLOAT: u32 = 0x1406;
const GL_HALF_FLOAT: u32 = 0x140B;
pub(super) const GL_RGB: u32 = 0x1907;
const GL_RGBA: u32 = 0x1908;
const GL_RGBA8: u32 = 0x8058;
const GL_SRGB8_ALPHA8: u32 = 0x8C43;
const GL_RGBA32F: u32 = 0x8814;
const GL_RGBA16F: u32 = 0x881A;
const GL_RGB16F: u32 = 0x881B;
pub(super) const GL_R11F_G11F_B10F: u32 = 0x8C3A;
const GL_UNSIGNED_INT_10F_11F_11F_REV: u32 = 0x8C3B;

/// Texel formats of KTX 1 files, by their OpenGL enumerants. Those that are [`GpuFormat`]s
/// share its encoding; RGB16F is three half floats.
///
/// R11F_G11F_B10F, the format `cmgen` deploys, is added here once `GpuFormat` has it: a variant
/// `Rg11b10` with glType 0x8C3A (GL_R11F_G11F_B10F: the value `cmgen` writes and the only one
/// Filament's `Ktx1Reader::toPixelDataType` maps to UINT_10F_11F_11F_REV; the specification's
/// GL_UNSIGNED_INT_10F_11F_11F_REV, 0x8C3B, must be read too), glTypeSize 4 (cmgen writes 1:
/// accept both), glFormat GL_RGB, glInternalFormat 0x8C3A, glBaseInternalFormat GL_RGB, 4 bytes
/// a texel, texels through `GpuFormat::Rg11b10`. See the `R11F_G11F_B10F` marks below.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ktx1Format {
    /// GL_RGBA16F, GL_HALF_FLOAT.
    Rgba16f,
    /// GL_RGB16F, GL_HALF_FLOAT: three half floats, rows padded to 4 bytes.
    Rgb16f,
    /// GL_RGBA32F, GL_FLOAT.
    Rgba32f,
    /// GL_RGBA8, GL_UNSIGNED_BYTE (linear data).
    Rgba8,
    /// GL_SRGB8_ALPHA8, GL_UNSIGNED_BYTE (sRGB colour).
    Rgba8Srgb,
    /// GL_R11F_G11F_B10F, what cmgen deploys: three unsigned floats packed in 4 bytes.
    Rg11b10,
}

/// The header fields that name a format: glType, glTypeSize, glFormat, glInternalFormat,
/// glBaseInternalFormat.
pub(super) struct GlFields {
    pub(super) gl_type: u32,
    pub(super) type_size: u32,
    pub(super) format: u32,
    pub(super) internal: u32,
    pub(super) base_internal: u32,
}

impl Ktx1Format {
    /// The format that stores texels as `format` does; block-compressed and shared-exponent
    /// formats have no KTX 1 form here (Filament's reader takes the ones below).
    pub fn from_gpu(format: GpuFormat) -> std::result::Result<Ktx1Format, String> {
        Ok(match format {
            GpuFormat::Rgba16f => Ktx1Format::Rgba16f,
            GpuFormat::Rgba32f => Ktx1Format::Rgba32f,
            GpuFormat::Rgba8 => Ktx1Format::Rgba8,
            GpuFormat::Rgba8Srgb => Ktx1Format::Rgba8Srgb,
            GpuFormat::Rg11b10 => Ktx1Format::Rg11b10,
            other => {
                return Err(format!(
                    "KTX 1 output takes rgba16f, rgba32f, rgba8, rgba8-srgb or rg11b10, not {}",
                    other.name()
                ))
            }
        })
    }

    /// The [`GpuFormat`] with the same texel encoding (None for RGB16F).
    pub fn gpu(self) -> Option<GpuFormat> {
        match self {
            Ktx1Format::Rgba16f => Some(GpuFormat::Rgba16f),
            Ktx1Format::Rgba32f => Some(GpuFormat::Rgba32f),
            Ktx1Format::Rgba8 => Some(GpuFormat::Rgba8),
            Ktx1Format::Rgba8Srgb => Some(GpuFormat::Rgba8Srgb),
            Ktx1Format::Rg11b10 => Some(GpuFormat::Rg11b10),
            Ktx1Format::Rgb16f => None,
        }
    }

    /// The format's name for messages ("RGBA16F").
    pub fn name(self) -> &'static str {
        match self {
            Ktx1Format::Rgb16f => "RGB16F",
            f => f.gpu().map_or("?", GpuFormat::name),
        }
    }

    /// Bytes of one texel.
    pub fn bytes_per_texel(self) -> usize {
        match self {
            Ktx1Format::Rgb16f => 6,
            f => f.gpu().map_or(0, GpuFormat::block_bytes),
        }
    }

    /// Whether texels are floats (HDR).
    pub fn is_float(self) -> bool {
        matches!(
            self,
            Ktx1Format::Rgba16f | Ktx1Format::Rgb16f | Ktx1Format::Rgba32f | Ktx1Format::Rg11b10
        )
    }

    pub(super) fn gl(self) -> GlFields {
        let (gl_type, type_size, format, internal) = match self {
            Ktx1Format::Rgba16f => (GL_HALF_FLOAT, 2, GL_RGBA, GL_RGBA16F),
            Ktx1Format::Rgb16f => (GL_HALF_FLOAT, 2, GL_RGB, GL_RGB16F),
            Ktx1Format::Rgba32f => (GL_FLOAT, 4, GL_RGBA, GL_RGBA32F),
            Ktx1Format::Rgba8 => (GL_UNSIGNED_BYTE, 1, GL_RGBA, GL_RGBA8),
            Ktx1Format::Rgba8Srgb => (GL_UNSIGNED_BYTE, 1, GL_RGBA, GL_SRGB8_ALPHA8),
            // cmgen's glType (the internal format's value): the only one Filament's reader maps.
            Ktx1Format::Rg11b10 => (GL_R11F_G11F_B10F, 4, GL_RGB, GL_R11F_G11F_B10F),
        };
        GlFields {
            gl_type,
            type_size,
            format,
            internal,
            base_internal: format,
        }
    }

    /// The format a header's glInternalFormat names, checked against its glType (None: not
    /// one of these).
    pub(super) fn from_gl(internal: u32, gl_type: u32) -> Option<Ktx1Format> {
        let f = match internal {
            GL_RGBA16F => Ktx1Format::Rgba16f,
            GL_RGB16F => Ktx1Format::Rgb16f,
            GL_RGBA32F => Ktx1Format::Rgba32f,
            GL_RGBA8 => Ktx1Format::Rgba8,
            GL_SRGB8_ALPHA8 => Ktx1Format::Rgba8Srgb,
            // cmgen writes glType 0x8C3A; the GL specification's is 0x8C3B.
            GL_R11F_G11F_B10F
                if gl_type == GL_R11F_G11F_B10F || gl_type == GL_UNSIGNED_INT_10F_11F_11F_REV =>
            {
                return Some(Ktx1Format::Rg11b10)
            }
            _ => return None,
        };
        (f.gl().gl_type == gl_type).then_some(f)
    }

    /// Bytes of one row of `w` texels, padded to 4.
    pub(super) fn row_bytes(self, w: usize) -> usize {
        (w * self.bytes_per_texel()).div_ceil(4) * 4
    }

    /// Appends one face's texels, row by row, each row padded to 4 bytes.
    pub(super) fn encode_face(
        self,
        face: &Image,
        out: &mut Vec<u8>,
    ) -> std::result::Result<(), String> {
        let row = self.row_bytes(face.width);
        let texels = face.width * self.bytes_per_texel();
        let bytes = match self.gpu() {
            Some(g) => g.encode_image(face)?,
            None => {
                let mut b = Vec::with_capacity(face.pixels.len() * 6);
                for p in &face.pixels {
                    for v in [p.x, p.y, p.z] {
                        let h = half::f16::from_f32(finite(v, HALF_MAX));
                        b.extend_from_slice(&h.to_le_bytes());
                    }
                }
                b
            }
        };
        for r in bytes.chunks_exact(texels.max(1)).take(face.height) {
            let start = out.len();
            out.extend_from_slice(r);
            out.resize(start + row, 0);
        }
        Ok(())
    }

    /// Decodes one face of `w` x `h` texels from little-endian `bytes` (padded rows).
    pub(super) fn decode_face(
        self,
        bytes: &[u8],
        w: usize,
        h: usize,
    ) -> std::result::Result<Image, String> {
        let row = self.row_bytes(w);
        let texels = w * self.bytes_per_texel();
        let mut packed = Vec::with_capacity(texels * h);
        for y in 0..h {
            packed.extend_from_slice(&bytes[y * row..y * row + texels]);
        }
        Ok(match self.gpu() {
            Some(g) => g.decode_image(&packed, w, h)?,
            None => Image {
                width: w,
                height: h,
                pixels: packed
                    .chunks_exact(6)
                    .map(|t| {
                        let c =
                            |i: usize| half::f16::from_le_bytes([t[2 * i], t[2 * i + 1]]).to_f32();
                        Vec4::new(c(0), c(1), c(2), 1.0)
                    })
                    .collect(),
            },
        })
    }
}
