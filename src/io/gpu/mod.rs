//! Texel formats of GPU containers (KTX2, DDS): plain RGBA (half, float, 8-bit), the packed HDR
//! formats E5B9G9R9 (shared exponent) and B10G11R11, and the block-compressed BC6H (HDR) and
//! BC7 (LDR), and ASTC HDR in 4x4 and 6x6 blocks (phones; see [`astc`]'s feature). Every format encodes and decodes a whole image at a time, in parallel over rows or
//! block rows, so a container encodes face by face and level by level; the bytes never depend on
//! the number of threads (every block and texel is encoded on its own).
//!
//! Block formats cover whole 4x4 blocks: an image whose sides are not multiples of 4 (the 2x2
//! and 1x1 mips) is padded by repeating its last column and row, as the formats require. BC6H and
//! BC7 are encoded by Intel's ISPC texture compressor (`intel_tex_2`, prebuilt kernels) and
//! decoded by `bcdec_rs` (pure Rust); E5B9G9R9 and B10G11R11 are packed here after the Vulkan
//! specification's conversion rules (they are not compression, just number formats).
//!
//! BC6H is written unsigned (UFLOAT), as are E5B9G9R9 and B10G11R11: negative values are
//! clamped to 0 with the counted clamp warning ([`super::clamp_warning`]). Radiance is never
//! negative (readers replace negatives by 0, filters weight with positive lobes); the only maker
//! of negatives is SH ringing, which a renderer should not show either. No maintained encoder
//! that builds without ispc or C++ offers signed BC6H, so there is no `bc6h-signed`.

#![warn(missing_docs)]

mod astc;
mod packed;
mod uastc;

use crate::image::{linear_to_srgb, srgb_to_linear, Image};
use glam::Vec4;
use packed::{pack_rgb9e5, pack_ufloat, unpack_rgb9e5, unpack_ufloat, unsigned};
use rayon::prelude::*;

/// Texel formats of GPU containers (KTX2, DDS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum GpuFormat {
    /// RGBA half float (the default: HDR, half the memory of f32).
    #[default]
    Rgba16f,
    /// RGBA 32-bit float.
    Rgba32f,
    /// RGBA 8-bit, sRGB-encoded colour.
    Rgba8Srgb,
    /// RGBA 8-bit, linear (UNORM) data.
    Rgba8,
    /// BC6H unsigned float blocks: HDR RGB in 1 byte a texel (negatives clamped to 0).
    Bc6h,
    /// BC7 blocks, linear (UNORM): LDR RGBA data in 1 byte a texel.
    Bc7,
    /// BC7 blocks, sRGB-encoded colour.
    Bc7Srgb,
    /// E5B9G9R9 shared exponent: HDR RGB in 4 bytes, 9 bits of mantissa each.
    Rgb9e5,
    /// B10G11R11 unsigned floats: HDR RGB in 4 bytes (6, 6 and 5 bits of mantissa).
    Rg11b10,
    /// ASTC HDR 4x4 blocks (phones, Apple GPUs, WebGPU/WebGL with ASTC HDR): 1 byte a texel
    /// (cargo feature `astc`).
    #[serde(rename = "astc-hdr-4x4")]
    #[cfg_attr(feature = "cli", value(name = "astc-hdr-4x4"))]
    AstcHdr4x4,
    /// ASTC HDR 6x6 blocks: 0.44 bytes a texel, coarser (cargo feature `astc`).
    #[serde(rename = "astc-hdr-6x6")]
    #[cfg_attr(feature = "cli", value(name = "astc-hdr-6x6"))]
    AstcHdr6x6,
    /// UASTC HDR 4x4 (basis_universal): ASTC HDR 4x4 blocks that transcoders turn into BC6H
    /// where ASTC HDR is missing (three.js's KTX2Loader); cargo feature `uastc`.
    #[serde(rename = "uastc-hdr-4x4")]
    #[cfg_attr(feature = "cli", value(name = "uastc-hdr-4x4"))]
    UastcHdr4x4,
}

/// The largest half float: values above it would be written as infinity.
pub const HALF_MAX: f32 = 65504.0;
/// The largest E5B9G9R9 value: (511 / 512) * 2^16.
pub const RGB9E5_MAX: f32 = 65408.0;
/// The largest 10-bit unsigned float (B10G11R11's blue; its 11-bit red and green reach 65024).
pub const UF10_MAX: f32 = 64512.0;
/// The largest 11-bit unsigned float.
const UF11_MAX: f32 = 65024.0;

impl GpuFormat {
    /// Every format, in the order help lists them.
    pub const ALL: [GpuFormat; 12] = [
        GpuFormat::Rgba16f,
        GpuFormat::Rgba32f,
        GpuFormat::Rgba8Srgb,
        GpuFormat::Rgba8,
        GpuFormat::Bc6h,
        GpuFormat::Bc7,
        GpuFormat::Bc7Srgb,
        GpuFormat::Rgb9e5,
        GpuFormat::Rg11b10,
        GpuFormat::AstcHdr4x4,
        GpuFormat::AstcHdr6x6,
        GpuFormat::UastcHdr4x4,
    ];

    /// Edge of the format's texel block: 4 for BC6H, BC7 and ASTC 4x4, 6 for ASTC 6x6, 1 for
    /// the others.
    pub fn block_dim(self) -> usize {
        match self {
            GpuFormat::AstcHdr6x6 => 6,
            f if f.is_block_compressed() => 4,
            _ => 1,
        }
    }

    /// Whether this build encodes and decodes the format: ASTC needs the cargo feature `astc`,
    /// UASTC HDR the feature `uastc` (which takes `astc` with it).
    pub fn check_built(self) -> Result<(), String> {
        match self {
            GpuFormat::UastcHdr4x4 => uastc::check_built(),
            f if f.is_astc() => astc::check_built(),
            _ => Ok(()),
        }
    }

    /// ASTC blocks (decoded by astcenc, behind the cargo feature `astc`): UASTC HDR 4x4 too.
    pub fn is_astc(self) -> bool {
        matches!(
            self,
            GpuFormat::AstcHdr4x4 | GpuFormat::AstcHdr6x6 | GpuFormat::UastcHdr4x4
        )
    }

    /// Bytes of one texel block (one texel for the uncompressed formats).
    pub fn block_bytes(self) -> usize {
        match self {
            GpuFormat::Rgba16f => 8,
            GpuFormat::Rgba32f => 16,
            GpuFormat::Rgba8Srgb | GpuFormat::Rgba8 | GpuFormat::Rgb9e5 | GpuFormat::Rg11b10 => 4,
            GpuFormat::Bc6h
            | GpuFormat::Bc7
            | GpuFormat::Bc7Srgb
            | GpuFormat::AstcHdr4x4
            | GpuFormat::AstcHdr6x6
            | GpuFormat::UastcHdr4x4 => 16,
        }
    }

    /// BC6H, BC7 and ASTC: blocks of texels, lossy.
    pub fn is_block_compressed(self) -> bool {
        matches!(self, GpuFormat::Bc6h | GpuFormat::Bc7 | GpuFormat::Bc7Srgb) || self.is_astc()
    }

    /// Holds values above 1 (HDR).
    pub fn is_float(self) -> bool {
        matches!(
            self,
            GpuFormat::Rgba16f
                | GpuFormat::Rgba32f
                | GpuFormat::Bc6h
                | GpuFormat::Rgb9e5
                | GpuFormat::Rg11b10
        ) || self.is_astc()
    }

    /// Colour stored sRGB-encoded (alpha stays linear).
    pub fn is_srgb(self) -> bool {
        matches!(self, GpuFormat::Rgba8Srgb | GpuFormat::Bc7Srgb)
    }

    /// Stores alpha (BC6H and the packed HDR formats hold RGB only; alpha reads as 1).
    pub fn has_alpha(self) -> bool {
        !matches!(
            self,
            GpuFormat::Bc6h | GpuFormat::Rgb9e5 | GpuFormat::Rg11b10
        )
    }

    /// Float formats without a sign: negative values are clamped to 0 (ASTC's HDR endpoints
    /// have no sign either, though Vulkan names the format SFLOAT).
    pub fn is_unsigned_float(self) -> bool {
        matches!(
            self,
            GpuFormat::Bc6h | GpuFormat::Rgb9e5 | GpuFormat::Rg11b10
        ) || self.is_astc()
    }

    /// Lossy beyond rounding to the format's precision: worth a quality report.
    pub fn is_lossy(self) -> bool {
        self.is_block_compressed()
    }

    /// The largest value the format stores (None for 8-bit formats, clamped to [0, 1] as a
    /// matter of course).
    pub fn largest_value(self) -> Option<f32> {
        match self {
            GpuFormat::Rgba16f
            | GpuFormat::Bc6h
            | GpuFormat::AstcHdr4x4
            | GpuFormat::AstcHdr6x6
            | GpuFormat::UastcHdr4x4 => Some(HALF_MAX),
            GpuFormat::Rgba32f => Some(f32::MAX),
            GpuFormat::Rgb9e5 => Some(RGB9E5_MAX),
            GpuFormat::Rg11b10 => Some(UF10_MAX),
            GpuFormat::Rgba8Srgb | GpuFormat::Rgba8 | GpuFormat::Bc7 | GpuFormat::Bc7Srgb => None,
        }
    }

    /// The format's name for messages and metadata ("RGBA16F", "BC6H UFLOAT").
    pub fn name(self) -> &'static str {
        match self {
            GpuFormat::Rgba16f => "RGBA16F",
            GpuFormat::Rgba32f => "RGBA32F",
            GpuFormat::Rgba8Srgb => "RGBA8 sRGB",
            GpuFormat::Rgba8 => "RGBA8 UNORM",
            GpuFormat::Bc6h => "BC6H UFLOAT",
            GpuFormat::Bc7 => "BC7 UNORM",
            GpuFormat::Bc7Srgb => "BC7 sRGB",
            GpuFormat::Rgb9e5 => "E5B9G9R9 UFLOAT",
            GpuFormat::Rg11b10 => "B10G11R11 UFLOAT",
            GpuFormat::AstcHdr4x4 => "ASTC 4x4 HDR",
            GpuFormat::AstcHdr6x6 => "ASTC 6x6 HDR",
            GpuFormat::UastcHdr4x4 => "UASTC HDR 4x4",
        }
    }

    /// Bytes of a `w` x `h` image in this format (whole blocks), None on overflow.
    pub fn image_bytes(self, w: u64, h: u64) -> Option<u64> {
        let d = self.block_dim() as u64;
        w.div_ceil(d)
            .checked_mul(h.div_ceil(d))?
            .checked_mul(self.block_bytes() as u64)
    }

    /// Encodes a whole image (rows top to bottom, blocks row by row), in parallel. Fails only
    /// for ASTC in a build without its encoder.
    pub fn encode_image(self, img: &Image) -> Result<Vec<u8>, String> {
        Ok(match self {
            GpuFormat::Bc6h => encode_bc6h(img),
            GpuFormat::Bc7 | GpuFormat::Bc7Srgb => encode_bc7(img, self.is_srgb()),
            GpuFormat::AstcHdr4x4 | GpuFormat::AstcHdr6x6 => astc::encode(img, self.block_dim())?,
            GpuFormat::UastcHdr4x4 => uastc::encode(img)?,
            _ => {
                let bpt = self.block_bytes();
                let mut out = vec![0u8; img.width * img.height * bpt];
                out.par_chunks_mut(img.width.max(1) * bpt)
                    .zip(img.pixels.par_chunks(img.width.max(1)))
                    .for_each(|(o, row)| {
                        for (t, p) in o.chunks_exact_mut(bpt).zip(row) {
                            self.encode_texel(*p, t);
                        }
                    });
                out
            }
        })
    }

    /// Decodes a `w` x `h` image from `bytes`, which must hold at least
    /// [`image_bytes`](Self::image_bytes) of it. Fails only for ASTC in a build without its
    /// decoder.
    pub fn decode_image(self, bytes: &[u8], w: usize, h: usize) -> Result<Image, String> {
        if self.is_astc() {
            return astc::decode(bytes, w, h, self.block_dim());
        }
        let mut pixels = vec![Vec4::ZERO; w * h];
        if w > 0 && h > 0 {
            if self.is_block_compressed() {
                let row_bytes = w.div_ceil(4) * 16;
                pixels
                    .par_chunks_mut(4 * w)
                    .zip(bytes.par_chunks(row_bytes))
                    .for_each(|(rows, blocks)| self.decode_block_row(blocks, rows, w));
            } else {
                let bpt = self.block_bytes();
                pixels
                    .par_chunks_mut(w)
                    .zip(bytes.par_chunks(w * bpt))
                    .for_each(|(row, b)| {
                        for (p, t) in row.iter_mut().zip(b.chunks_exact(bpt)) {
                            *p = self.decode_texel(t);
                        }
                    });
            }
        }
        Ok(Image {
            width: w,
            height: h,
            pixels,
        })
    }

    fn encode_texel(self, p: Vec4, t: &mut [u8]) {
        let a = p.to_array();
        match self {
            GpuFormat::Rgba16f => {
                for (i, v) in a.into_iter().enumerate() {
                    let h = half::f16::from_f32(finite(v, HALF_MAX));
                    t[2 * i..2 * i + 2].copy_from_slice(&h.to_le_bytes());
                }
            }
            GpuFormat::Rgba32f => {
                for (i, v) in a.into_iter().enumerate() {
                    t[4 * i..4 * i + 4].copy_from_slice(&finite(v, f32::MAX).to_le_bytes());
                }
            }
            GpuFormat::Rgba8Srgb => {
                for (i, v) in a.into_iter().enumerate() {
                    t[i] = unorm8(if i < 3 { linear_to_srgb(v) } else { v });
                }
            }
            GpuFormat::Rgba8 => {
                for (i, v) in a.into_iter().enumerate() {
                    t[i] = unorm8(v);
                }
            }
            GpuFormat::Rgb9e5 => t.copy_from_slice(&pack_rgb9e5(p).to_le_bytes()),
            GpuFormat::Rg11b10 => {
                let r = pack_ufloat(a[0], 6, UF11_MAX);
                let g = pack_ufloat(a[1], 6, UF11_MAX);
                let b = pack_ufloat(a[2], 5, UF10_MAX);
                t.copy_from_slice(&(r | (g << 11) | (b << 22)).to_le_bytes());
            }
            _ => unreachable!("block formats encode whole images"),
        }
    }

    fn decode_texel(self, t: &[u8]) -> Vec4 {
        let word = || u32::from_le_bytes([t[0], t[1], t[2], t[3]]);
        match self {
            GpuFormat::Rgba16f => Vec4::from_array(std::array::from_fn(|i| {
                half::f16::from_le_bytes([t[2 * i], t[2 * i + 1]]).to_f32()
            })),
            GpuFormat::Rgba32f => Vec4::from_array(std::array::from_fn(|i| {
                f32::from_le_bytes([t[4 * i], t[4 * i + 1], t[4 * i + 2], t[4 * i + 3]])
            })),
            GpuFormat::Rgba8Srgb => Vec4::new(
                srgb_to_linear(t[0] as f32 / 255.0),
                srgb_to_linear(t[1] as f32 / 255.0),
                srgb_to_linear(t[2] as f32 / 255.0),
                t[3] as f32 / 255.0,
            ),
            GpuFormat::Rgba8 => Vec4::new(
                t[0] as f32 / 255.0,
                t[1] as f32 / 255.0,
                t[2] as f32 / 255.0,
                t[3] as f32 / 255.0,
            ),
            GpuFormat::Rgb9e5 => unpack_rgb9e5(word()),
            GpuFormat::Rg11b10 => {
                let w = word();
                Vec4::new(
                    unpack_ufloat(w & 0x7FF, 6),
                    unpack_ufloat((w >> 11) & 0x7FF, 6),
                    unpack_ufloat(w >> 22, 5),
                    1.0,
                )
            }
            _ => unreachable!("block formats decode whole images"),
        }
    }

    /// Decodes one row of blocks into up to four rows of `w` pixels.
    fn decode_block_row(self, blocks: &[u8], rows: &mut [Vec4], w: usize) {
        let h = rows.len() / w;
        for (bx, block) in blocks.chunks_exact(16).enumerate() {
            let mut texels = [Vec4::ZERO; 16];
            match self {
                GpuFormat::Bc6h => {
                    let mut halves = [0u16; 48];
                    bcdec_rs::bc6h_half(block, &mut halves, 12, false);
                    for (t, h) in texels.iter_mut().zip(halves.chunks_exact(3)) {
                        let f = |i: usize| half::f16::from_bits(h[i]).to_f32();
                        *t = Vec4::new(f(0), f(1), f(2), 1.0);
                    }
                }
                _ => {
                    let mut bytes = [0u8; 64];
                    bcdec_rs::bc7(block, &mut bytes, 16);
                    let srgb = self.is_srgb();
                    for (t, b) in texels.iter_mut().zip(bytes.chunks_exact(4)) {
                        let c = |i: usize| {
                            let v = b[i] as f32 / 255.0;
                            if srgb {
                                srgb_to_linear(v)
                            } else {
                                v
                            }
                        };
                        *t = Vec4::new(c(0), c(1), c(2), b[3] as f32 / 255.0);
                    }
                }
            }
            for y in 0..h.min(4) {
                for x in 0..4 {
                    let px = bx * 4 + x;
                    if px < w {
                        rows[y * w + px] = texels[y * 4 + x];
                    }
                }
            }
        }
    }
}

/// `v` made finite within +-`max` (NaN becomes 0): what every float encoder writes.
#[inline]
pub fn finite(v: f32, max: f32) -> f32 {
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-max, max)
    }
}

/// A value in [0, 1] as an 8-bit UNORM, rounded to nearest (clamped outside the range).
#[inline]
pub fn unorm8(v: f32) -> u8 {
    (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
}

/// Block rows handed to the encoder at once: enough work per task, enough tasks for all cores.
const BAND_BLOCK_ROWS: usize = 4;

/// The image padded to whole 4x4 blocks (last column and row repeated), as `T` texels made by
/// `texel`, row by row.
fn padded<T: Copy + Send + Default>(
    img: &Image,
    texel: impl Fn(Vec4) -> T + Sync,
) -> (Vec<T>, usize, usize) {
    let (pw, ph) = (img.width.div_ceil(4) * 4, img.height.div_ceil(4) * 4);
    let mut out = vec![T::default(); pw * ph];
    out.par_chunks_mut(pw).enumerate().for_each(|(y, row)| {
        let src = &img.pixels[y.min(img.height - 1) * img.width..][..img.width];
        for (x, t) in row.iter_mut().enumerate() {
            *t = texel(src[x.min(img.width - 1)]);
        }
    });
    (out, pw, ph)
}

/// Runs `encode` on bands of block rows of a padded image of `pw` x `ph` texels of
/// `texel_bytes` each, in parallel; the blocks land row by row as the formats store them.
fn encode_bands(
    data: &[u8],
    pw: usize,
    ph: usize,
    texel_bytes: usize,
    encode: impl Fn(&intel_tex_2::RgbaSurface, &mut [u8]) + Sync,
) -> Vec<u8> {
    let blocks_per_row = pw / 4;
    let mut out = vec![0u8; blocks_per_row * (ph / 4) * 16];
    let band_in = pw * 4 * texel_bytes * BAND_BLOCK_ROWS;
    let band_out = blocks_per_row * 16 * BAND_BLOCK_ROWS;
    out.par_chunks_mut(band_out)
        .zip(data.par_chunks(band_in))
        .for_each(|(blocks, texels)| {
            let surface = intel_tex_2::RgbaSurface {
                data: texels,
                width: pw as u32,
                height: (texels.len() / (pw * texel_bytes)) as u32,
                stride: (pw * texel_bytes) as u32,
            };
            encode(&surface, blocks);
        });
    out
}

fn encode_bc6h(img: &Image) -> Vec<u8> {
    if img.pixels.is_empty() {
        return Vec::new();
    }
    // Half floats, negatives and NaN as 0: the encoder reads the bits as unsigned.
    let (texels, pw, ph) = padded(img, |p| {
        [p.x, p.y, p.z, 1.0].map(|v| half::f16::from_f32(unsigned(v, HALF_MAX)).to_bits())
    });
    let settings = intel_tex_2::bc6h::basic_settings();
    encode_bands(bytemuck::cast_slice(&texels), pw, ph, 8, |s, out| {
        intel_tex_2::bc6h::compress_blocks_into(&settings, s, out)
    })
}

fn encode_bc7(img: &Image, srgb: bool) -> Vec<u8> {
    if img.pixels.is_empty() {
        return Vec::new();
    }
    let (texels, pw, ph) = padded(img, |p| {
        let c = |v: f32| unorm8(if srgb { linear_to_srgb(v) } else { v });
        [c(p.x), c(p.y), c(p.z), unorm8(p.w)]
    });
    // The opaque settings spend every bit on colour; an image with any alpha below 1 needs
    // the alpha modes. Decided per image, so the bytes do not depend on the bands.
    let opaque = texels.par_iter().all(|t| t[3] == 255);
    let settings = if opaque {
        intel_tex_2::bc7::opaque_basic_settings()
    } else {
        intel_tex_2::bc7::alpha_basic_settings()
    };
    encode_bands(bytemuck::cast_slice(&texels), pw, ph, 4, |s, out| {
        intel_tex_2::bc7::compress_blocks_into(&settings, s, out)
    })
}

/// How close a decoded map is to the one encoded, in dB (higher is closer; infinite when
/// identical). HDR formats compare RGB after the tone curve v / (1 + v), so a bright sun and a
/// dark corner count alike; LDR formats compare RGBA as stored (sRGB-encoded for sRGB formats).
/// Peak 1 either way.
pub fn psnr<'a>(
    format: GpuFormat,
    original: impl IntoIterator<Item = &'a Image>,
    decoded: impl IntoIterator<Item = &'a Image>,
) -> f64 {
    let map = |v: f32| -> f64 {
        let v = if v.is_nan() { 0.0 } else { v };
        if format.is_float() {
            let v = v.max(0.0) as f64;
            v / (1.0 + v)
        } else if format.is_srgb() {
            linear_to_srgb(v.clamp(0.0, 1.0)) as f64
        } else {
            v.clamp(0.0, 1.0) as f64
        }
    };
    // HDR formats compare colour only: an alpha of 1 kept exactly would flatter them.
    let channels = if format.has_alpha() && !format.is_float() {
        4
    } else {
        3
    };
    let (mut sum, mut n) = (0.0f64, 0u64);
    for (a, b) in original.into_iter().zip(decoded) {
        // Rows summed in parallel, then in order: the same sum on any number of threads.
        let rows: Vec<f64> = a
            .pixels
            .par_chunks(a.width.max(1))
            .zip(b.pixels.par_chunks(b.width.max(1)))
            .map(|(ra, rb)| {
                let mut s = 0.0;
                for (p, q) in ra.iter().zip(rb) {
                    for c in 0..channels {
                        let alpha = c == 3;
                        let (x, y) = if alpha {
                            (p[c].clamp(0.0, 1.0) as f64, q[c].clamp(0.0, 1.0) as f64)
                        } else {
                            (map(p[c]), map(q[c]))
                        };
                        s += (x - y) * (x - y);
                    }
                }
                s
            })
            .collect();
        sum += rows.iter().sum::<f64>();
        n += (a.pixels.len() * channels) as u64;
    }
    if n == 0 || sum == 0.0 {
        return f64::INFINITY;
    }
    10.0 * (1.0 / (sum / n as f64)).log10()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_mips_are_padded_to_whole_blocks() {
        for format in [GpuFormat::Bc6h, GpuFormat::Bc7, GpuFormat::Bc7Srgb] {
            for (w, h) in [(1, 1), (2, 2), (5, 3)] {
                let img = Image {
                    width: w,
                    height: h,
                    pixels: (0..w * h)
                        .map(|i| Vec4::new(0.1 + 0.05 * i as f32, 0.5, 0.25, 1.0))
                        .collect(),
                };
                let bytes = format.encode_image(&img).unwrap();
                assert_eq!(
                    bytes.len() as u64,
                    format.image_bytes(w as u64, h as u64).unwrap()
                );
                let back = format.decode_image(&bytes, w, h).unwrap();
                // Within 8 %: BC6H interpolates 16 steps between half-float bit patterns,
                // about log-spaced, and this block spans three octaves (0.1 to 0.75).
                for (a, b) in img.pixels.iter().zip(&back.pixels) {
                    let tol = 0.08 * a.max_element() + 0.01;
                    assert!((*a - *b).abs().max_element() < tol, "{format:?} {a} {b}");
                }
            }
        }
    }
}
