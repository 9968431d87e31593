//! Where a result goes: the output's layout and file type from its name and options, the
//! files it becomes (six faces, a container with its mips, one image), and a write that lands
//! whole or not at all. The writing half of [`crate::io`]'s reading.

#![warn(missing_docs)]

use crate::convert::MapKind;
use crate::convert::Output;
use crate::cube::{fixup, CubeMap, Faces, FACE_NAMES};
use crate::error::{param, Error, Result};
use crate::image::Image;
use crate::io::{self, Container, FileFormat, WriteOptions};
use crate::layout::Kind;
use crate::tonemap::Tonemap;
use std::path::{Path, PathBuf};

mod deliver;
pub mod depfile;
mod encode;
mod encoding;
pub use deliver::{
    deliver, is_closed_pipe, stdout_open, write_stdout, write_summary, Destination, Files,
};
pub use encode::{encode_cube, encode_cube_with, encode_image, ultrahdr_encode};
pub(crate) use encode::{encode_cube_as, encode_image_as, encode_image_with};
pub use encoding::Encoding;

/// An output as [`Encoding::resolve`] decided it: where, in which layout and format, with
/// which options, and what did not apply.
#[derive(Clone, Debug)]
pub struct Target {
    /// Where the result goes (a folder for faces).
    pub path: PathBuf,
    /// The layout or container written.
    pub kind: MapKind,
    /// The file type written (of each face for faces; None: faces whose type follows the
    /// input, not known yet).
    pub format: Option<FileFormat>,
    /// Pixel format, colour space and compression of the written files.
    pub write: WriteOptions,
    /// JPEG outputs as UltraHDR: a gain map over an SDR picture made by this curve (`None`:
    /// plain JPEG), radiance kept, not clipped. Here, not in `WriteOptions`: the curve is
    /// pixel work done above the codecs.
    pub gain_map: Option<Tonemap>,
    /// Mip levels of a KTX2 or DDS container (None: the full chain down to 1x1).
    pub levels: Option<usize>,
    /// Exposure (stops) and tone curve: both for 8-bit outputs; float outputs stay linear,
    /// scaled by the exposure alone.
    pub tone: Option<(f32, Tonemap)>,
    /// The options that do not apply to this output, each ignored with a warning.
    pub warnings: Vec<crate::error::Text>,
}

/// A result as the bytes of its files, with what the encoders had to clamp.
pub struct Encoded {
    /// Each file's final path and its bytes, written in this order.
    pub files: Vec<(PathBuf, Vec<u8>)>,
    /// Texels beyond the format's largest value, written as that value (None: none).
    pub clamped: Option<String>,
    /// A lossy container format's (BC6H, BC7) quality: level 0 as read back against the map
    /// before encoding, in dB ([`io::gpu::psnr`]).
    pub psnr: Option<f64>,
    /// Folders that are outputs in their own right (six faces, a chain), replaced whole.
    pub folders: Vec<PathBuf>,
    /// What an UltraHDR output's gain map kept.
    pub gain_map: Option<io::ultrahdr::GainStats>,
}

impl Encoded {
    /// The files to hand to [`deliver`].
    pub fn into_files(self) -> Files {
        Files {
            files: self.files,
            folders: self.folders,
            known: Vec::new(),
        }
    }
}

impl Target {
    /// The file type the result is encoded in (None: faces whose type is not known yet).
    pub fn format(&self) -> Option<FileFormat> {
        self.format
    }

    /// Lines printed with the output: how a reader decodes an RGBM or RGBD file (engines
    /// disagree on RGBM's range), and what a KTX2 without cubeforge's keys leaves unsaid.
    pub fn notes(&self) -> Vec<String> {
        let name = self
            .path
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        let Some(format) = self.format else {
            return Vec::new();
        };
        let mut notes = Vec::new();
        if let Some(e) = self.write.hdr_encoding {
            notes.push(e.loader_line(format, &name));
        }
        if format != FileFormat::Ktx2 || self.write.cubeforge_keys {
            return notes;
        }
        let keys = param("cubeforge_keys");
        if let Some(e) = self.write.hdr_encoding {
            notes.push(format!(
                "{name} does not name its encoding (KTX2 has no key for it; {keys} adds \
                 cubeforge's): read it back with {} {}",
                param("decode"),
                e.name()
            ));
        }
        if self.write.edge_fixup != crate::cube::EdgeFixup::None {
            notes.push(format!(
                "{name} does not record its edge fixup ({keys} adds cubeforge's key): \
                 readers, cubeforge too, take its texels as stored"
            ));
        }
        notes
    }

    /// Whether the result is stored in 8 bits a channel, where a tone curve applies.
    pub fn is_8bit(&self) -> bool {
        self.format()
            .is_some_and(|f| io::largest_value(f, self.write.gpu_format).is_none())
    }

    /// Applies the exposure and tone curve to `images` (level 0: the mips are made from it):
    /// an 8-bit output's curve, or a linear one's exposure alone. Returns the warning for
    /// what an 8-bit output clips.
    fn tone_images(&self, images: Vec<&mut Image>) -> Option<String> {
        let (exposure, curve) = self.tone.unwrap_or((0.0, Tonemap::None));
        // RGBM and RGBD hold radiance: no tone curve, no clipping at 1.
        let eight_bit = self.is_8bit() && self.write.hdr_encoding.is_none();
        let clipped = if eight_bit {
            let (n, top) = crate::tonemap::clipped(images.iter().map(|i| &**i), curve, exposure);
            (n > 0).then(|| clip_warning(&self.path, n, top, exposure, true))
        } else {
            None
        };
        match (self.tone, eight_bit) {
            (Some(_), true) => images
                .into_iter()
                .for_each(|img| crate::tonemap::apply(img, curve, exposure)),
            (Some(_), false) if exposure != 0.0 => images
                .into_iter()
                .for_each(|img| crate::tonemap::scale(img, exposure)),
            _ => {}
        }
        clipped
    }

    /// The files `out` becomes. Refuses to overwrite any of `inputs`, and a result whose
    /// shape the layout cannot hold (a cube map as an equirect, an image as faces).
    pub fn encode(&self, mut out: Output, inputs: &[PathBuf]) -> Result<Encoded> {
        let wrong = |what: &str| {
            Error::file(
                &self.path,
                format!("a {what} cannot be written as {}", self.kind.name()),
            )
        };
        match (&out, self.kind.is_cube()) {
            (Output::Cube(_), true) | (Output::Image(_), false) => {}
            (Output::Cube(_), false) => return Err(wrong("cube map")),
            (Output::Image(_), true) => return Err(wrong("single image")),
        }
        let images: Vec<&mut Image> = match &mut out {
            Output::Cube(c) => c.levels[0].iter_mut().collect(),
            Output::Image(img) => vec![img],
        };
        let clipped = self.tone_images(images);
        // Box mips are means of level 0: they fit where it fits.
        let clamped = self.format().and_then(|f| {
            let images: Vec<&Image> = match &out {
                Output::Cube(c) => c.levels[0].iter().collect(),
                Output::Image(img) => vec![img],
            };
            io::clamp_warning_with(&self.path, f, &self.write, images)
        });
        let clamped = clamped.or(clipped);
        let mut psnr = None;
        let mut gain_map = None;
        let faces = self.kind == MapKind::Layout(Kind::Faces);
        let folders = if faces {
            vec![self.path.clone()]
        } else {
            Vec::new()
        };
        let files = match out {
            Output::Cube(cube) if faces => {
                refuse_folder(&self.path, inputs)?;
                let cube = fixup::apply_cube(cube, self.write.edge_fixup);
                let format = self.format.ok_or_else(|| io::unknown_ext(&self.path))?;
                encode_faces(
                    &self.path,
                    &cube.levels[0],
                    format,
                    (&self.write, self.gain_map),
                    inputs,
                )?
            }
            Output::Cube(cube) => {
                refuse_inputs(std::slice::from_ref(&self.path), inputs)?;
                // Babylon needs the whole chain down to 1x1.
                let levels = if self.kind == MapKind::Container(Container::Env) {
                    None
                } else {
                    self.levels
                };
                // Each level moved on its own grid, after the mips are made from the unmoved one.
                let cube: CubeMap =
                    fixup::apply_cube(cube.with_box_mips(levels), self.write.edge_fixup);
                let format = self.format.ok_or_else(|| io::unknown_ext(&self.path))?;
                let bytes = encode_cube_as(format, &self.path, &cube, &self.write, &[])?;
                if self.write.gpu_format.is_lossy() {
                    let faces: Vec<&Image> = cube.levels[0].iter().collect();
                    psnr = io::container_psnr(&bytes, self.write.gpu_format, &faces);
                }
                vec![(self.path.clone(), bytes)]
            }
            Output::Image(img) if self.format() == Some(FileFormat::UltraHdr) => {
                refuse_inputs(std::slice::from_ref(&self.path), inputs)?;
                let curve = self.gain_map.unwrap_or_default();
                let equirect = self.kind == MapKind::Layout(Kind::Equirect);
                let (bytes, stats) =
                    ultrahdr_encode(&img, curve, io::ultrahdr::Reader::Format, equirect)
                        .map_err(|e| Error::file(&self.path, e))?;
                gain_map = Some(stats);
                vec![(self.path.clone(), bytes)]
            }
            Output::Image(img) => {
                refuse_inputs(std::slice::from_ref(&self.path), inputs)?;
                let format = self.format.ok_or_else(|| io::unknown_ext(&self.path))?;
                let bytes =
                    encode_image_with(format, &self.path, &img, &self.write, self.gain_map)?;
                vec![(self.path.clone(), bytes)]
            }
        };
        Ok(Encoded {
            files,
            clamped,
            psnr,
            folders,
            gain_map,
        })
    }
}

/// The layout or container an output gets: `to`, checked against the name, or what the name
/// implies.
pub(crate) fn kind_for(output: &Path, to: Option<MapKind>) -> Result<MapKind> {
    let by_name = FileFormat::from_extension(output);
    let named = by_name.and_then(FileFormat::container);
    match (to, by_name) {
        (Some(MapKind::Container(c)), _) if named == Some(c) => Ok(MapKind::Container(c)),
        (Some(MapKind::Container(c)), _) => Err(Error::file(
            output,
            format!(
                "{} {} needs an output named .{}",
                param("to"),
                c.name(),
                c.name()
            ),
        )),
        (Some(MapKind::Layout(Kind::Faces)), Some(_)) => Err(Error::file(
            output,
            format!(
                "{} faces writes a folder: give a folder name without an image extension",
                param("to")
            ),
        )),
        (Some(MapKind::Layout(Kind::Faces)), None) => Ok(Kind::Faces.into()),
        (Some(MapKind::Layout(k)), Some(f)) => match named {
            Some(_) => Err(Error::file(
                output,
                format!(
                    "{} holds cube maps and {} {} is a single image: name the output {}, or \
                     leave out {} for a cube map",
                    f.name(),
                    param("to"),
                    k.name(),
                    FileFormat::list(FileFormat::is_image, true),
                    param("to"),
                ),
            )),
            None => Ok(k.into()),
        },
        (Some(MapKind::Layout(k)), None) => Err(Error::file(
            output,
            format!(
                "a {} image needs a file name ending in {}",
                k.name(),
                FileFormat::list(FileFormat::is_image, true)
            ),
        )),
        (None, Some(_)) => Ok(named.map_or(Kind::Hcross.into(), MapKind::Container)),
        (None, None) if output.extension().is_some() && !output.is_dir() => {
            Err(io::unknown_ext(output))
        }
        (None, None) => Ok(Kind::Faces.into()),
    }
}

/// The file type of face images from its name (png, jpg, tga, hdr, exr).
pub fn face_format(name: &str) -> Result<FileFormat> {
    match FileFormat::from_ext_str(name) {
        Some(f) if !f.is_container() => Ok(f),
        _ => Err(Error::usage(format!(
            "{} {name}: face images are {}",
            param("format"),
            FileFormat::list(FileFormat::is_image, false)
        ))),
    }
}

/// Six face images `dir/px.EXT` ..., encoded in parallel. Refuses to overwrite `inputs`.
pub(crate) fn encode_faces(
    dir: &Path,
    faces: &Faces,
    format: FileFormat,
    (write, gain_map): (&WriteOptions, Option<Tonemap>),
    inputs: &[PathBuf],
) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    let ext = format.extension();
    let paths: Vec<PathBuf> = FACE_NAMES
        .iter()
        .map(|n| dir.join(format!("{n}.{ext}")))
        .collect();
    refuse_inputs(&paths, inputs)?;
    let encoded: Vec<Result<Vec<u8>>> = {
        use rayon::prelude::*;
        paths
            .par_iter()
            .zip(faces.par_iter())
            .map(|(p, f)| encode_image_with(format, p, f, write, gain_map))
            .collect()
    };
    paths
        .into_iter()
        .zip(encoded)
        .map(|(p, e)| e.map(|b| (p, b)))
        .collect()
}

/// Refuses, before the work, a folder output that holds an input or that cubeforge may not
/// replace whole ([`io::check_folder`]; `writing`: the paths the command writes into it).
pub fn check_folder_output(dir: &Path, inputs: &[PathBuf], writing: &[PathBuf]) -> Result<()> {
    refuse_folder(dir, inputs)?;
    io::check_folder(dir, writing)
}

/// The one output check, made before the work where a job can and again by [`deliver`] as
/// every file is written: each of `files` is a regular file or nothing yet (never a FIFO, a
/// device or a socket, links followed), no two of them are one file, none is an input, and
/// no folder output (`folders`, replaced whole) holds an input. Paths are compared as places
/// (normalised, folders resolved, device and inode: hard links and symlinked folders too).
pub(crate) fn check_outputs(
    files: &[PathBuf],
    folders: &[PathBuf],
    inputs: &[PathBuf],
) -> Result<()> {
    io::atomic::check_targets(files)?;
    if inputs.is_empty() {
        return Ok(());
    }
    let ins: Vec<io::atomic::Place> = inputs.iter().map(|i| io::atomic::Place::of(i)).collect();
    let mut by_place = io::atomic::Places::default();
    for place in &ins {
        by_place.insert(place, ());
    }
    if let Some(o) = files
        .iter()
        .find(|o| by_place.get(&io::atomic::Place::of(o)).is_some())
    {
        return Err(Error::file(o, "refusing to overwrite an input file"));
    }
    let mut dirs = io::atomic::Places::default();
    for d in folders {
        dirs.insert(&io::atomic::Place::of(d), d);
    }
    for (i, place) in inputs.iter().zip(&ins) {
        if let Some(dir) = dirs
            .get(place)
            .or_else(|| dirs.above(place).map(|(_, d)| d))
        {
            return Err(Error::file(
                dir,
                format!(
                    "holds the input {}: the output folder is replaced whole, so write to another folder",
                    i.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses a folder output (replaced whole) that holds an input ([`check_outputs`]).
pub fn refuse_folder(dir: &Path, inputs: &[PathBuf]) -> Result<()> {
    check_outputs(&[], std::slice::from_ref(&dir.to_path_buf()), inputs)
}

/// Refuses to write over any input file, or where no regular file can be ([`check_outputs`]).
pub fn refuse_inputs(outputs: &[PathBuf], inputs: &[PathBuf]) -> Result<()> {
    check_outputs(outputs, &[], inputs)
}

/// The warning for a tone curve given for an output that keeps linear radiance.
pub fn tone_ignored(output: &Path) -> String {
    format!(
        "{}: {} applies to 8-bit outputs; this one keeps linear radiance ({} scales it)",
        crate::error::shown(output),
        param("tonemap"),
        param("exposure")
    )
}

/// The warning for texels an 8-bit output clips to white, `top` the brightest value, with the
/// ways to keep them (a tone curve where the command has `--tonemap`).
pub fn clip_warning(output: &Path, texels: u64, top: f32, exposure: f32, tonemap: bool) -> String {
    let ev = exposure - top.log2().ceil().max(1.0);
    let curve = if tonemap {
        format!(", {} aces rolls highlights off", param("tonemap"))
    } else {
        String::new()
    };
    let top = if top >= 100.0 {
        format!("{top:.0}")
    } else {
        format!("{top:.2}")
    };
    format!(
        "{}: {texels} texels brighter than 1 clip to white in an 8-bit file (the brightest is \
         {top}): {} {ev} brings it to 1{curve}, or a float output (.exr, .hdr) keeps the \
         radiance",
        crate::error::shown(output),
        param("exposure"),
    )
}
