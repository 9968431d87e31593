//! How a [`GpuFormat`] is named in a KTX2 file: its vkFormat, typeSize and Data Format
//! Descriptor (the Khronos Data Format Specification's basic block, as libktx writes it).

use super::GpuFormat;

pub(super) const VK_FORMAT_R8G8B8A8_UNORM: u32 = 37;
pub(super) const VK_FORMAT_R8G8B8A8_SRGB: u32 = 43;
pub(super) const VK_FORMAT_R16G16B16A16_SFLOAT: u32 = 97;
pub(super) const VK_FORMAT_R32G32B32A32_SFLOAT: u32 = 109;
pub(super) const VK_FORMAT_B10G11R11_UFLOAT_PACK32: u32 = 122;
pub(super) const VK_FORMAT_E5B9G9R9_UFLOAT_PACK32: u32 = 123;
pub(super) const VK_FORMAT_BC6H_UFLOAT_BLOCK: u32 = 143;
pub(super) const VK_FORMAT_BC7_UNORM_BLOCK: u32 = 145;
pub(super) const VK_FORMAT_BC7_SRGB_BLOCK: u32 = 146;
/// VK_EXT_texture_compression_astc_hdr (core in Vulkan 1.3).
pub(super) const VK_FORMAT_ASTC_4X4_SFLOAT_BLOCK: u32 = 1_000_066_000;
pub(super) const VK_FORMAT_ASTC_6X6_SFLOAT_BLOCK: u32 = 1_000_066_004;

/// supercompressionScheme of Zstandard.
pub(super) const SCHEME_ZSTD: u32 = 2;

// Khronos Data Format Specification constants used by the basic descriptor block.
pub(super) const KHR_DF_VENDORID_KHRONOS: u32 = 0;
pub(super) const KHR_DF_KHR_DESCRIPTORTYPE_BASICFORMAT: u32 = 0;
pub(super) const KHR_DF_VERSIONNUMBER_1_3: u32 = 2;
pub(super) const KHR_DF_MODEL_RGBSDA: u32 = 1;
pub(super) const KHR_DF_MODEL_BC6H: u32 = 133;
pub(super) const KHR_DF_MODEL_BC7: u32 = 134;
pub(super) const KHR_DF_MODEL_ASTC: u32 = 162;
/// basis_universal's colour model for UASTC HDR 4x4: ASTC 4x4 HDR blocks in its subset
/// (three.js's KTX2Loader looks for it beside the ASTC vkFormat).
pub(super) const KHR_DF_MODEL_UASTC_HDR_4X4: u32 = 167;
pub(super) const KHR_DF_PRIMARIES_BT709: u32 = 1;
pub(super) const KHR_DF_TRANSFER_LINEAR: u32 = 1;
pub(super) const KHR_DF_TRANSFER_SRGB: u32 = 2;
pub(super) const KHR_DF_FLAG_ALPHA_STRAIGHT: u32 = 0;
pub(super) const KHR_DF_CHANNEL_RGBSDA_RED: u32 = 0;
pub(super) const KHR_DF_CHANNEL_RGBSDA_GREEN: u32 = 1;
pub(super) const KHR_DF_CHANNEL_RGBSDA_BLUE: u32 = 2;
pub(super) const KHR_DF_CHANNEL_RGBSDA_ALPHA: u32 = 15;
pub(super) const KHR_DF_SAMPLE_DATATYPE_LINEAR: u32 = 0x10;
pub(super) const KHR_DF_SAMPLE_DATATYPE_EXPONENT: u32 = 0x20;
pub(super) const KHR_DF_SAMPLE_DATATYPE_SIGNED: u32 = 0x40;
pub(super) const KHR_DF_SAMPLE_DATATYPE_FLOAT: u32 = 0x80;
/// Bytes of a basic descriptor block before its samples.
pub(super) const DFD_BLOCK_HEADER_LEN: u32 = 24;
/// Bytes of one sample description.
pub(super) const DFD_SAMPLE_LEN: u32 = 16;
pub(super) fn vk_format(format: GpuFormat) -> u32 {
    match format {
        GpuFormat::Rgba16f => VK_FORMAT_R16G16B16A16_SFLOAT,
        GpuFormat::Rgba32f => VK_FORMAT_R32G32B32A32_SFLOAT,
        GpuFormat::Rgba8Srgb => VK_FORMAT_R8G8B8A8_SRGB,
        GpuFormat::Rgba8 => VK_FORMAT_R8G8B8A8_UNORM,
        GpuFormat::Bc6h => VK_FORMAT_BC6H_UFLOAT_BLOCK,
        GpuFormat::Bc7 => VK_FORMAT_BC7_UNORM_BLOCK,
        GpuFormat::Bc7Srgb => VK_FORMAT_BC7_SRGB_BLOCK,
        GpuFormat::Rgb9e5 => VK_FORMAT_E5B9G9R9_UFLOAT_PACK32,
        GpuFormat::Rg11b10 => VK_FORMAT_B10G11R11_UFLOAT_PACK32,
        GpuFormat::AstcHdr4x4 | GpuFormat::UastcHdr4x4 => VK_FORMAT_ASTC_4X4_SFLOAT_BLOCK,
        GpuFormat::AstcHdr6x6 => VK_FORMAT_ASTC_6X6_SFLOAT_BLOCK,
    }
}

/// The format of a file's vkFormat and the colour model of its DFD: UASTC HDR 4x4 shares
/// ASTC 4x4's vkFormat and names itself by its colour model.
pub(super) fn from_vk_format(vk: u32, color_model: Option<u32>) -> Option<GpuFormat> {
    Some(match vk {
        VK_FORMAT_ASTC_4X4_SFLOAT_BLOCK if color_model == Some(KHR_DF_MODEL_UASTC_HDR_4X4) => {
            GpuFormat::UastcHdr4x4
        }
        VK_FORMAT_R16G16B16A16_SFLOAT => GpuFormat::Rgba16f,
        VK_FORMAT_R32G32B32A32_SFLOAT => GpuFormat::Rgba32f,
        VK_FORMAT_R8G8B8A8_SRGB => GpuFormat::Rgba8Srgb,
        VK_FORMAT_R8G8B8A8_UNORM => GpuFormat::Rgba8,
        VK_FORMAT_BC6H_UFLOAT_BLOCK => GpuFormat::Bc6h,
        VK_FORMAT_BC7_UNORM_BLOCK => GpuFormat::Bc7,
        VK_FORMAT_BC7_SRGB_BLOCK => GpuFormat::Bc7Srgb,
        VK_FORMAT_E5B9G9R9_UFLOAT_PACK32 => GpuFormat::Rgb9e5,
        VK_FORMAT_B10G11R11_UFLOAT_PACK32 => GpuFormat::Rg11b10,
        VK_FORMAT_ASTC_4X4_SFLOAT_BLOCK => GpuFormat::AstcHdr4x4,
        VK_FORMAT_ASTC_6X6_SFLOAT_BLOCK => GpuFormat::AstcHdr6x6,
        _ => return None,
    })
}

/// What the reader takes, for messages.
pub(super) const SUPPORTED: &str =
    "cubeforge reads RGBA16F, RGBA32F, RGBA8 sRGB/UNORM, BC6H UFLOAT, BC7 sRGB/UNORM, E5B9G9R9, B10G11R11 and ASTC 4x4/6x6 SFLOAT (HDR, UASTC HDR 4x4 among them)";

/// typeSize: the size of the data type for endian conversion (1 for block formats, 4 for
/// the packed 32-bit ones).
pub(super) fn type_size(format: GpuFormat) -> u32 {
    match format {
        GpuFormat::Rgba16f => 2,
        GpuFormat::Rgba32f | GpuFormat::Rgb9e5 | GpuFormat::Rg11b10 => 4,
        _ => 1,
    }
}

/// One sample description: bit offset and length, channel with its qualifiers, and the
/// values that stand for 0 and 1 (lower, upper).
pub(super) type Sample = (u32, u32, u32, u32, u32);

/// The Data Format Descriptor: dfdTotalSize, then one basic block (colour model, transfer,
/// texel block size and bytes, then its samples), as the Khronos Data Format Specification
/// describes each Vulkan format.
pub(super) fn data_format_descriptor(format: GpuFormat) -> Vec<u8> {
    let transfer = if format.is_srgb() {
        KHR_DF_TRANSFER_SRGB
    } else {
        KHR_DF_TRANSFER_LINEAR
    };
    let (model, samples) = samples(format, transfer);
    let block_size = DFD_BLOCK_HEADER_LEN + samples.len() as u32 * DFD_SAMPLE_LEN;
    let dim = format.block_dim() as u32 - 1;
    let mut words: Vec<u32> = vec![
        4 + block_size,
        KHR_DF_VENDORID_KHRONOS | (KHR_DF_KHR_DESCRIPTORTYPE_BASICFORMAT << 17),
        KHR_DF_VERSIONNUMBER_1_3 | (block_size << 16),
        model
            | (KHR_DF_PRIMARIES_BT709 << 8)
            | (transfer << 16)
            | (KHR_DF_FLAG_ALPHA_STRAIGHT << 24),
        dim | (dim << 8), // texelBlockDimension0..3, each stored as value - 1
        format.block_bytes() as u32, // bytesPlane0; bytesPlane1..3 are 0
        0,                // bytesPlane4..7
    ];
    for (offset, bits, channel, lower, upper) in samples {
        words.push(offset | ((bits - 1) << 16) | (channel << 24));
        words.push(0); // samplePosition0..3
        words.push(lower);
        words.push(upper);
    }
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// 1.0f and -1.0f, as a sample's upper and lower values.
const ONE: u32 = 0x3F80_0000;
const MINUS_ONE: u32 = 0xBF80_0000;

/// A format's colour model and its samples (for `transfer`: alpha is marked linear under
/// sRGB).
fn samples(format: GpuFormat, transfer: u32) -> (u32, Vec<Sample>) {
    let float = KHR_DF_SAMPLE_DATATYPE_FLOAT;
    let signed_float = KHR_DF_SAMPLE_DATATYPE_FLOAT | KHR_DF_SAMPLE_DATATYPE_SIGNED;
    let rgb = [
        KHR_DF_CHANNEL_RGBSDA_RED,
        KHR_DF_CHANNEL_RGBSDA_GREEN,
        KHR_DF_CHANNEL_RGBSDA_BLUE,
    ];
    let rgba = [
        KHR_DF_CHANNEL_RGBSDA_RED,
        KHR_DF_CHANNEL_RGBSDA_GREEN,
        KHR_DF_CHANNEL_RGBSDA_BLUE,
        KHR_DF_CHANNEL_RGBSDA_ALPHA,
    ];
    match format {
        GpuFormat::Rgba16f | GpuFormat::Rgba32f | GpuFormat::Rgba8 | GpuFormat::Rgba8Srgb => {
            let bits = format.block_bytes() as u32 * 2;
            let samples = rgba
                .iter()
                .enumerate()
                .map(|(i, &channel)| {
                    let mut q = 0;
                    if format.is_float() {
                        q |= signed_float;
                    }
                    // Alpha is never sRGB-encoded: the spec asks for the LINEAR bit on it when
                    // the transfer function is not linear.
                    if channel == KHR_DF_CHANNEL_RGBSDA_ALPHA && transfer != KHR_DF_TRANSFER_LINEAR
                    {
                        q |= KHR_DF_SAMPLE_DATATYPE_LINEAR;
                    }
                    let (lower, upper) = if format.is_float() {
                        (MINUS_ONE, ONE)
                    } else {
                        (0, 255)
                    };
                    (i as u32 * bits, bits, channel | q, lower, upper)
                })
                .collect();
            (KHR_DF_MODEL_RGBSDA, samples)
        }
        // Packed from bit 0: R 11 bits, G 11, B 10, each an unsigned float.
        GpuFormat::Rg11b10 => (
            KHR_DF_MODEL_RGBSDA,
            vec![
                (0, 11, rgb[0] | float, 0, ONE),
                (11, 11, rgb[1] | float, 0, ONE),
                (22, 10, rgb[2] | float, 0, ONE),
            ],
        ),
        // Each channel: its 9-bit mantissa and the shared 5-bit exponent at bit 27, with the
        // lower and upper values libktx's reader expects of this format (it compares them).
        GpuFormat::Rgb9e5 => (
            KHR_DF_MODEL_RGBSDA,
            rgb.iter()
                .enumerate()
                .flat_map(|(i, &c)| {
                    [
                        (9 * i as u32, 9, c, 0, 8448),
                        (27, 5, c | KHR_DF_SAMPLE_DATATYPE_EXPONENT, 15, 31),
                    ]
                })
                .collect(),
        ),
        // One 128-bit sample over the whole block.
        GpuFormat::Bc6h => (KHR_DF_MODEL_BC6H, vec![(0, 128, float, 0, ONE)]),
        GpuFormat::Bc7 | GpuFormat::Bc7Srgb => (KHR_DF_MODEL_BC7, vec![(0, 128, 0, 0, u32::MAX)]),
        // SFLOAT: the ASTC data channel (0) marked signed float, from -1 to 1, as libktx
        // describes every *_SFLOAT_BLOCK.
        GpuFormat::AstcHdr4x4 | GpuFormat::AstcHdr6x6 => (
            KHR_DF_MODEL_ASTC,
            vec![(0, 128, signed_float, MINUS_ONE, ONE)],
        ),
        // As basis_universal writes it: unsigned float, from 0 to 1.
        GpuFormat::UastcHdr4x4 => (KHR_DF_MODEL_UASTC_HDR_4X4, vec![(0, 128, float, 0, ONE)]),
    }
}
