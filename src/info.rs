//! What a file holds: layout, sizes, levels, pixel format, colour space and value statistics.

use crate::error::Result;
use crate::flux;
use crate::image::{luminance, Image};
use crate::io::{self, Decoded, ReadOptions};
use crate::layout::{self, Kind};
use serde::Serialize;
use std::path::Path;

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
    for img in images {
        for p in &img.pixels {
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
        let grid = flux::Grid::Cube(faces[0].width);
        flux::mean_radiance(grid, &faces.iter().collect::<Vec<_>>())
    })
}

/// Reads a file as stored (no value replacement) and describes it.
pub fn describe(path: &Path, opts: &ReadOptions) -> Result<Report> {
    let (decoded, meta) = io::read_raw(path, opts)?;
    let file = path.display().to_string();
    Ok(match decoded {
        Decoded::Cube(cube) => {
            let n = cube.size();
            Report {
                file,
                file_format: meta.file_format,
                kind: Some(if meta.file_format == io::FileFormat::Dds {
                    Kind::Dds
                } else {
                    Kind::Ktx2
                }),
                kind_note: None,
                width: n,
                height: n,
                face_size: Some(n),
                mip_levels: cube.levels.len(),
                pixel_format: meta.pixel_format,
                color_space: meta.color_space,
                stats: stats(cube.levels[0].iter()),
                flux: Some(flux::mean_radiance(
                    flux::Grid::Cube(n),
                    &cube.levels[0].iter().collect::<Vec<_>>(),
                )),
                levels: levels_description(path, meta.file_format),
            }
        }
        Decoded::Image(img) => {
            let (w, h) = (img.width, img.height);
            let (kind, note) = match layout::detect(w, h) {
                Ok(k) => (Some(k), None),
                Err(e) => (None, Some(e)),
            };
            Report {
                file,
                file_format: meta.file_format,
                kind,
                kind_note: note,
                width: w,
                height: h,
                face_size: kind
                    .map(|k| k.face_size(w, h))
                    .or((w == h).then_some(w / 2)),
                mip_levels: 1,
                pixel_format: meta.pixel_format,
                color_space: meta.color_space,
                stats: stats([&img]),
                flux: kind.and_then(|k| image_flux(k, &img)),
                levels: None,
            }
        }
    })
}

impl std::fmt::Display for Report {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "{}", self.file)?;
        writeln!(f, "  format:       {}", self.file_format.name())?;
        match (&self.kind, &self.kind_note) {
            (Some(k), _) => writeln!(f, "  layout:       {}", k.name())?,
            (None, Some(n)) => writeln!(f, "  layout:       unknown: {n}")?,
            _ => {}
        }
        writeln!(f, "  dimensions:   {} x {}", self.width, self.height)?;
        if let Some(n) = self.face_size {
            writeln!(f, "  face size:    {n}")?;
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
