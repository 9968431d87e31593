//! Which gain-map metadata an UltraHDR file is read by. libultrahdr's default build (and so
//! Android's and Chrome's encoders) writes ISO 21496-1 only: an APP2 block
//! (`urn:iso:std:iso:ts:21496:-1`) in the gain map's JPEG, and a version-only one in the
//! primary's; other writers add Adobe's `hdrgm` XMP, or write only that. The standard says a
//! reader that understands both takes the ISO block, so it comes first here; the XMP is what
//! `ultrahdr-rs`'s decoder reads. The block's two layouts (a common denominator, or a
//! fraction per value) are `ultrahdr-core`'s parser's.

use ultrahdr_core::metadata::iso21496::parse_iso21496;
use ultrahdr_core::Iso21496Format;
use ultrahdr_rs::container::scan_segments;
use ultrahdr_rs::{Decoder, GainMapMetadata};

/// The namespace that opens an ISO 21496-1 APP2 block, NUL included.
const ISO_NAMESPACE: &[u8] = b"urn:iso:std:iso:ts:21496:-1\0";

/// The payload of the first ISO 21496-1 APP2 block of `jpeg` (after its namespace).
fn iso_block(jpeg: &[u8]) -> Option<Vec<u8>> {
    scan_segments(jpeg)
        .into_iter()
        .find(|s| s.marker_num == 2 && s.data.starts_with(ISO_NAMESPACE))
        .map(|s| s.data[ISO_NAMESPACE.len()..].to_vec())
}

/// Whether `jpeg` says, in an ISO 21496-1 block of its own, that it has a gain map.
pub(super) fn declares_iso(jpeg: &[u8]) -> bool {
    iso_block(jpeg).is_some()
}

/// Where the metadata came from, for `info`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Source {
    Iso,
    Xmp,
}

/// The gain-map metadata of a decoded container: the gain map's ISO 21496-1 block where it
/// has a whole one, else the XMP; Err (what is wrong) when neither can be read.
pub(super) fn of(decoder: &Decoder) -> Result<(GainMapMetadata, Source), String> {
    // A file that says anything not finite is refused, whichever block would be read.
    if decoder.metadata().is_some_and(|m| !finite(m)) {
        return Err("its gain-map metadata holds a value that is not finite".into());
    }
    let iso = decoder.gainmap_jpeg().and_then(iso_block);
    match iso {
        // A block of four bytes holds the versions alone (what a primary carries).
        Some(block) if block.len() > 4 => match parse_iso21496(&block, Iso21496Format::JpegApp2) {
            Ok(m) => Ok((m, Source::Iso)),
            Err(e) => match decoder.metadata() {
                Some(m) => Ok((m.clone(), Source::Xmp)),
                None => Err(format!(
                    "its ISO 21496-1 gain-map metadata cannot be read: {e}"
                )),
            },
        },
        _ => match decoder.metadata() {
            Some(m) => Ok((m.clone(), Source::Xmp)),
            None => Err(
                "it declares a gain map but holds no gain-map metadata that cubeforge \
                         reads (ISO 21496-1 or Adobe's hdrgm XMP)"
                    .into(),
            ),
        },
    }
}

/// Whether every value `m` holds is a finite number (a gamma above 0).
pub(super) fn finite(m: &GainMapMetadata) -> bool {
    let ok = |v: f64| v.is_finite();
    (0..3).all(|c| {
        ok(m.gain_map_min[c])
            && ok(m.gain_map_max[c])
            && ok(m.gamma[c])
            && m.gamma[c] > 0.0
            && ok(m.base_offset[c])
            && ok(m.alternate_offset[c])
    })
}

/// The matrix from the linear RGB of the primary picture's ICC profile to cubeforge's
/// (BT.709 / sRGB primaries), where the profile has other primaries: libultrahdr writes its
/// pictures in Display P3, whose colours read as sRGB come out 2-5% off in each channel and
/// dulled. None for sRGB, for no profile and for one that cannot be read (taken as sRGB, as
/// every JPEG reader does).
pub(super) fn primaries(decoder: &Decoder) -> Option<glam::Mat3> {
    let icc = decoder.icc_profile()?;
    let profile = moxcms::ColorProfile::new_from_slice(&icc).ok()?;
    if profile.color_space != moxcms::DataColorSpace::Rgb {
        return None;
    }
    let m = profile
        .transform_matrix(&moxcms::ColorProfile::new_srgb())
        .v;
    let identity = (0..3).all(|r| (0..3).all(|c| (m[r][c] - (r == c) as u8 as f64).abs() < 1e-3));
    (!identity && m.iter().flatten().all(|v| v.is_finite())).then(|| {
        // glam is column-major: column c holds the matrix's column c.
        glam::Mat3::from_cols_array_2d(&[0, 1, 2].map(|c| [0, 1, 2].map(|r| m[r][c] as f32)))
    })
}
