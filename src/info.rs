//! What a file or folder holds: layout, sizes, levels, pixel format, colour space and value
//! statistics.

use crate::convert::find_faces;
use crate::cube::{faces_from_images, CubeMap, Faces, FACE_LONG_NAMES, FACE_NAMES};
use crate::error::{Error, Result};
use crate::flux;
use crate::image::{luminance, Image};
use crate::io::{self, Decoded, Meta, ReadOptions};
use crate::layout::{self, Kind};
use glam::Vec4;
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(Clone, Debug, Serialize)]
pub struct Stats {
    pub min_luminance: f64,
    pub max_luminance: f64,
    pub mean_luminance: f64,
    /// Counts of channel values (RGBA) that are NaN, infinite, or negative.
    pub nan: u64,
    pub inf: u64,
    pub negative: u64,
}

#[derive(Clone, Debug, Serialize)]
pub struct Report {
    pub file: String,
    pub file_format: io::FileFormat,
    /// The layout, when the shape tells it.
    pub kind: Option<Kind>,
    /// Why the layout is unknown or ambiguous.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kind_note: Option<String>,
    pub width: usize,
    pub height: usize,
    pub face_size: Option<usize>,
    pub mip_levels: usize,
    pub pixel_format: String,
    pub color_space: crate::image::ColorSpace,
    pub stats: Stats,
    /// Solid-angle-weighted mean radiance per channel (R, G, B) over the sphere: what every
    /// conversion keeps (see [`crate::flux`]). None where the layout is unknown.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flux: Option<[f64; 3]>,
    /// What each level of a prefiltered chain holds (KTX2 metadata, or a DDS's
    /// `NAME.dds.levels.json` sidecar), as `cubeforge prefilter` wrote it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub levels: Option<serde_json::Value>,
}

/// The levels description of a prefiltered KTX2 or DDS chain, if it has one.
fn levels_description(path: &Path, format: io::FileFormat) -> Option<serde_json::Value> {
    let bytes = match format {
        io::FileFormat::Ktx2 => io::ktx2::metadata_from_file(path)
            .into_iter()
            .find(|(k, _)| k == io::ktx2::LEVELS_KEY)
            .map(|(_, v)| v)?,
        io::FileFormat::Dds => {
            let mut s = path.as_os_str().to_owned();
            s.push(".levels.json");
            std::fs::read(s).ok()?
        }
        _ => return None,
    };
    serde_json::from_slice(&bytes).ok()
}

/// Statistics over images; luminance ignores non-finite values, sums run in a fixed order.
pub fn stats<'a>(images: impl IntoIterator<Item = &'a Image>) -> Stats {
    stats_of(images.into_iter().flat_map(|img| img.pixels.iter()))
}

/// Statistics over the texels of `img` that hold part of a `kind` layout: a cross's or
/// strip's six faces (not its empty cells), the disc of a sphere or angular map (not the
/// corners outside it), every texel of a panorama. With no layout, every texel.
pub fn layout_stats(kind: Option<Kind>, img: &Image) -> Stats {
    match kind {
        Some(k) if k.is_cells() => stats(&layout::cross::extract(k, img)),
        Some(k) => match k.projection() {
            Some(p @ (layout::Projection::Sphere | layout::Projection::Angular)) => {
                let (w, h) = (img.width, img.height);
                stats_of(img.pixels.iter().enumerate().filter_map(|(i, px)| {
                    let u = ((i % w) as f32 + 0.5) / w as f32;
                    let v = ((i / w) as f32 + 0.5) / h as f32;
                    p.to_dir(u, v).map(|_| px)
                }))
            }
            _ => stats([img]),
        },
        None => stats([img]),
    }
}

fn stats_of<'a>(pixels: impl Iterator<Item = &'a Vec4>) -> Stats {
    let mut s = Stats {
        min_luminance: f64::INFINITY,
        max_luminance: f64::NEG_INFINITY,
        mean_luminance: 0.0,
        nan: 0,
        inf: 0,
        negative: 0,
    };
    let mut sum = 0.0f64;
    let mut n = 0u64;
    for p in pixels {
        for c in p.to_array() {
            if c.is_nan() {
                s.nan += 1;
            } else if c.is_infinite() {
                s.inf += 1;
            } else if c < 0.0 {
                s.negative += 1;
            }
        }
        let l = luminance(*p) as f64;
        if l.is_finite() {
            s.min_luminance = s.min_luminance.min(l);
            s.max_luminance = s.max_luminance.max(l);
            sum += l;
            n += 1;
        }
    }
    if n == 0 {
        s.min_luminance = 0.0;
        s.max_luminance = 0.0;
    } else {
        s.mean_luminance = sum / n as f64;
    }
    s
}

/// The flux of a single image laid out as `kind`: a panorama, ball or angular map as it is,
/// a cross or strip through its faces.
fn image_flux(kind: Kind, img: &Image) -> Option<[f64; 3]> {
    if let Some(p) = kind.projection() {
        let grid = flux::Grid::Projection(p, img.width, img.height);
        return Some(flux::mean_radiance(grid, &[img]));
    }
    kind.is_cells().then(|| {
        let faces = layout::cross::extract(kind, img);
        cube_flux(&faces)
    })
}

fn cube_flux(faces: &Faces) -> [f64; 3] {
    flux::mean_radiance(
        flux::Grid::Cube(faces[0].width),
        &faces.iter().collect::<Vec<_>>(),
    )
}

/// What a square image with no `--from` may be.
fn square_note(n: usize) -> String {
    format!(
        "a square {n}x{n} image: a sphere or angular map (face size {}; say which with --from sphere or --from angular) or a single face (face size {n})",
        (n / 2).max(1)
    )
}

/// Reads a file as stored (no value replacement), or a folder of six faces or a prefiltered
/// chain (`m0/`, `m1/`, ... and `levels.json`, as `cubeforge prefilter` writes one), and
/// describes it. `from` settles the layout of a single image (a square one needs it) or
/// overrides what its shape says.
pub fn describe(path: &Path, from: Option<Kind>, opts: &ReadOptions) -> Result<Report> {
    if path.is_dir() {
        return describe_folder(path, from, opts);
    }
    let (decoded, meta) = io::read_raw(path, opts)?;
    let file = path.display().to_string();
    Ok(match decoded {
        Decoded::Cube(cube) => {
            let kind = if meta.file_format == io::FileFormat::Dds {
                Kind::Dds
            } else {
                Kind::Ktx2
            };
            if let Some(k) = from.filter(|&k| k != kind) {
                return Err(Error::file(
                    path,
                    format!(
                        "--from {}: the file is a {} cube map",
                        k.name(),
                        meta.file_format.name()
                    ),
                ));
            }
            let n = cube.size();
            Report {
                file,
                file_format: meta.file_format,
                kind: Some(kind),
                kind_note: None,
                width: n,
                height: n,
                face_size: Some(n),
                mip_levels: cube.levels.len(),
                pixel_format: meta.pixel_format,
                color_space: meta.color_space,
                stats: stats(cube.levels[0].iter()),
                flux: Some(cube_flux(&cube.levels[0])),
                levels: levels_description(path, meta.file_format),
            }
        }
        Decoded::Image(img) => {
            let (w, h) = (img.width, img.height);
            let (kind, note) = match from {
                Some(k @ (Kind::Faces | Kind::Ktx2 | Kind::Dds)) => {
                    return Err(Error::file(
                        path,
                        format!(
                            "--from {} does not describe a single image (give a folder of faces, or a .ktx2 or .dds file)",
                            k.name()
                        ),
                    ))
                }
                Some(k) if !k.fits(w, h) => {
                    return Err(Error::file(
                        path,
                        format!("a {w}x{h} image cannot hold a {} layout", k.name()),
                    ))
                }
                Some(k) => (Some(k), None),
                None if w == h => (None, Some(square_note(w))),
                None => match layout::detect(w, h) {
                    Ok(k) => (Some(k), None),
                    Err(e) => (None, Some(e)),
                },
            };
            Report {
                file,
                file_format: meta.file_format,
                kind,
                kind_note: note,
                width: w,
                height: h,
                // Unknown where the layout is: a square image's face is its width or half of it.
                face_size: kind.map(|k| k.face_size(w, h)),
                mip_levels: 1,
                pixel_format: meta.pixel_format,
                color_space: meta.color_space,
                stats: layout_stats(kind, &img),
                flux: kind.and_then(|k| image_flux(k, &img)),
                levels: None,
            }
        }
    })
}

/// Six faces read as stored, with the first face's description (and a note where the faces'
/// pixel formats differ).
fn read_faces(dir: &Path, opts: &ReadOptions) -> Result<(Faces, Meta)> {
    let files = find_faces(dir)?;
    let mut images = Vec::with_capacity(6);
    let mut metas: Vec<Meta> = Vec::with_capacity(6);
    for f in &files {
        let (decoded, m) = io::read_raw(f, opts)?;
        match decoded {
            Decoded::Image(img) => images.push(img),
            Decoded::Cube(_) => {
                return Err(Error::file(
                    f,
                    "a face must be a single image, not a cube map",
                ))
            }
        }
        metas.push(m);
    }
    let cube = faces_from_images(images, &files)?;
    let mut meta = metas.swap_remove(0);
    let mut formats = vec![meta.pixel_format.clone()];
    for m in &metas {
        if !formats.contains(&m.pixel_format) {
            formats.push(m.pixel_format.clone());
        }
    }
    if formats.len() > 1 {
        meta.pixel_format = format!("mixed: {}", formats.join(", "));
    }
    let CubeMap { mut levels } = cube;
    Ok((levels.swap_remove(0), meta))
}

/// A folder of six faces, or a prefiltered chain `m0/`, `m1/`, ... (each a folder of faces,
/// each level half the size of the one before) with its `levels.json`.
fn describe_folder(dir: &Path, from: Option<Kind>, opts: &ReadOptions) -> Result<Report> {
    if let Some(k) = from.filter(|&k| k != Kind::Faces) {
        return Err(Error::file(
            dir,
            format!(
                "--from {}: a folder holds faces (--from faces) or a prefiltered chain",
                k.name()
            ),
        ));
    }
    let chain = dir.join("m0").is_dir();
    let (base, meta, mip_levels, levels) = if chain {
        let (base, meta) = read_faces(&dir.join("m0"), opts)?;
        let mut size = base[0].width;
        let mut count = 1;
        loop {
            let sub = dir.join(format!("m{count}"));
            if !sub.is_dir() {
                break;
            }
            let (faces, _) = read_faces(&sub, opts)?;
            let want = (size / 2).max(1);
            if faces[0].width != want {
                return Err(Error::file(
                    &sub,
                    format!(
                        "faces are {0}x{0}, but level m{count} of a chain must be {1}x{1} (half of m{2})",
                        faces[0].width,
                        want,
                        count - 1
                    ),
                ));
            }
            size = want;
            count += 1;
        }
        (base, meta, count, chain_levels(dir, count)?)
    } else {
        if !holds_a_face(dir) {
            // Say what a folder may hold when it holds none of it.
            return Err(Error::file(
                dir,
                "holds neither six faces (px.EXT nx.EXT ... or posx.EXT negx.EXT ...) nor a prefiltered chain (m0/ m1/ ... and levels.json)",
            ));
        }
        let (base, meta) = read_faces(dir, opts)?;
        (base, meta, 1, None)
    };
    let n = base[0].width;
    Ok(Report {
        file: dir.display().to_string(),
        file_format: meta.file_format,
        kind: Some(Kind::Faces),
        kind_note: None,
        width: n,
        height: n,
        face_size: Some(n),
        mip_levels,
        pixel_format: meta.pixel_format,
        color_space: meta.color_space,
        stats: stats(base.iter()),
        flux: Some(cube_flux(&base)),
        levels,
    })
}

/// Whether a folder holds any file named as a face (px.EXT, posx.EXT, ...).
fn holds_a_face(dir: &Path) -> bool {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return true; // find_faces says why it cannot be read
    };
    entries.filter_map(|e| e.ok()).any(|e| {
        let name = e.file_name().to_string_lossy().to_ascii_lowercase();
        let stem = name.split('.').next().unwrap_or_default().to_owned();
        FACE_NAMES.contains(&stem.as_str()) || FACE_LONG_NAMES.contains(&stem.as_str())
    })
}

/// A chain folder's `levels.json`, if there is one; it must be JSON and list as many levels
/// as the folder holds.
fn chain_levels(dir: &Path, count: usize) -> Result<Option<serde_json::Value>> {
    let path: PathBuf = dir.join("levels.json");
    if !path.exists() {
        return Ok(None);
    }
    let bytes = io::read_file(&path)?;
    let json: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| Error::file(&path, format!("not valid JSON: {e}")))?;
    if let Some(list) = json.get("levels").and_then(|l| l.as_array()) {
        if list.len() != count {
            return Err(Error::file(
                &path,
                format!(
                    "lists {} levels but the folder holds {count} (m0 to m{})",
                    list.len(),
                    count - 1
                ),
            ));
        }
    }
    Ok(Some(json))
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The name on one line, whatever it holds.
        writeln!(f, "{}", self.file.replace('\n', "\\n").replace('\r', "\\r"))?;
        writeln!(f, "  format:       {}", self.file_format.name())?;
        match (&self.kind, &self.kind_note) {
            (Some(Kind::Faces), _) if self.mip_levels > 1 => writeln!(
                f,
                "  layout:       faces, a prefiltered chain (folders m0 to m{})",
                self.mip_levels - 1
            )?,
            (Some(Kind::Faces), _) => writeln!(f, "  layout:       faces (a folder of six)")?,
            (Some(k), _) => writeln!(f, "  layout:       {}", k.name())?,
            (None, Some(n)) => writeln!(f, "  layout:       unknown: {n}")?,
            _ => {}
        }
        writeln!(f, "  dimensions:   {} x {}", self.width, self.height)?;
        match self.face_size {
            Some(n) => writeln!(f, "  face size:    {n}")?,
            None if self.kind.is_none() && self.width == self.height => writeln!(
                f,
                "  face size:    unknown: {} as a sphere or angular map, {} as a single face",
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
        if let Some([r, g, b]) = self.flux {
            write!(
                f,
                "\n  flux:         {r:.6} {g:.6} {b:.6} (mean radiance over the sphere)"
            )?;
        }
        if let Some(levels) = self
            .levels
            .as_ref()
            .and_then(|l| l.get("levels"))
            .and_then(|l| l.as_array())
        {
            for l in levels {
                let get = |k: &str| l.get(k).and_then(|v| v.as_f64());
                let what = if let Some(r) = get("roughness") {
                    format!("roughness {r:.3}")
                } else if let Some(p) = get("power") {
                    format!("power {p:.1}")
                } else if let Some(s) = get("sigma") {
                    format!("sigma {s:.5} rad")
                } else {
                    "box".to_string()
                };
                write!(
                    f,
                    "\n  level {:>2}:     {:>5} px, {} {what}",
                    get("level").unwrap_or(0.0),
                    get("size").unwrap_or(0.0),
                    l.get("filter").and_then(|v| v.as_str()).unwrap_or("")
                )?;
            }
        }
        Ok(())
    }
}
