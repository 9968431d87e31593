//! UASTC HDR 4x4 (basis_universal 2.x): ASTC HDR 4x4 blocks restricted to the configurations
//! that transcode quickly and well to BC6H, so one file serves phones (read as ASTC HDR as it
//! is) and desktops (Basis's transcoder, three.js's KTX2Loader among its users, turns each block
//! into BC6H). The blocks are plain ASTC, so astcenc decodes them (cargo feature `astc`); only
//! the encoder is basis_universal's, a C++ build of minutes, behind the cargo feature `uastc`.
//!
//! basis_universal's C API compresses whole images into a KTX2 file of its own: each band of
//! whole block rows is compressed on its own, single-threaded, and its blocks are taken from
//! that file's one level, so the bytes never depend on the number of threads. The encoder
//! weighs errors in log space as astcenc does, so the blocks whose light is off are refitted by
//! [`super::astc`]'s light keeper with basis_universal as the block encoder.

#[cfg(not(feature = "uastc"))]
use crate::image::Image;

/// The message for a build without the encoder.
#[cfg(not(feature = "uastc"))]
fn missing() -> String {
    "UASTC HDR needs cubeforge built with the cargo feature `uastc` \
     (cargo install --locked --path . --features uastc)"
        .into()
}

/// Whether this build has basis_universal's encoder (decoding needs astcenc only).
pub(super) fn check_built() -> Result<(), String> {
    #[cfg(not(feature = "uastc"))]
    return Err(missing());
    #[cfg(feature = "uastc")]
    Ok(())
}

/// Encodes `img` as UASTC HDR 4x4 blocks, row by row.
#[cfg(not(feature = "uastc"))]
pub(super) fn encode(_img: &Image) -> Result<Vec<u8>, String> {
    Err(missing())
}

#[cfg(feature = "uastc")]
pub(super) use with_basisu::encode;

#[cfg(feature = "uastc")]
mod with_basisu {
    use super::super::astc::{keep_light, texel};
    use crate::image::Image;
    use basisu_c_sys::extra::{
        basisu_encoder_init, types::Extent3d, BasisuEncoder, BasisuEncoderParams, SourceImage,
        SourceImageFormat,
    };
    use basisu_c_sys::{common, BasisTextureFormat};
    use rayon::prelude::*;

    /// Block rows per task, as for astcenc: each band is one call of the encoder.
    const BAND_BLOCK_ROWS: usize = 4;
    /// basis_universal's unified effort (0 to 10), its default: on the real panoramas' 256 px
    /// cubes 0 and 1 lost 0.9 to 5.3 dB, and 4 to 6 took twice the time for -1.0 to +0.3 dB.
    const EFFORT: i32 = 2;
    /// vkFormat of basis_universal's UASTC HDR 4x4 KTX2 files (ASTC 4x4 SFLOAT).
    const VK_FORMAT_ASTC_4X4_SFLOAT_BLOCK: u32 = 1_000_066_000;

    pub(in super::super) fn encode(img: &Image) -> Result<Vec<u8>, String> {
        let (w, h) = (img.width, img.height);
        if w == 0 || h == 0 {
            return Ok(Vec::new());
        }
        basisu_encoder_init();
        let row_blocks = w.div_ceil(4);
        let band_rows = BAND_BLOCK_ROWS * 4;
        let mut out = vec![0u8; row_blocks * h.div_ceil(4) * 16];
        out.par_chunks_mut(row_blocks * 16 * BAND_BLOCK_ROWS)
            .zip(img.pixels.par_chunks(w * band_rows))
            .try_for_each(|(blocks, rows)| {
                let mut texels: Vec<f32> = rows.iter().flat_map(|&p| texel(p, [1.0; 3])).collect();
                let bytes = compress(&mut texels, w, rows.len() / w)?;
                blocks.copy_from_slice(&bytes);
                Ok::<(), String>(())
            })?;
        keep_light(img, 4, &mut out, &|texels| {
            let bytes = compress(texels, 4, 4)?;
            let mut block = [0u8; 16];
            block.copy_from_slice(&bytes);
            Ok(block)
        })?;
        Ok(out)
    }

    /// The UASTC HDR 4x4 blocks of one `w` x `h` image of RGBA f32 texels: basis_universal
    /// writes a one-level KTX2 file, whose level is the blocks, row by row.
    fn compress(texels: &mut [f32], w: usize, h: usize) -> Result<Vec<u8>, String> {
        let failed = |why: &str| format!("basis_universal failed: {why}");
        let mut encoder = BasisuEncoder::new();
        encoder
            .set_image(SourceImage {
                data: bytemuck::cast_slice(texels),
                format: SourceImageFormat::Rgba32Float,
                size: Extent3d {
                    width: w as u32,
                    height: h as u32,
                    depth_or_array_layers: 1,
                },
            })
            .map_err(|e| failed(&e.to_string()))?;
        let file = encoder
            .compress(BasisuEncoderParams {
                basis_tex_format: BasisTextureFormat::UastcHdr4x4,
                // UASTC HDR 4x4 has no rate-distortion step: quality is not its parameter.
                quality_level: -1,
                effort_level: EFFORT,
                // One thread, no supercompression: the level is the plain blocks.
                flags_and_quality: common::BU_COMP_FLAGS_KTX2_OUTPUT,
                low_level_uastc_rdo_or_dct_quality: 0.0,
            })
            .map_err(|e| failed(&e.to_string()))?;
        level_zero(&file, w.div_ceil(4) * h.div_ceil(4) * 16)
            .ok_or_else(|| failed("its KTX2 file is not the one level of UASTC HDR 4x4 asked for"))
    }

    /// Level 0 of a KTX2 file that must hold `len` bytes of plain ASTC 4x4 HDR blocks.
    fn level_zero(file: &[u8], len: usize) -> Option<Vec<u8>> {
        let u32_at = |o: usize| Some(u32::from_le_bytes(file.get(o..o + 4)?.try_into().ok()?));
        let u64_at = |o: usize| Some(u64::from_le_bytes(file.get(o..o + 8)?.try_into().ok()?));
        // vkFormat at 12, supercompressionScheme at 44, level 0's offset and length at 80.
        if u32_at(12)? != VK_FORMAT_ASTC_4X4_SFLOAT_BLOCK || u32_at(44)? != 0 {
            return None;
        }
        let (offset, length) = (u64_at(80)? as usize, u64_at(88)? as usize);
        if length != len {
            return None;
        }
        Some(file.get(offset..offset.checked_add(length)?)?.to_vec())
    }
}
