//! Unit tests of the KTX2 writer and reader.
use super::*;

#[test]
fn descriptor_matches_the_spec_layout() {
    let d = data_format_descriptor(GpuFormat::Rgba16f);
    assert_eq!(d.len(), 4 + 24 + 4 * 16);
    let w = |i: usize| u32::from_le_bytes(d[4 * i..4 * i + 4].try_into().unwrap());
    assert_eq!(w(0), 92); // dfdTotalSize
    assert_eq!(w(2), 2 | (88 << 16)); // version 2, block size 88
    assert_eq!(w(3) & 0xFF, KHR_DF_MODEL_RGBSDA);
    assert_eq!((w(3) >> 16) & 0xFF, KHR_DF_TRANSFER_LINEAR);
    assert_eq!(w(5), 8); // bytesPlane0
                         // Blue sample: offset 32, 16 bits, float + signed.
    assert_eq!(w(7 + 8), 32 | (15 << 16) | ((0xC0 | 2) << 24));
    assert_eq!(w(7 + 10), 0xBF80_0000);

    let d = data_format_descriptor(GpuFormat::Rgba8Srgb);
    let w = |i: usize| u32::from_le_bytes(d[4 * i..4 * i + 4].try_into().unwrap());
    assert_eq!((w(3) >> 16) & 0xFF, KHR_DF_TRANSFER_SRGB);
    // Alpha sample: offset 24, 8 bits, linear qualifier, 0..255.
    assert_eq!(w(7 + 12), 24 | (7 << 16) | ((0x10 | 15) << 24));
    assert_eq!(w(7 + 15), 255);
}

#[test]
fn alignment_is_lcm_with_4() {
    assert_eq!(level_alignment(GpuFormat::Rgba8, false), 4);
    assert_eq!(level_alignment(GpuFormat::Rgba16f, false), 8);
    assert_eq!(level_alignment(GpuFormat::Rgba32f, false), 16);
    assert_eq!(level_alignment(GpuFormat::Bc6h, false), 16);
    assert_eq!(level_alignment(GpuFormat::Rgb9e5, false), 4);
    // Supercompressed levels are byte-aligned.
    assert_eq!(level_alignment(GpuFormat::Bc7, true), 1);
}

#[test]
fn block_and_packed_descriptors() {
    let w = |d: &[u8], i: usize| u32::from_le_bytes(d[4 * i..4 * i + 4].try_into().unwrap());
    let d = data_format_descriptor(GpuFormat::Bc6h);
    assert_eq!(d.len(), 4 + 24 + 16);
    assert_eq!(w(&d, 3) & 0xFF, KHR_DF_MODEL_BC6H);
    assert_eq!(w(&d, 4), 3 | (3 << 8)); // 4x4 blocks
    assert_eq!(w(&d, 5), 16);
    assert_eq!(w(&d, 7), (127 << 16) | (0x80 << 24)); // 128 bits, float, unsigned
    let d = data_format_descriptor(GpuFormat::Bc7Srgb);
    assert_eq!(w(&d, 3) & 0xFF, KHR_DF_MODEL_BC7);
    assert_eq!((w(&d, 3) >> 16) & 0xFF, KHR_DF_TRANSFER_SRGB);
    assert_eq!(w(&d, 10), u32::MAX);
    let d = data_format_descriptor(GpuFormat::Rgb9e5);
    assert_eq!(d.len(), 4 + 24 + 6 * 16);
    // Green's exponent sample: bit 27, 5 bits, exponent qualifier, bias 15.
    assert_eq!(w(&d, 7 + 12), 27 | (4 << 16) | ((1 | 0x20) << 24));
    assert_eq!(w(&d, 7 + 14), 15);
    let d = data_format_descriptor(GpuFormat::Rg11b10);
    assert_eq!(w(&d, 7 + 8), 22 | (9 << 16) | ((2 | 0x80) << 24));
}
