//! Conversion between layouts: load any input as a direction-addressed environment, then
//! render the requested layout from it.

#![warn(missing_docs)]

use crate::cube::{CubeMap, CubeSampler, EdgeFixup, Environment};
use crate::error::{Error, Result};
use crate::flux::{Grid, Peaks};
use crate::image::Image;
use crate::io::{self, Decoded, FileFormat, Meta, ReadOptions};
use crate::layout::{self, cross, ImageEnv, Kind};
use crate::resample::Resampler;
use glam::Vec4;
use std::path::{Path, PathBuf};

mod envmap;
mod faces;
mod map_kind;
mod read;
pub mod stream;
pub(crate) use faces::find_faces;
pub(crate) use faces::skybox_note;
use faces::{load_faces, naming_of};
pub use map_kind::MapKind;
pub use read::{read, read_raw};
pub use stream::Reduced;

/// A loaded input: a cube map (faces, cross, strip, container) or a single-image projection.
pub enum Source {
    /// Six faces with their mip levels.
    Cube(CubeMap),
    /// A panorama, mirror ball, angular or octahedral map, looked up by direction.
    Projection(layout::Projection, Image),
    /// A panorama reduced as it was decoded, its peaks at full resolution ([`stream`]).
    Reduced(Box<Reduced>),
}

/// An input with what was learned while reading it.
pub struct Loaded {
    /// The pixels, as a cube map or a projection.
    pub source: Source,
    /// What the input was: a layout (`Faces` for face folders and six files) or the
    /// container read.
    pub kind: MapKind,
    /// Holds values above 1: float outputs are the natural default.
    pub hdr: bool,
    /// The first file's format, pixel format and colour space, and what was replaced on reading.
    pub meta: Meta,
    /// Every file read, so outputs can be checked against them.
    pub files: Vec<PathBuf>,
}

impl Loaded {
    /// A cube map made in memory (a filter's result, say) as an input to convert from.
    pub fn from_cube(cube: CubeMap) -> Loaded {
        Loaded {
            source: Source::Cube(cube),
            kind: Kind::Faces.into(),
            hdr: true,
            meta: Meta {
                file_format: FileFormat::Exr,
                pixel_format: "RGBA32F".into(),
                color_space: crate::image::ColorSpace::Linear,
                hdr: true,
                replaced_values: 0,
                stored_levels: 1,
                declared: None,
                undo: Default::default(),
                part: None,
            },
            files: Vec::new(),
        }
    }

    /// Scales the input's radiance by 2^`exposure` (every level, alpha unchanged): what
    /// `--exposure` does before a chain, an irradiance map or an engine's files are computed.
    pub fn expose(&mut self, exposure: f32) {
        if exposure == 0.0 {
            return;
        }
        match &mut self.source {
            Source::Cube(c) => c
                .levels
                .iter_mut()
                .flatten()
                .for_each(|f| crate::tonemap::scale(f, exposure)),
            Source::Projection(_, img) => crate::tonemap::scale(img, exposure),
            Source::Reduced(r) => {
                crate::tonemap::scale(&mut r.image, exposure);
                if let Some(p) = &mut r.peaks {
                    p.expose(exposure);
                }
            }
        }
    }

    /// Keeps only level `n` of a cube map's mip chain (a prefiltered chain's blurrier level,
    /// say) as the input.
    pub fn keep_level(&mut self, n: usize) -> Result<()> {
        let count = match &self.source {
            Source::Cube(c) => c.levels.len(),
            Source::Projection(..) | Source::Reduced(_) => 1,
        };
        if n >= count {
            return Err(Error::file(
                &self.files[0],
                format!(
                    "no level {n}: it holds {count} level{}",
                    if count == 1 { "" } else { "s" }
                ),
            ));
        }
        if let Source::Cube(c) = &mut self.source {
            let level = c.levels.swap_remove(n);
            c.levels = vec![level];
        }
        Ok(())
    }

    /// The decoded input's bytes while a command works from it: [`InputPlan::working_bytes`]
    /// for what was read (standard input's size is known only now).
    pub fn working_bytes(&self) -> u64 {
        let held: u64 = self
            .images()
            .iter()
            .map(|i| i.pixels.len() as u64 * 16)
            .sum();
        held.saturating_add(held / 2)
    }

    /// The face edge that keeps the input's resolution.
    pub fn face_size(&self) -> usize {
        match &self.source {
            Source::Cube(c) => c.size(),
            Source::Projection(_, img) => self.kind.layout().face_size(img.width, img.height),
            Source::Reduced(r) => Kind::Equirect.face_size(r.full.0, r.full.1),
        }
    }

    /// Prepares the input for lookups by direction, with the pyramid levels an output whose
    /// texels span at most `max_footprint` radians needs for antialiasing (None: all levels),
    /// and finds its peaks: lookups see the input below their ceiling, and a resampler splats
    /// the peaks on top of what it renders (`Resampler::to_cube_with_peaks`).
    pub fn environment(
        &self,
        max_footprint: Option<f32>,
    ) -> (Box<dyn Environment + '_>, Option<Peaks>) {
        // Down to the deepest level the resampler picks for that footprint.
        let levels =
            |texel_angle: f32| max_footprint.map(|f| crate::resample::levels_for(f / texel_angle));
        match &self.source {
            Source::Projection(p, img) => {
                let angle = ImageEnv::new(*p, img, Some(1)).texel_angle();
                if *p == layout::Projection::Equirect {
                    let (env, peaks) = split_panorama(img, levels(angle));
                    return (Box::new(env), peaks);
                }
                let peaks = self.peaks();
                let env = ImageEnv::below(*p, img, levels(angle), ceiling(&peaks));
                (Box::new(env), peaks)
            }
            Source::Reduced(r) => {
                let equirect = layout::Projection::Equirect;
                let angle = ImageEnv::new(equirect, &r.image, Some(1)).texel_angle();
                let env = ImageEnv::below(equirect, &r.image, levels(angle), ceiling(&r.peaks));
                (Box::new(env), r.peaks.clone())
            }
            Source::Cube(c) => {
                let peaks = self.peaks();
                // Box mips of level 0 (stored levels may be prefiltered, not plain mips).
                let angle = crate::cube::texel_angle(c.size());
                let env =
                    CubeSampler::with_box_mips_below(&c.levels[0], levels(angle), ceiling(&peaks));
                (Box::new(env), peaks)
            }
        }
    }

    /// The texel grid of the input (level 0 of a cube).
    pub fn grid(&self) -> Grid {
        match &self.source {
            Source::Cube(c) => Grid::Cube(c.size()),
            Source::Projection(p, img) => Grid::Projection(*p, img.width, img.height),
            Source::Reduced(r) => {
                Grid::Projection(layout::Projection::Equirect, r.image.width, r.image.height)
            }
        }
    }

    /// The input's images on its grid: six faces, or the one image.
    pub fn images(&self) -> Vec<&Image> {
        match &self.source {
            Source::Cube(c) => c.levels[0].iter().collect(),
            Source::Projection(_, img) => vec![img],
            Source::Reduced(r) => vec![&r.image],
        }
    }

    /// The input's texels above `flux::PEAK_RATIO` times its mean luminance, if any.
    pub fn peaks(&self) -> Option<Peaks> {
        match &self.source {
            Source::Reduced(r) => r.peaks.clone(),
            _ => Peaks::find(self.grid(), &self.images()),
        }
    }

    /// The input's flux: solid-angle-weighted mean radiance per channel.
    pub fn mean_radiance(&self) -> [f64; 3] {
        let mut mean = crate::flux::mean_radiance(self.grid(), &self.images());
        // A reduced panorama holds the part below the ceiling; its peaks hold the rest.
        if let Source::Reduced(r) = &self.source {
            let Some(p) = &r.peaks else { return mean };
            let flux = p.flux();
            for (m, f) in mean.iter_mut().zip(flux) {
                *m += f / (4.0 * std::f64::consts::PI);
            }
        }
        mean
    }
}

/// Each colour channel clamped to the peaks' ceiling (none without peaks): what lookups see.
fn ceiling(peaks: &Option<Peaks>) -> Vec4 {
    peaks.as_ref().map_or(Vec4::INFINITY, Peaks::ceiling_vec)
}

/// `ImageEnv::below` for a panorama whose peaks are not known yet: finds them in the same pass
/// that makes level 1 (when `levels` asks for it), and returns them with the environment.
fn split_panorama(base: &Image, levels: Option<usize>) -> (ImageEnv<'_>, Option<Peaks>) {
    let equirect = layout::Projection::Equirect;
    let grid = Grid::Projection(equirect, base.width, base.height);
    if levels.is_some_and(|l| l < 2) || base.height <= 8 {
        let peaks = Peaks::find(grid, &[base]);
        let env = ImageEnv::below(equirect, base, levels, ceiling(&peaks));
        return (env, peaks);
    }
    let weights = layout::equirect::row_weights(base.width, base.height);
    let (peaks, first) = Peaks::find_reducing(grid, base, &weights);
    let env = ImageEnv::panorama_from_level_one(base, first, levels, ceiling(&peaks));
    (env, peaks)
}

/// What loading an input will take, from its files' headers alone ([`io::claim`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct InputPlan {
    /// The face edge that keeps the input's resolution, where the headers tell it.
    pub face_size: Option<usize>,
    /// Bytes the decoded input keeps (RGBA f32 texels, every level of a chain or container).
    pub held_bytes: u64,
    /// Bytes in use at the peak of decoding it: the files decode one after another, each
    /// with its file's bytes and a decoder's buffer while the ones before it are kept.
    pub peak_bytes: u64,
}

impl InputPlan {
    /// The input's bytes while a command works from it: its texels and the lookup pyramid
    /// built over them (box means: at most half as many again), or the decode's peak.
    pub fn working_bytes(&self) -> u64 {
        self.peak_bytes
            .max(self.held_bytes.saturating_add(self.held_bytes / 2))
    }
}

/// Plans loading `inputs` as [`load`] would read them (one image, six faces, a folder of
/// faces), checking the decode's peak against the memory budget before any file is decoded:
/// six faces each within the budget are refused when together they are not. A chain
/// folder's every level: [`crate::chain::plan`]. Jobs plan through [`crate::input::Input`].
pub(crate) fn plan_input(
    inputs: &[PathBuf],
    from: Option<Kind>,
    opts: &ReadOptions,
) -> Result<InputPlan> {
    let files: Vec<PathBuf> = match inputs {
        [dir] if dir.is_dir() => find_faces(dir)?.0,
        files => files.to_vec(),
    };
    plan_files(&files, from, opts)
}

/// [`plan_input`] for the files themselves, decoded one after another.
pub(crate) fn plan_files(
    files: &[PathBuf],
    from: Option<Kind>,
    opts: &ReadOptions,
) -> Result<InputPlan> {
    let mut plan = InputPlan::default();
    let mut first = None;
    for f in files {
        let Some(c) = io::claim(f, opts)? else {
            continue; // standard input: checked by its reader as it arrives
        };
        first.get_or_insert(c);
        plan.peak_bytes = plan
            .peak_bytes
            .max(plan.held_bytes.saturating_add(c.decode_bytes));
        plan.held_bytes = plan.held_bytes.saturating_add(c.held_bytes);
    }
    // Looking a cube up by direction (its flux, its peaks) takes a face's solid-angle table.
    if let Some(c) = first.filter(|c| c.cube || files.len() > 1) {
        let table = c.width.saturating_mul(c.width).saturating_mul(4);
        plan.peak_bytes = plan.peak_bytes.max(plan.held_bytes.saturating_add(table));
    }
    plan.face_size = first.and_then(|c| {
        let (w, h) = (c.width as usize, c.height as usize);
        if c.cube || files.len() > 1 {
            return Some(w);
        }
        let kind = from.or_else(|| layout::detect(w, h).ok())?;
        kind.fits(w, h).then(|| kind.face_size(w, h))
    });
    let what = match files {
        [one] => one.display().to_string(),
        [first, ..] => format!(
            "{} input files ({} and the others)",
            files.len(),
            first.display()
        ),
        [] => return Err(Error::usage("no input given")),
    };
    opts.limits
        .check_memory(format_args!("decoding {what}"), plan.peak_bytes)?;
    Ok(plan)
}

/// Loads one image file (any layout), a folder of six faces, or six face files, once the
/// whole input's decode is planned within the memory budget ([`plan_input`]).
pub fn load(inputs: &[PathBuf], from: Option<Kind>, opts: &ReadOptions) -> Result<Loaded> {
    if inputs.len() == 1 || inputs.len() == 6 {
        plan_input(inputs, from, opts)?;
    }
    load_planned(inputs, from, opts)
}

/// [`load`] once the caller has planned it ([`plan_input`], [`crate::chain::plan`]): the
/// headers are not read and checked a second time.
pub(crate) fn load_planned(
    inputs: &[PathBuf],
    from: Option<Kind>,
    opts: &ReadOptions,
) -> Result<Loaded> {
    match inputs {
        [] => Err(Error::usage("no input given")),
        [dir] if dir.is_dir() => {
            let (files, naming) = find_faces(dir)?;
            load_faces(&files, naming, opts)
        }
        [file] => load_single(file, from, opts),
        files if files.len() == 6 => load_faces(files, naming_of(files), opts),
        files => Err(Error::usage(format!(
            "give one image, a folder of faces, or six face images in px nx py ny pz nz order ({} given)",
            files.len()
        ))),
    }
}

fn load_single(path: &Path, from: Option<Kind>, opts: &ReadOptions) -> Result<Loaded> {
    let (decoded, meta) = read(path, opts)?;
    let files = vec![path.to_path_buf()];
    let hdr = meta.hdr;
    let (source, kind) = match decoded {
        Decoded::Cube(cube) => {
            // Only containers decode to cube maps.
            let kind = meta
                .file_format
                .container()
                .map_or(Kind::Faces.into(), MapKind::from);
            (Source::Cube(cube), kind)
        }
        Decoded::Image(img) => {
            let (w, h) = (img.width, img.height);
            let cannot_hold = |k: Kind| {
                Error::file(
                    path,
                    format!(
                        "a {w}x{h} image cannot hold {} layout",
                        crate::error::with_article(k.name())
                    ),
                )
            };
            let kind = match from {
                Some(Kind::Faces) => {
                    return Err(Error::file(
                        path,
                        format!(
                            "{} faces does not describe a single image",
                            crate::error::param("from")
                        ),
                    ))
                }
                Some(k) if !k.fits(w, h) => return Err(cannot_hold(k)),
                Some(k) => k,
                None => layout::detect(w, h).map_err(|e| Error::file(path, e))?,
            };
            // `fits` holds for projections and cells only.
            let source = match (kind.projection(), kind.cells()) {
                (Some(p), _) => Source::Projection(p, img),
                (None, Some(cells)) => Source::Cube(
                    CubeMap::from_faces(cross::extract(cells, &img))
                        .map_err(|e| Error::file(path, e.to_string()))?,
                ),
                (None, None) => return Err(cannot_hold(kind)),
            };
            (source, kind.into())
        }
    };
    Ok(Loaded {
        source,
        kind,
        hdr,
        meta,
        files,
    })
}

/// What a conversion produces: one image, or a cube map (faces and containers).
pub enum Output {
    /// Cross, strip or projection: one image.
    Image(Image),
    /// Faces or a container: six faces with their mip levels.
    Cube(CubeMap),
}

/// Renders layout `to` at face edge `size`: a cube map for faces, an image for the others. A
/// container holds faces ([`MapKind::layout`]).
pub fn convert(loaded: &Loaded, to: Kind, size: usize, resampler: &Resampler) -> Output {
    convert_fixed(loaded, to, size, resampler, EdgeFixup::None)
}

/// [`convert`] with the faces of a cross or strip moved by an edge fixup (cube outputs get
/// theirs as they are encoded, every level: [`crate::output::Target::encode`]).
pub fn convert_fixed(
    loaded: &Loaded,
    to: Kind,
    size: usize,
    resampler: &Resampler,
    fixup: EdgeFixup,
) -> Output {
    match (to, to.cells()) {
        (Kind::Faces, _) => Output::Cube(to_cube(loaded, size, resampler)),
        (_, Some(cells)) if fixup != EdgeFixup::None => {
            let faces =
                crate::cube::fixup::apply(&to_cube(loaded, size, resampler).levels[0], fixup);
            Output::Image(cross::assemble(cells, &faces))
        }
        _ => Output::Image(to_image(loaded, to, size, resampler)),
    }
}

/// The input as a cube map of face edge `size`. A cube input of that size and orientation is
/// copied texel for texel, never resampled.
pub fn to_cube(loaded: &Loaded, size: usize, resampler: &Resampler) -> CubeMap {
    match &loaded.source {
        Source::Cube(c) if resampler.orientation.is_identity() && c.size() == size => CubeMap {
            levels: vec![c.levels[0].clone()],
        },
        _ => {
            let (env, peaks) = loaded.environment(Some(2.0 / size as f32));
            resampler.to_cube_with_peaks(env.as_ref(), peaks.as_ref(), size)
        }
    }
}

/// The input as one image in layout `to` (a projection, cross or strip) for face edge
/// `size`; `to` naming faces gives a horizontal cross.
pub fn to_image(loaded: &Loaded, to: Kind, size: usize, resampler: &Resampler) -> Image {
    match to.projection() {
        Some(p) => {
            let (w, h) = to.image_size(size);
            // The widest output texel's angle, where it is bounded.
            let footprint = match p {
                layout::Projection::Equirect => Some(std::f32::consts::PI / h as f32),
                layout::Projection::Octahedral => Some(6.0 / w as f32),
                _ => None,
            };
            let (env, peaks) = loaded.environment(footprint);
            resampler.to_projection_with_peaks(env.as_ref(), peaks.as_ref(), p, w, h)
        }
        None => {
            let cells = to.cells().unwrap_or(cross::Cells::Hcross);
            cross::assemble(cells, &to_cube(loaded, size, resampler).levels[0])
        }
    }
}
