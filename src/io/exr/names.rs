//! What `info` and the warnings call an OpenEXR part: its samples and compression
//! ("RGBA16F (ZIP, 16 lines)") and the layout its `envmap` attribute declares.

use super::super::Envmap;
use exr::meta::BlockDescription;
use exr::prelude::*;

/// Where a user meets OpenEXR's layouts: its latlong runs the other way round from cubeforge's
/// equirect, so a cubeforge panorama given to `exrenvmap -li` comes back mirrored.
const MIRROR_HINT: &str = "; a cubeforge panorama given to exrenvmap comes back mirrored \
    unless written with --mirror";

/// OpenEXR's own environment maps: the layout a header's `envmap` attribute declares, named
/// here and resampled by its definition above io (`convert::read`), and what `info` says.
pub(super) fn envmap_of(header: &exr::meta::header::Header) -> (Option<Envmap>, Option<String>) {
    match header.own_attributes.environment_map {
        None => (None, None),
        Some(exr::meta::attribute::EnvironmentMap::LatitudeLongitude) => (
            Some(Envmap::LatLong),
            Some(format!("declared by its envmap attribute: an OpenEXR latlong map, read by OpenEXR's mapping{MIRROR_HINT}")),
        ),
        Some(exr::meta::attribute::EnvironmentMap::Cube) => (
            Some(Envmap::Cube),
            Some(format!("declared by its envmap attribute: an OpenEXR cube map, read by OpenEXR's faces{MIRROR_HINT}")),
        ),
    }
}

/// How `info` names the part's samples and compression: "RGBA16F (ZIP, 16 lines)", each
/// channel's type where they differ ("R16F G16F B32F"), luminance and chroma as "Y16F" or
/// "Y RY BY16F, chroma 2x2".
pub(super) fn pixel_format(header: &exr::meta::header::Header, alpha: bool, zstd: bool) -> String {
    let kind = |t: SampleType| match t {
        SampleType::F16 => "16F",
        SampleType::U32 => "32UI",
        SampleType::F32 => "32F",
    };
    let has = |n: &str| header.channels.list.iter().find(|c| c.name.eq(n));
    let mut names: Vec<&str> = if has("R").is_some() {
        vec!["R", "G", "B"]
    } else {
        ["Y", "RY", "BY"]
            .into_iter()
            .filter(|n| has(n).is_some())
            .collect()
    };
    if alpha {
        names.push("A");
    }
    let luma = names[0] == "Y";
    let types: Vec<SampleType> = names
        .iter()
        .filter_map(|n| has(n))
        .map(|c| c.sample_type)
        .collect();
    let glue = if luma { " " } else { "" };
    let mut samples = if types.windows(2).all(|w| w[0] == w[1]) {
        format!(
            "{}{}",
            names.join(glue),
            types.first().map_or("", |&t| kind(t))
        )
    } else {
        let each: Vec<String> = names
            .iter()
            .zip(&types)
            .map(|(n, &t)| format!("{n}{}", kind(t)))
            .collect();
        each.join(" ")
    };
    if let Some(c) = has("RY").filter(|c| luma && c.sampling != Vec2(1, 1)) {
        samples += &format!(", chroma {}x{}", c.sampling.0, c.sampling.1);
    }
    let mut compression = if zstd {
        "ZSTD".to_string()
    } else {
        compression_name(header.compression)
    };
    // A tiled file compresses a tile a block, whatever the scan-line count of its name.
    if let BlockDescription::Tiles(t) = &header.blocks {
        compression = match header.compression {
            Compression::ZIP1 if !zstd => "ZIPS".into(),
            Compression::ZIP16 if !zstd => "ZIP".into(),
            _ => compression,
        };
        compression += &format!(", tiles {}x{}", t.tile_size.0, t.tile_size.1);
    }
    format!("{samples} ({compression})")
}

/// A compression as OpenEXR names it ("ZIP, 16 lines", "DWAB, level 45").
pub(super) fn compression_name(compression: Compression) -> String {
    match compression {
        Compression::Uncompressed => "uncompressed".to_string(),
        Compression::RLE => "RLE".into(),
        Compression::ZIP1 => "ZIPS, 1 line".into(),
        Compression::ZIP16 => "ZIP, 16 lines".into(),
        Compression::PIZ => "PIZ".into(),
        Compression::PXR24 => "PXR24".into(),
        Compression::B44 => "B44".into(),
        Compression::B44A => "B44A".into(),
        Compression::DWAA(level) => dwa("DWAA", level),
        Compression::DWAB(level) => dwa("DWAB", level),
        #[allow(unreachable_patterns)]
        other => format!("{other:?}"),
    }
}

/// A DWA compression's name, with its level where the file states one.
fn dwa(name: &str, level: Option<f32>) -> String {
    match level {
        Some(l) => format!("{name}, level {l}"),
        None => name.into(),
    }
}
