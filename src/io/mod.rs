//! Reading and writing files: codecs by content, size limits before allocation, and writes that
//! land whole (temporary file, then rename) or not at all.

#![warn(missing_docs)]

pub mod atomic;
pub mod babylon_env;
mod band_shape;
pub mod bands;
mod container;
pub mod dds;
pub mod exr;
pub mod gpu;
mod guard;
pub mod hdr8;
mod input;
pub mod ktx1;
pub mod ktx2;
mod limits;
pub mod raster;
pub mod rgbe;
mod session;
pub mod ultrahdr;

use crate::cube::CubeMap;
use crate::error::{Error, Result};
use crate::image::{ColorSpace, Image};
use std::path::Path;

pub(crate) use crate::alloc::human_bytes;
pub(crate) use atomic::stage_replacing;
pub use atomic::{check_folder, remove_temporaries, Staged};
pub use encode::{check_gpu_format, container_psnr, zstd_needs_ktx2, ExrFloat, WriteOptions};
pub use gpu::{finite, unorm8, GpuFormat, HALF_MAX};
pub use hdr8::HdrEncoding;
mod encode;
mod range;
pub use container::Container;
pub use input::claim;
use input::read_with;
pub(crate) use input::{read_file, regular_file};
pub use limits::{Claim, Limits};
pub use range::{clamp_warning, clamp_warning_with, count_out_of_range, largest_value};
pub use session::{Session, SessionGuard};

/// File formats, told apart by their content (TGA, which has no signature, by its name).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FileFormat {
    /// PNG, 8 or 16 bits.
    Png,
    /// JPEG, 8 bits, sRGB.
    Jpeg,
    /// Truevision TGA, 8 bits; known by its name only.
    Tga,
    /// Radiance HDR (RGBE).
    Hdr,
    /// OpenEXR, half or full float.
    Exr,
    /// KTX2 cube-map container.
    Ktx2,
    /// DDS cube-map container.
    Dds,
    /// KTX 1 cube-map container (Filament's `cmgen` output).
    Ktx1,
    /// Babylon.js `.env` prefiltered environment (RGBD PNG faces).
    Env,
    /// UltraHDR: a JPEG with a gain map (known by its content; a `.jpg` name). Not in
    /// [`FileFormat::ALL`], whose extensions it would repeat.
    UltraHdr,
}

impl FileFormat {
    /// Every format, in the order messages list them.
    pub const ALL: [FileFormat; 9] = [
        FileFormat::Png,
        FileFormat::Jpeg,
        FileFormat::Tga,
        FileFormat::Hdr,
        FileFormat::Exr,
        FileFormat::Ktx2,
        FileFormat::Dds,
        FileFormat::Ktx1,
        FileFormat::Env,
    ];

    /// The image formats (one picture a file, not a cube-map container).
    pub fn is_image(self) -> bool {
        !self.is_container()
    }

    /// The extensions of the formats `keep` selects, for messages: `dot` puts a dot before
    /// each (".png .jpg or .exr"), else they are comma-separated ("png, jpg or exr").
    pub fn list(keep: impl Fn(FileFormat) -> bool, dot: bool) -> String {
        let names: Vec<String> = Self::ALL
            .iter()
            .filter(|&&f| keep(f))
            .map(|f| {
                if dot {
                    format!(".{}", f.extension())
                } else {
                    f.extension().to_owned()
                }
            })
            .collect();
        match names.split_last() {
            Some((last, [])) => last.clone(),
            Some((last, rest)) => {
                let sep = if dot { " " } else { ", " };
                format!("{} or {last}", rest.join(sep))
            }
            None => String::new(),
        }
    }

    /// The extension cubeforge writes for the format (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            FileFormat::Png => "png",
            FileFormat::Jpeg | FileFormat::UltraHdr => "jpg",
            FileFormat::Tga => "tga",
            FileFormat::Hdr => "hdr",
            FileFormat::Exr => "exr",
            FileFormat::Ktx2 => "ktx2",
            FileFormat::Dds => "dds",
            FileFormat::Ktx1 => "ktx",
            FileFormat::Env => "env",
        }
    }

    /// The format a file's name says (extension, any case); None for unknown ones.
    pub fn from_extension(path: &Path) -> Option<FileFormat> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Self::from_ext_str(&ext)
    }

    /// The format of an extension with or without its dot, any case (`hdr`, `rgbe` and `pic` are Radiance HDR).
    pub fn from_ext_str(ext: &str) -> Option<FileFormat> {
        Some(
            match ext.trim_start_matches('.').to_ascii_lowercase().as_str() {
                "png" => FileFormat::Png,
                "jpg" | "jpeg" => FileFormat::Jpeg,
                "tga" => FileFormat::Tga,
                "hdr" | "rgbe" | "pic" => FileFormat::Hdr,
                "exr" => FileFormat::Exr,
                "ktx2" => FileFormat::Ktx2,
                "dds" => FileFormat::Dds,
                "ktx" => FileFormat::Ktx1,
                "env" => FileFormat::Env,
                _ => return None,
            },
        )
    }

    pub(crate) fn from_magic(bytes: &[u8]) -> Option<FileFormat> {
        let starts = |m: &[u8]| bytes.starts_with(m);
        Some(if starts(b"\x89PNG\r\n\x1a\n") {
            FileFormat::Png
        } else if starts(&[0xFF, 0xD8, 0xFF]) {
            FileFormat::Jpeg
        } else if starts(&[0x76, 0x2F, 0x31, 0x01]) {
            FileFormat::Exr
        } else if starts(b"#?RADIANCE") || starts(b"#?RGBE") {
            FileFormat::Hdr
        } else if starts(&ktx2::IDENTIFIER) {
            FileFormat::Ktx2
        } else if starts(b"DDS ") {
            FileFormat::Dds
        } else if starts(&ktx1::IDENTIFIER) {
            FileFormat::Ktx1
        } else if starts(&babylon_env::MAGIC) {
            FileFormat::Env
        } else {
            return None;
        })
    }

    /// The format's name for messages ("OpenEXR").
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::Png => "PNG",
            FileFormat::Jpeg => "JPEG",
            FileFormat::Tga => "TGA",
            FileFormat::Hdr => "Radiance HDR",
            FileFormat::Exr => "OpenEXR",
            FileFormat::Ktx2 => "KTX2",
            FileFormat::Dds => "DDS",
            FileFormat::Ktx1 => "KTX",
            FileFormat::Env => "Babylon.js env",
            FileFormat::UltraHdr => "UltraHDR JPEG",
        }
    }

    /// KTX2, DDS, KTX and Babylon env: cube maps with mip levels, not single images.
    pub fn is_container(self) -> bool {
        self.container().is_some()
    }

    /// The container a format is (None for image formats): the layouts know no file
    /// formats, the formats know their containers.
    pub fn container(self) -> Option<Container> {
        match self {
            FileFormat::Ktx2 => Some(Container::Ktx2),
            FileFormat::Dds => Some(Container::Dds),
            FileFormat::Ktx1 => Some(Container::Ktx),
            FileFormat::Env => Some(Container::Env),
            _ => None,
        }
    }

    /// Formats that hold values above 1 (written linear, unclamped).
    pub fn is_float(self) -> bool {
        matches!(
            self,
            FileFormat::Hdr
                | FileFormat::Exr
                | FileFormat::Ktx2
                | FileFormat::Dds
                | FileFormat::Ktx1
                | FileFormat::Env
                | FileFormat::UltraHdr
        )
    }
}

/// What a reader found besides the pixels.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Meta {
    /// The format read, by content.
    pub file_format: FileFormat,
    /// Stored pixel format, e.g. "RGB8", "RGBA16F".
    pub pixel_format: String,
    /// How stored values were mapped to linear light.
    pub color_space: ColorSpace,
    /// Holds values above 1 (float formats).
    pub hdr: bool,
    /// NaN, infinite or negative values replaced by 0 on read (values above 1e28 by 1e28).
    pub replaced_values: usize,
    /// Mip levels the file holds (1 for plain images): a 2D KTX2 or DDS is read at level 0
    /// only, and this says how many it has.
    pub stored_levels: usize,
    /// The layout the file declares and how it was read (OpenEXR's `envmap` attribute), for
    /// `info`; None where the layout comes from the shape.
    pub declared: Option<String>,
    /// Which part of a multi-part file was read, for `info` and a warning (None: the file has
    /// one).
    pub part: Option<String>,
    /// What the texels hold beyond what the codec decodes (RGBM/RGBD, an edge fixup): `io`
    /// names it and returns the texels as stored; `convert::read` undoes it.
    #[serde(skip)]
    pub undo: Undo,
}

/// What a file says of its texels that a reader above `io` undoes (`convert::read`): `io`
/// decodes codecs and filters no pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Undo {
    /// 8-bit texels as RGBM or RGBD, decoded as stored (linear bytes), and whether `--decode`
    /// named it (true) rather than the file's own metadata.
    pub hdr_encoding: Option<(HdrEncoding, bool)>,
    /// A KTX2 cube map written with an edge fixup (`cubeforge.edgeFixup`).
    pub edge_fixup: Option<crate::cube::EdgeFixup>,
    /// An OpenEXR image whose `envmap` attribute declares OpenEXR's own layout.
    pub envmap: Option<Envmap>,
}

/// OpenEXR's own environment-map layouts (`ImfEnvmap`), which an `envmap` attribute declares.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Envmap {
    /// `LatLongMap`: a panorama, +X a quarter turn left of the centre.
    LatLong,
    /// `CubeMap`: six faces +X -X +Y -Y +Z -Z stacked top to bottom.
    Cube,
}

impl Meta {
    /// What a GPU container (`file_format`) holding `stored_levels` levels of `format` texels
    /// says of itself.
    pub(crate) fn for_gpu(
        file_format: FileFormat,
        format: GpuFormat,
        stored_levels: usize,
    ) -> Meta {
        Meta {
            file_format,
            pixel_format: format.name().into(),
            color_space: if format.is_srgb() {
                ColorSpace::Srgb
            } else {
                ColorSpace::Linear
            },
            hdr: format.is_float(),
            replaced_values: 0,
            stored_levels,
            declared: None,
            part: None,
            undo: Undo::default(),
        }
    }
}

/// A decoded file: one image, or a cube map with its levels (from KTX2 or DDS).
#[derive(Clone, Debug)]
pub enum Decoded {
    /// A single image (any raster format, HDR, EXR).
    Image(Image),
    /// Six faces with their mip levels.
    Cube(CubeMap),
}

/// How to read.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReadOptions {
    /// Sizes refused before any pixel memory is allocated.
    pub limits: Limits,
    /// Treat 8- and 16-bit values as data: no sRGB decode.
    pub linear: bool,
    /// Keep values as stored (NaN, infinities, negatives): for inspecting a file, not for
    /// computing with it.
    pub as_stored: bool,
    /// Which part of a multi-part OpenEXR file to read (None: the first, and `Meta::part`
    /// says so).
    pub exr_part: Option<usize>,
    /// Which stored level of a mip-mapped OpenEXR file to read (0: the full size).
    pub exr_level: usize,
    /// An 8-bit file's RGBM or RGBD, decoded to radiance (None: plain, or what a KTX2 says).
    pub hdr_encoding: Option<HdrEncoding>,
}

impl ReadOptions {
    /// Whether this reads a file's usual image (no EXR part or level chosen): the reads a
    /// session keeps.
    fn usual(&self) -> bool {
        self.exr_part.is_none() && self.exr_level == 0 && self.hdr_encoding.is_none()
    }
}

/// Whether `path` is an OpenEXR file, by its magic number (false where it cannot be read).
pub fn is_exr(path: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 4];
    std::fs::File::open(path).is_ok_and(|mut f| f.read_exact(&mut magic).is_ok())
        && magic == [0x76, 0x2f, 0x31, 0x01]
}

/// Which part of the OpenEXR file `path` `choice` names: an index ("2"), or a part's name
/// ("diffuse", its `name` attribute). How `--part N|NAME` becomes
/// [`ReadOptions::exr_part`].
pub fn exr_part(path: &Path, choice: &str) -> Result<usize> {
    if let Ok(k) = choice.parse::<usize>() {
        return Ok(k);
    }
    if !is_exr(path) {
        return Err(Error::file(
            path,
            format!(
                "{} {choice:?}: only an OpenEXR file has named parts",
                crate::error::param("part")
            ),
        ));
    }
    exr::part_index(&read_file(path)?, path, choice)
}

/// Decodes any supported file and replaces NaN, infinite and negative values by 0, counting
/// them in `Meta::replaced_values`; the texels as stored otherwise (what `Meta::undo` names
/// is undone by `convert::read`, the reader every caller uses).
pub fn decode_file(path: &Path, opts: &ReadOptions) -> Result<(Decoded, Meta)> {
    let session = opts.limits.session;
    if !opts.usual() {
        return read_sanitized(path, opts);
    }
    if let Some(kept) = session.cached(path, opts.linear, opts.as_stored) {
        session.note(path);
        return Ok((*kept).clone());
    }
    let read = read_sanitized(path, opts)?;
    if path != Path::new("-") && session.shares() {
        let kept = std::sync::Arc::new(read);
        session.keep(path, opts.linear, opts.as_stored, kept.clone());
        return Ok((*kept).clone());
    }
    Ok(read)
}

fn read_sanitized(path: &Path, opts: &ReadOptions) -> Result<(Decoded, Meta)> {
    let (decoded, mut meta) = read_with(path, opts, !opts.as_stored)?;
    if opts.as_stored {
        return Ok((decoded, meta));
    }
    // Integer and shared-exponent encodings hold only finite values >= 0: no pass needed
    // (it cost a quarter of a 4K panorama's decode). OpenEXR sanitizes as it decodes.
    if matches!(
        meta.file_format,
        FileFormat::Png
            | FileFormat::Jpeg
            | FileFormat::Tga
            | FileFormat::Hdr
            | FileFormat::Exr
            | FileFormat::UltraHdr
    ) {
        return Ok((decoded, meta));
    }
    let mut replaced = 0;
    let decoded = match decoded {
        Decoded::Image(mut img) => {
            replaced += img.sanitize();
            Decoded::Image(img)
        }
        Decoded::Cube(mut cube) => {
            for level in &mut cube.levels {
                for f in level.iter_mut() {
                    replaced += f.sanitize();
                }
            }
            Decoded::Cube(cube)
        }
    };
    meta.replaced_values = replaced;
    Ok((decoded, meta))
}

/// Decodes any supported file as stored, by content, with the size limit checked from the
/// header before pixels are allocated.
pub fn decode_file_raw(path: &Path, opts: &ReadOptions) -> Result<(Decoded, Meta)> {
    read_with(path, opts, false)
}

/// The error for an output name whose extension no writer knows.
pub fn unknown_ext(path: &Path) -> Error {
    Error::unsupported(
        path,
        format!(
            "unknown output extension: use {}",
            FileFormat::list(|_| true, true)
        ),
    )
}

/// An I/O error as a short phrase (kept here for callers of `io::io_msg`).
pub use crate::error::io_msg;
