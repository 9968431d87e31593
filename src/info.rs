//! What a file or folder holds: layout, sizes, levels, pixel format, colour space and value
//! statistics.

#![warn(missing_docs)]

use crate::chain::{self, LevelsFile};
use crate::convert::{MapKind, Source};
use crate::cube::Faces;
use crate::error::{param, Error, Result};
use crate::flux;
use crate::image::Image;
use crate::input::Input;
use crate::io::{self, Decoded, ReadOptions};
use crate::layout::{self, Kind};
use glam::Vec4;
use serde::Serialize;
use std::path::Path;

mod stream;
pub mod sun;
mod tally;
pub use sun::LightInfo;
use tally::Tally;

/// Value statistics of a file's texels, as `cubeforge info` prints them.
#[derive(Clone, Debug, Serialize)]
pub struct Stats {
    /// Smallest Rec. 709 luminance, linear.
    pub min_luminance: f64,
    /// Largest Rec. 709 luminance, linear.
    pub max_luminance: f64,
    /// Mean Rec. 709 luminance per texel, linear (not weighted by solid angle).
    pub mean_luminance: f64,
    /// Channel values (RGBA counted separately) that are NaN.
    pub nan: u64,
    /// Channel values that are infinite.
    pub inf: u64,
    /// Channel values below 0.
    pub negative: u64,
}

/// Bad channel values in one mip level of a container or chain.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct LevelBad {
    /// The level, 0 the largest.
    pub level: usize,
    /// Channel values that are NaN.
    pub nan: u64,
    /// Channel values that are infinite.
    pub inf: u64,
    /// Channel values below 0.
    pub negative: u64,
}

/// What `cubeforge info` says about one file or folder (also its `--json`).
///
/// `stats` counts bad values (NaN, Inf, negative) over every decoded level, so a bad mip
/// cannot pass unseen, while its luminance and `flux` describe level 0 only (the image a
/// viewer shows; the other levels are its filtered copies). `bad_levels` (JSON
/// `"bad_levels": [{"level": 3, "nan": 2, "inf": 0, "negative": 5}]`) names each level that
/// holds bad values, for inputs of several levels (containers, chain folders); it is left out
/// when every level is clean or there is one level. A 2D texture's levels past 0 are not
/// decoded, so not counted.
#[derive(Clone, Debug, Serialize)]
pub struct Report {
    /// The path as given.
    pub file: String,
    /// The format of the (first) file, by content.
    pub file_format: io::FileFormat,
    /// The layout or container, when the file or the shape tells it.
    pub kind: Option<MapKind>,
    /// Why the layout is unknown or ambiguous.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kind_note: Option<String>,
    /// The layout the file declares of itself and how it was read (OpenEXR's `envmap`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub declared: Option<String>,
    /// Which part of a multi-part file was read, of how many.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub part: Option<String>,
    /// Why the file is taken for a 2D texture rather than an environment map (a container of
    /// one face, a lookup table's channels): it gets no layout, face size or flux.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub texture: Option<String>,
    /// Image width in texels (a face's, for faces and containers).
    pub width: usize,
    /// Image height in texels (a face's, for faces and containers).
    pub height: usize,
    /// Edge of one cube face in texels (None where the layout is unknown).
    pub face_size: Option<usize>,
    /// Mip levels stored (1 for plain images).
    pub mip_levels: usize,
    /// Stored pixel format, e.g. "RGB8", "RGBA16F".
    pub pixel_format: String,
    /// How stored values map to linear light.
    pub color_space: crate::image::ColorSpace,
    /// Luminance over level 0, over the layout's texels only; bad values over every level.
    pub stats: Stats,
    /// The levels that hold bad values, when there are several levels (see above).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub bad_levels: Vec<LevelBad>,
    /// Solid-angle-weighted mean radiance per channel (R, G, B) over the sphere: what every
    /// conversion keeps (see [`crate::flux`]). None where the layout is unknown.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flux: Option<[f64; 3]>,
    /// What each level of a prefiltered chain holds (KTX2 metadata, or a DDS's
    /// `NAME.dds.levels.json` sidecar), as `cubeforge prefilter` wrote it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub levels: Option<LevelsFile>,
    /// The map's sun (JSON null when it has none, or no known layout): see
    /// [`crate::flux::sun`] for the threshold that tells a sun from a sky.
    pub sun: Option<LightInfo>,
    /// The other compact lights (lamps, a second bright patch), brightest first.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<LightInfo>,
}

/// Statistics over images; luminance ignores non-finite values. Each row is summed on its own
/// (in parallel), the rows in order: the same figures on any thread count, and from a file
/// read a band at a time ([`stream`]).
pub fn stats<'a>(images: impl IntoIterator<Item = &'a Image>) -> Stats {
    layout_tally(None, images).stats()
}

/// Statistics over the texels of `img` that hold part of a `kind` layout: a cross's or
/// strip's six faces (not its empty cells), the disc of a sphere or angular map (not the
/// corners outside it), every texel of a panorama or octahedral map. With no layout, every
/// texel.
pub(crate) fn layout_stats(kind: Option<Kind>, img: &Image) -> Stats {
    if let Some(cells) = kind.and_then(Kind::cells) {
        return stats(&layout::cross::extract(cells, img));
    }
    layout_tally(kind.and_then(Kind::projection), [img]).stats()
}

/// The rows of `images` tallied in parallel (those of `projection`'s layout), added in order.
fn layout_tally<'a>(
    projection: Option<layout::Projection>,
    images: impl IntoIterator<Item = &'a Image>,
) -> Tally {
    use rayon::prelude::*;
    let mut t = Tally::default();
    for img in images {
        let (w, h) = (img.width.max(1), img.height);
        let rows: Vec<Tally> = img
            .pixels
            .par_chunks(w)
            .enumerate()
            .map(|(y, row)| Tally::of_row(projection, (w, h), y, row))
            .collect();
        rows.iter().for_each(|r| t.add(r));
    }
    t
}

impl LevelBad {
    /// Counts a texel's bad channel values (NaN, infinite, negative: one kind each).
    fn count(&mut self, p: Vec4) {
        for c in p.to_array() {
            if c.is_nan() {
                self.nan += 1;
            } else if c.is_infinite() {
                self.inf += 1;
            } else if c < 0.0 {
                self.negative += 1;
            }
        }
    }
}

/// Bad values of one face.
fn face_bad(img: &Image) -> LevelBad {
    let mut b = LevelBad::default();
    img.pixels.iter().for_each(|&p| b.count(p));
    b
}

/// Adds the bad values of every level past 0 to `stats` (which counted level 0 with its
/// luminance) and lists the levels that hold any. The faces are counted in parallel: a 4K
/// chain's levels past 0 are a third of level 0's texels, so this stays cheap.
fn count_levels(levels: &[Faces], stats: &mut Stats) -> Vec<LevelBad> {
    use rayon::prelude::*;
    if levels.len() < 2 {
        return Vec::new();
    }
    let faces: Vec<(usize, &Image)> = (1..levels.len())
        .flat_map(|l| levels[l].iter().map(move |f| (l, f)))
        .collect();
    let counted: Vec<(usize, LevelBad)> =
        faces.par_iter().map(|&(l, f)| (l, face_bad(f))).collect();
    let mut per_level: Vec<LevelBad> = (0..levels.len())
        .map(|level| LevelBad {
            level,
            ..LevelBad::default()
        })
        .collect();
    per_level[0].nan = stats.nan;
    per_level[0].inf = stats.inf;
    per_level[0].negative = stats.negative;
    for (l, b) in counted {
        let p = &mut per_level[l];
        p.nan += b.nan;
        p.inf += b.inf;
        p.negative += b.negative;
        stats.nan += b.nan;
        stats.inf += b.inf;
        stats.negative += b.negative;
    }
    per_level.retain(|b| b.nan + b.inf + b.negative > 0);
    per_level
}

/// The flux of a single image laid out as `kind`: a panorama, ball, angular or octahedral map
/// as it is, a cross or strip through its faces.
fn image_flux(kind: Kind, img: &Image) -> Option<[f64; 3]> {
    if let Some(p) = kind.projection() {
        let grid = flux::Grid::Projection(p, img.width, img.height);
        return Some(flux::mean_radiance(grid, &[img]));
    }
    kind.cells()
        .map(|cells| cube_flux(&layout::cross::extract(cells, img)))
}

fn cube_flux(faces: &Faces) -> [f64; 3] {
    flux::mean_radiance(
        flux::Grid::Cube(faces[0].width),
        &faces.iter().collect::<Vec<_>>(),
    )
}

/// What a square image with no `--from` may be.
/// Why a single image is a 2D texture, not an environment map: a GPU container holding one
/// face (a cube map's container holds six), or a square table whose B channel is 0 everywhere
/// (what `cubeforge lut` and other BRDF tables store: R and G only).
fn texture_2d(meta: &io::Meta, img: &Image) -> Option<String> {
    if meta.file_format.container().is_some() {
        return Some(format!(
            "{} file of one face, not a cube map",
            crate::error::with_article(meta.file_format.name())
        ));
    }
    let square_table = img.width == img.height && img.width <= 1024;
    let two_channels = img.pixels.iter().all(|p| p.z == 0.0)
        && img.pixels.iter().any(|p| p.x != 0.0 || p.y != 0.0);
    (square_table && two_channels)
        .then(|| "R and G hold data and B is 0 everywhere, as in a BRDF lookup table".into())
}

fn square_note(n: usize) -> String {
    format!(
        "a square {n}x{n} image: a sphere, angular or octahedral map (face size {}; say which with {f} sphere, {f} angular or {f} octahedral) or a single face (face size {n})",
        (n / 2).max(1),
        f = param("from")
    )
}

/// Reads a file as stored (no value replacement), or a folder of six faces or a prefiltered
/// chain (`m0/`, `m1/`, ... and `levels.json`, as `cubeforge prefilter` writes one), and
/// describes it. `from` settles the layout of a single image (a square one needs it) or
/// overrides what its shape says.
pub fn describe(path: &Path, from: Option<Kind>, opts: &ReadOptions) -> Result<Report> {
    let opts = &ReadOptions {
        as_stored: true,
        ..*opts
    };
    if path.is_dir() {
        return describe_folder(path, from, opts);
    }
    if let Some(report) = stream::describe(path, from, opts)? {
        return Ok(report);
    }
    let (decoded, mut meta) = crate::convert::read_raw(path, opts)?;
    let declared = meta.declared.take();
    let part = meta.part.take();
    let file = path.display().to_string();
    Ok(match decoded {
        Decoded::Cube(cube) => {
            // Only containers decode to cube maps.
            let kind = meta
                .file_format
                .container()
                .map_or(Kind::Faces.into(), MapKind::from);
            if let Some(k) = from {
                return Err(Error::file(
                    path,
                    format!(
                        "{} {}: the file is {} cube map",
                        param("from"),
                        k.name(),
                        crate::error::with_article(meta.file_format.name())
                    ),
                ));
            }
            let n = cube.size();
            let mut stats = stats(cube.levels[0].iter());
            let bad_levels = count_levels(&cube.levels, &mut stats);
            let (sun, lights) = sun::of_faces(&cube.levels[0]);
            Report {
                file,
                file_format: meta.file_format,
                kind: Some(kind),
                kind_note: None,
                declared,
                part,
                texture: None,
                width: n,
                height: n,
                face_size: Some(n),
                mip_levels: cube.levels.len(),
                pixel_format: meta.pixel_format,
                color_space: meta.color_space,
                stats,
                bad_levels,
                flux: Some(cube_flux(&cube.levels[0])),
                levels: chain::container_levels(path, meta.file_format, opts.limits.session),
                sun,
                lights,
            }
        }
        Decoded::Image(img) => {
            let (w, h) = (img.width, img.height);
            let texture = from.is_none().then(|| texture_2d(&meta, &img)).flatten();
            let (kind, note) = image_kind(path, from, (w, h), texture.is_some())?;
            let (sun, lights) = sun::of_image(kind, &img);
            Report {
                file,
                file_format: meta.file_format,
                kind: kind.map(MapKind::Layout),
                kind_note: note,
                declared,
                part,
                texture,
                width: w,
                height: h,
                // Unknown where the layout is: a square image's face is its width or half of it.
                face_size: kind.map(|k| k.face_size(w, h)),
                mip_levels: meta.stored_levels,
                pixel_format: meta.pixel_format,
                color_space: meta.color_space,
                stats: layout_stats(kind, &img),
                bad_levels: Vec::new(),
                flux: kind.and_then(|k| image_flux(k, &img)),
                levels: None,
                sun,
                lights,
            }
        }
    })
}

/// The layout of a `w` x `h` image (`from`, or what its shape says) and, where none is
/// known, why: an error where `from` cannot describe it. A 2D texture has none.
fn image_kind(
    path: &Path,
    from: Option<Kind>,
    (w, h): (usize, usize),
    texture: bool,
) -> Result<(Option<Kind>, Option<String>)> {
    Ok(match from {
        Some(Kind::Faces) => {
            return Err(Error::file(
                path,
                format!(
                    "{} faces does not describe a single image (give a folder of faces, or a .ktx2, .dds, .ktx or .env file)",
                    param("from")
                ),
            ))
        }
        Some(k) if !k.fits(w, h) => {
            return Err(Error::file(
                path,
                format!(
                    "a {w}x{h} image cannot hold {} layout",
                    crate::error::with_article(k.name())
                ),
            ))
        }
        Some(k) => (Some(k), None),
        None if texture => (None, None),
        None if w == h => (None, Some(square_note(w))),
        None => match layout::detect(w, h) {
            Ok(k) => (Some(k), None),
            Err(e) => (None, Some(e)),
        },
    })
}

/// A folder of six faces, or a prefiltered chain `m0/`, `m1/`, ... (each a folder of faces,
/// each level half the size of the one before) with its `levels.json`.
fn describe_folder(dir: &Path, from: Option<Kind>, opts: &ReadOptions) -> Result<Report> {
    if let Some(k) = from.filter(|&k| k != Kind::Faces) {
        return Err(Error::file(
            dir,
            format!(
                "{f} {}: a folder holds faces ({f} faces) or a prefiltered chain",
                k.name(),
                f = param("from")
            ),
        ));
    }
    let (cube, meta, levels) = if chain::is_chain_dir(dir) {
        let (c, _) = Input::open(&[dir.to_path_buf()], None, opts)?.load_chain()?;
        (c.cube, c.meta, c.levels)
    } else {
        if !holds_a_face(dir) {
            // Say what a folder may hold when it holds none of it.
            return Err(Error::file(
                dir,
                format!(
                    "holds neither six faces ({}) nor a prefiltered chain (m0/ m1/ ... and \
                     levels.json)",
                    crate::cube::FACE_NAMINGS
                ),
            ));
        }
        let (loaded, _) = Input::open(&[dir.to_path_buf()], None, opts)?.load()?;
        let Source::Cube(mut cube) = loaded.source else {
            return Err(Error::file(dir, "a folder must hold six faces"));
        };
        cube.levels.truncate(1);
        (cube, loaded.meta, None)
    };
    let base = &cube.levels[0];
    let n = base[0].width;
    let mut stats = stats(base.iter());
    let bad_levels = count_levels(&cube.levels, &mut stats);
    let (sun, lights) = sun::of_faces(base);
    Ok(Report {
        file: dir.display().to_string(),
        file_format: meta.file_format,
        kind: Some(Kind::Faces.into()),
        kind_note: None,
        declared: None,
        part: None,
        texture: None,
        width: n,
        height: n,
        face_size: Some(n),
        mip_levels: cube.levels.len(),
        pixel_format: meta.pixel_format,
        color_space: meta.color_space,
        stats,
        bad_levels,
        flux: Some(cube_flux(base)),
        levels,
        sun,
        lights,
    })
}

/// Whether a folder holds any file named as a face (px.EXT, posx.EXT, ...).
fn holds_a_face(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return true; // find_faces says why it cannot be read
    };
    entries.filter_map(|e| e.ok()).any(|e| {
        let path = std::path::PathBuf::from(e.file_name());
        let stem = path.file_stem().unwrap_or_default().to_string_lossy();
        crate::cube::face_of_stem(&stem).is_some()
    })
}

/// The report as text. Parameters in it (a square image's note names `from`) are marked for
/// a front end to name its own way ([`crate::error::name_params`]).
impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The name on one line, whatever it holds.
        writeln!(f, "{}", self.file.replace('\n', "\\n").replace('\r', "\\r"))?;
        writeln!(f, "  format:       {}", self.file_format.name())?;
        self.layout_line(f)?;
        if let Some(p) = &self.part {
            writeln!(
                f,
                "  part:         {}",
                p.strip_prefix("part ").unwrap_or(p)
            )?;
        }
        writeln!(f, "  dimensions:   {} x {}", self.width, self.height)?;
        match self.face_size {
            _ if self.texture.is_some() => {}
            Some(n) => writeln!(f, "  face size:    {n}")?,
            None if self.kind.is_none() && self.width == self.height => writeln!(
                f,
                "  face size:    unknown: {} as a sphere, angular or octahedral map, {} as a single face",
                (self.width / 2).max(1),
                self.width
            )?,
            None => writeln!(f, "  face size:    unknown")?,
        }
        writeln!(f, "  mip levels:   {}", self.mip_levels)?;
        writeln!(f, "  pixel format: {}", self.pixel_format)?;
        writeln!(
            f,
            "  colour space: {}",
            match self.color_space {
                crate::image::ColorSpace::Srgb => "sRGB",
                crate::image::ColorSpace::Linear => "linear",
            }
        )?;
        let s = &self.stats;
        writeln!(
            f,
            "  luminance:    min {:.6}  max {:.6}  mean {:.6}",
            s.min_luminance, s.max_luminance, s.mean_luminance
        )?;
        write!(
            f,
            "  bad values:   {} NaN, {} Inf, {} negative",
            s.nan, s.inf, s.negative
        )?;
        // One line per level that holds any, aligned with the lines above.
        for b in &self.bad_levels {
            write!(
                f,
                "\n  {:<14}{} NaN, {} Inf, {} negative",
                format!("bad level {}:", b.level),
                b.nan,
                b.inf,
                b.negative
            )?;
        }
        if let Some([r, g, b]) = self.flux {
            write!(
                f,
                "\n  flux:         {r:.6} {g:.6} {b:.6} (mean radiance over the sphere)"
            )?;
            sun::lines(f, self.sun.as_ref(), &self.lights)?;
        }
        self.level_lines(f)
    }
}

impl Report {
    /// The `layout:` line: a 2D texture, the declared or detected layout, or why unknown.
    fn layout_line(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (&self.kind, &self.kind_note) {
            _ if self.texture.is_some() => writeln!(
                f,
                "  layout:       2D texture ({})",
                self.texture.as_deref().unwrap_or_default()
            )?,
            (Some(k), _) if self.declared.is_some() => writeln!(
                f,
                "  layout:       {} ({})",
                k.name(),
                self.declared.as_deref().unwrap_or_default()
            )?,
            (Some(MapKind::Layout(Kind::Faces)), _) if self.mip_levels > 1 => writeln!(
                f,
                "  layout:       faces, a prefiltered chain (folders m0 to m{})",
                self.mip_levels - 1
            )?,
            (Some(MapKind::Layout(Kind::Faces)), _) => {
                writeln!(f, "  layout:       faces (a folder of six)")?
            }
            (Some(k), _) => writeln!(f, "  layout:       {}", k.name())?,
            (None, Some(n)) => writeln!(f, "  layout:       unknown: {n}")?,
            _ => {}
        }
        Ok(())
    }

    /// One line per level of a prefiltered chain: its size and filter.
    fn level_lines(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for l in self.levels.iter().flat_map(|d| &d.levels) {
            let what = match (l.roughness, l.power, l.sigma) {
                (Some(r), _, _) => format!("roughness {r:.3}"),
                (_, Some(p), _) => format!("power {p:.1}"),
                (_, _, Some(s)) => format!("sigma {s:.5} rad"),
                _ => "box".to_string(),
            };
            write!(
                f,
                "\n  level {:>2}:     {:>5} px, {} {what}",
                l.level,
                l.size,
                l.filter.name()
            )?;
        }
        Ok(())
    }
}
