//! Which image of an OpenEXR file is read, and the images the common decoders leave out: a
//! part other than the first (`--part N|NAME`), a stored level other than the largest
//! (`--level N`), and luminance/chroma images (Y, RY, BY), converted to RGB as OpenEXR's
//! `RgbaInputFile` does. Their channels come from [`super::planes`].

use super::checks::RawChunk;
use super::planes::{self, Plane};
use crate::image::Image;
use exr::meta::attribute::LevelMode;
use exr::meta::header::Header;
use exr::meta::{BlockDescription, MetaData};
use exr::prelude::*;
use glam::{Mat3, Vec3, Vec4};

/// The part `choice` names (None: the first), checked against the file's parts.
pub(super) fn part(meta: &MetaData, choice: Option<usize>) -> std::result::Result<usize, String> {
    let n = meta.headers.len();
    match choice {
        None => Ok(0),
        Some(k) if k < n => Ok(k),
        Some(k) => Err(format!(
            "no part {k}: the file holds {n} part{} ({})",
            if n == 1 { "" } else { "s" },
            names(meta).join(", ")
        )),
    }
}

/// An EXR text (a part's or channel's name) as written: OpenEXR stores UTF-8, where the exr
/// crate's `to_string` reads each byte as a Latin-1 character.
pub(super) fn text(t: &exr::meta::attribute::Text) -> String {
    String::from_utf8_lossy(t.bytes()).into_owned()
}

/// Each part as `info` and messages name it: its index and, where it has one, its name.
pub(super) fn names(meta: &MetaData) -> Vec<String> {
    meta.headers
        .iter()
        .enumerate()
        .map(|(i, h)| match &h.own_attributes.layer_name {
            Some(name) => format!("{i} {:?}", text(name)),
            None => i.to_string(),
        })
        .collect()
}

/// The index of the part named `name` (a part's `name` attribute), from the file's headers:
/// how a front end turns `--part NAME` into an index.
pub(super) fn part_named(meta: &MetaData, name: &str) -> std::result::Result<usize, String> {
    meta.headers
        .iter()
        .position(|h| {
            h.own_attributes
                .layer_name
                .as_ref()
                .is_some_and(|n| n.bytes() == name.as_bytes())
        })
        .ok_or_else(|| {
            format!(
                "no part named {name:?}: its parts are {}",
                names(meta).join(", ")
            )
        })
}

/// What `Meta::part` says of a multi-part file: which part was read, of how many.
pub(super) fn part_note(meta: &MetaData, part: usize, chosen: bool) -> Option<String> {
    let n = meta.headers.len();
    (n > 1).then(|| {
        let this = &names(meta)[part];
        if chosen {
            format!("part {this} of {n}")
        } else {
            format!(
                "part {this} of {n} (choose another with {} N or NAME)",
                crate::error::param("part")
            )
        }
    })
}

/// How many levels a part stores: 1 for scan lines and one-level tiles, the mip chain's
/// length for mip maps; rip maps count their levels that shrink both ways alike.
pub(super) fn level_count(header: &Header) -> usize {
    match header.blocks {
        BlockDescription::Tiles(t) => match t.level_mode {
            LevelMode::Singular => 1,
            LevelMode::MipMap | LevelMode::RipMap => {
                let largest = header.layer_size.0.max(header.layer_size.1);
                exr::meta::compute_level_count(t.rounding_mode, largest).min(
                    if t.level_mode == LevelMode::RipMap {
                        let smallest = header.layer_size.0.min(header.layer_size.1);
                        exr::meta::compute_level_count(t.rounding_mode, smallest)
                    } else {
                        usize::MAX
                    },
                )
            }
        },
        BlockDescription::ScanLines => 1,
    }
}

/// Part `part`'s level `level` as RGBA: from R G B (A), or from Y (grey) or Y RY BY
/// (luminance and chroma) as OpenEXR reconstructs them. Subsampled channels are
/// interpolated between their samples.
pub(super) fn image(
    meta: &MetaData,
    part: usize,
    level: usize,
    chunks: &[RawChunk],
    zstd: bool,
    rgb: bool,
) -> std::result::Result<Image, String> {
    let header = &meta.headers[part];
    let wanted: &[&str] = if rgb {
        &["R", "G", "B", "A"]
    } else {
        &["Y", "RY", "BY", "A"]
    };
    let planes = planes::read_planes(meta, part, (level, level), chunks, zstd, wanted)?;
    let (w, h) = planes::level_size(header, (level, level));
    let find = |n: &str| planes.iter().find(|p| p.name == n);
    let mut img = Image::new(w, h);
    let sample = |p: Option<&Plane>, x: usize, y: usize, default: f32| {
        p.map_or(default, |p| at(p, x, y, w, h))
    };
    let a = find("A");
    if rgb {
        let (r, g, b) = (find("R"), find("G"), find("B"));
        for y in 0..h {
            for x in 0..w {
                let t = Vec4::new(
                    sample(r, x, y, 0.0),
                    sample(g, x, y, 0.0),
                    sample(b, x, y, 0.0),
                    sample(a, x, y, 1.0),
                );
                img.set(x, y, t);
            }
        }
        return Ok(img);
    }
    let ly = find("Y");
    // Chroma at every texel: OpenEXR's filters where it is sampled every 2 x 2 texels.
    let full = |p: Option<&Plane>| -> Vec<f32> {
        match p {
            Some(p) if p.width * 2 == w && p.height * 2 == h => reconstruct(p),
            Some(p) => (0..w * h).map(|i| at(p, i % w, i / w, w, h)).collect(),
            None => vec![0.0; w * h],
        }
    };
    let (ry, by) = (full(find("RY")), full(find("BY")));
    let yw = luminance_weights(header);
    for y in 0..h {
        for x in 0..w {
            let l = sample(ly, x, y, 0.0);
            let (cr, cb) = (ry[y * w + x], by[y * w + x]);
            // OpenEXR's YCAtoRGB: RY = (R - Y) / Y, BY = (B - Y) / Y.
            let c = if cr == 0.0 && cb == 0.0 {
                Vec3::splat(l)
            } else {
                let r = (cr + 1.0) * l;
                let b = (cb + 1.0) * l;
                Vec3::new(r, (l - r * yw.x - b * yw.z) / yw.y, b)
            };
            img.set(x, y, c.extend(sample(a, x, y, 1.0)));
        }
    }
    Ok(img)
}

/// OpenEXR's chroma reconstruction filter (`RgbaYca::reconstructChromaHoriz` and `Vert`):
/// weights of the samples 1, 3, 5, ... 13 texels away on either side.
const TAPS: [f32; 7] = [
    0.627123, -0.186077, 0.087929, -0.043159, 0.019597, -0.007540, 0.002128,
];

/// A chroma plane sampled every 2 x 2 texels at every texel, as `RgbaInputFile` fills it in:
/// on the rows it samples, the odd texels from the samples on either side (the row's first
/// sample repeated before it, its last after); then the odd rows from the rows on either side
/// (the first row repeated above, the last below).
fn reconstruct(p: &Plane) -> Vec<f32> {
    let (w, h) = (p.width * 2, p.height * 2);
    // Sampled rows at full width.
    let rows: Vec<Vec<f32>> = (0..p.height)
        .map(|j| {
            let src = &p.samples[j * p.width..(j + 1) * p.width];
            let even = |x: isize| src[(x.max(0) as usize / 2).min(p.width - 1)];
            (0..w as isize)
                .map(|x| {
                    if x % 2 == 0 {
                        return even(x);
                    }
                    TAPS.iter()
                        .enumerate()
                        .map(|(t, c)| {
                            let d = 2 * t as isize + 1;
                            c * (even(x - d) + even(x + d))
                        })
                        .sum()
                })
                .collect()
        })
        .collect();
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        let line = &mut out[y * w..(y + 1) * w];
        if y % 2 == 0 {
            line.copy_from_slice(&rows[y / 2]);
            continue;
        }
        let row = |y: isize| &rows[(y.max(0) as usize / 2).min(p.height - 1)];
        for (t, c) in TAPS.iter().enumerate() {
            let d = 2 * t as isize + 1;
            let (above, below) = (row(y as isize - d), row(y as isize + d));
            for ((o, a), b) in line.iter_mut().zip(above).zip(below) {
                *o += c * (a + b);
            }
        }
    }
    out
}

/// A plane's value at texel (x, y) of the `w` x `h` level: its own sample where it has one,
/// else linearly between the samples around (a sample sits on the first texel it covers, as
/// OpenEXR places them).
fn at(p: &Plane, x: usize, y: usize, w: usize, h: usize) -> f32 {
    let (sx, sy) = (w / p.width.max(1), h / p.height.max(1));
    if sx == 1 && sy == 1 {
        return p.samples[y * p.width + x];
    }
    let lerp_axis = |v: usize, s: usize, n: usize| {
        let u = v as f32 / s as f32;
        let i0 = (u.floor() as usize).min(n - 1);
        let i1 = (i0 + 1).min(n - 1);
        (i0, i1, u - i0 as f32)
    };
    let (x0, x1, tx) = lerp_axis(x, sx, p.width);
    let (y0, y1, ty) = lerp_axis(y, sy, p.height);
    let s = |i: usize, j: usize| p.samples[j * p.width + i];
    let top = s(x0, y0) * (1.0 - tx) + s(x1, y0) * tx;
    let bottom = s(x0, y1) * (1.0 - tx) + s(x1, y1) * tx;
    top * (1.0 - ty) + bottom * ty
}

/// The luminance of each primary (OpenEXR's `computeYw`): the Y row of the RGB-to-XYZ matrix
/// of the file's chromaticities (Rec. 709 and D65 where it states none).
fn luminance_weights(header: &Header) -> Vec3 {
    let Some(c) = header.shared_attributes.chromaticities else {
        return Vec3::new(0.2126, 0.7152, 0.0722);
    };
    let xyz = |p: Vec2<f32>| Vec3::new(p.0 / p.1, 1.0, (1.0 - p.0 - p.1) / p.1);
    let m = Mat3::from_cols(xyz(c.red), xyz(c.green), xyz(c.blue));
    let scale = m.inverse() * xyz(c.white);
    if scale.is_finite() && scale.y > 0.0 {
        scale
    } else {
        Vec3::new(0.2126, 0.7152, 0.0722)
    }
}

/// The message for a part with neither R, G and B nor Y: its channels, quoted with escapes (a
/// corrupt name can hold a newline), at most eight of them.
pub(super) fn no_colour(header: &Header, part: usize) -> String {
    let list = &header.channels.list;
    let mut names: Vec<String> = list
        .iter()
        .take(8)
        .map(|c| format!("{:?}", text(&c.name)))
        .collect();
    if list.len() > 8 {
        names.push(format!("and {} more", list.len() - 8));
    }
    format!(
        "OpenEXR part {part} has channels [{}]: neither R, G and B nor Y (luminance)",
        names.join(", ")
    )
}
