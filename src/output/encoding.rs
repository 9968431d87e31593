//! Every output option, declared once: a job holds one [`Encoding`], and [`Encoding::resolve`]
//! decides the output's format from its name and these options before anything is built,
//! says which options do not apply, runs the checks and sizes the encoder's own memory. A new
//! output option is a field here, an arm in `resolve` and a term in `plan_bytes`.

use super::{kind_for, Target};
use crate::convert::MapKind;
use crate::cube::EdgeFixup;
use crate::error::{param, Error, Result, Text};
use crate::io::{self, ExrFloat, FileFormat, GpuFormat, HdrEncoding, WriteOptions};
use crate::layout::Kind;
use crate::tonemap::Tonemap;
use std::path::Path;

/// How a result is stored: texel format, compression, sample type, 8-bit HDR encoding, edge
/// fixup, face file type and the tone of 8-bit outputs. The defaults write what the name
/// asks for, linear where the format allows.
///
/// ```
/// use cubeforge::{ConvertJob, Destination, Encoding, GpuFormat};
///
/// let job = ConvertJob {
///     encoding: Encoding { gpu_format: Some(GpuFormat::Bc6h), zstd: Some(19), ..Encoding::default() },
///     ..ConvertJob::new(vec!["sky.exr".into()], Destination::Path("sky.ktx2".into()))
/// };
/// assert_eq!(job.encoding.zstd, Some(19));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Encoding {
    /// Texel format of KTX2, DDS and KTX outputs (None: rgba16f, or the job's own for data).
    pub gpu_format: Option<GpuFormat>,
    /// Zstandard level (1 to 22) of KTX2 supercompression (None: the levels plain).
    pub zstd: Option<i32>,
    /// Sample type of EXR outputs (half by default; f32 keeps radiance beyond 65504).
    pub exr_float: ExrFloat,
    /// 16 bits a channel for PNG.
    pub png16: bool,
    /// Texel centres moved for per-face (non-seamless) samplers: cube outputs, every level.
    pub edge_fixup: EdgeFixup,
    /// 8-bit outputs as RGBM or RGBD (PNG, or KTX2/DDS of rgba8): HDR kept in 8 bits.
    pub hdr_encoding: Option<HdrEncoding>,
    /// File type of face images (None: EXR for HDR results, PNG otherwise).
    pub face_format: Option<FileFormat>,
    /// A JPEG output as UltraHDR: an SDR picture (`tonemap`'s curve) and a gain map.
    pub ultrahdr: bool,
    /// Exposure in stops: radiance scaled by 2^EV (before the tone curve of 8-bit outputs).
    pub exposure: f32,
    /// Tone curve for 8-bit outputs; others stay linear.
    pub tonemap: Tonemap,
    /// KTX2 outputs also carry cubeforge's keys (`cubeforge.hdrEncoding`, `.edgeFixup`,
    /// `.levels`), which cubeforge reads back but `ktx validate -e` rejects (7010).
    pub cubeforge_keys: bool,
}

/// The bytes a texel of a moved or encoded copy costs: its level, its mips (4/3) and the
/// packed bytes, rounded up.
const COPY_BYTES_PER_TEXEL: u64 = 32;

impl Encoding {
    /// The output at `path` (layout `to`, or what the name implies) as these options write
    /// it: its format (faces whose type follows the input stay undecided while `hdr`, whether
    /// the result holds radiance, is not known), its write options (`linear`: 8- and 16-bit
    /// values as data) and tone, and the warnings for the options that do not apply. Refuses
    /// what the format cannot hold, before any work.
    pub fn resolve(
        &self,
        path: &Path,
        to: Option<MapKind>,
        hdr: Option<bool>,
        linear: bool,
    ) -> Result<Target> {
        let kind = kind_for(path, to)?;
        let faces = kind == MapKind::Layout(Kind::Faces);
        let container = kind.container();
        let mut warnings = Vec::new();
        if let Some(f) = self.face_format.filter(|f| faces && f.is_container()) {
            return Err(Error::usage(format!(
                "{} {}: face images are {}",
                param("format"),
                f.extension(),
                FileFormat::list(FileFormat::is_image, false)
            )));
        }
        let format = if faces {
            self.face_format
                .or(hdr.map(|h| if h { FileFormat::Exr } else { FileFormat::Png }))
        } else {
            FileFormat::from_extension(path)
        };
        let jpeg = format == Some(FileFormat::Jpeg);
        if self.ultrahdr && !jpeg {
            return Err(Error::usage(format!(
                "{} writes JPEG files: name the output .jpg (or give {} jpg for faces)",
                param("ultrahdr"),
                param("format")
            )));
        }
        let format = format.map(|f| match f {
            FileFormat::Jpeg if self.ultrahdr => FileFormat::UltraHdr,
            f => f,
        });
        let cube = kind.is_cube() || kind.layout().cells().is_some();
        if self.edge_fixup != EdgeFixup::None && !cube {
            warnings.push(Text::new(format!(
                "{} {} moves the texels of cube faces, and {} has none: ignored",
                param("edge_fixup"),
                self.edge_fixup.name(),
                kind.name()
            )));
        }
        match (container, self.gpu_format) {
            (None, Some(_)) => warnings.push(Text::new(format!(
                "{} applies to KTX2 and DDS outputs: ignored",
                param("gpu_format")
            ))),
            (Some(c), Some(f)) => {
                io::check_gpu_format(path, c.format(), f)?;
                if c == io::Container::Ktx {
                    io::ktx1::Ktx1Format::from_gpu(f).map_err(|e| Error::unsupported(path, e))?;
                }
            }
            _ => {}
        }
        match container {
            _ if self.zstd.is_none() => {}
            None => warnings.push(Text::new(format!(
                "{} applies to KTX2 outputs: ignored",
                param("zstd")
            ))),
            Some(io::Container::Ktx2) => {}
            Some(_) => return Err(io::zstd_needs_ktx2(path)),
        }
        let ktx2 = container == Some(io::Container::Ktx2);
        if self.cubeforge_keys && !ktx2 {
            warnings.push(Text::new(format!(
                "{} applies to KTX2 outputs: ignored",
                param("cubeforge_keys")
            )));
        }
        let write = WriteOptions {
            zstd: self.zstd.filter(|_| ktx2),
            cubeforge_keys: self.cubeforge_keys && ktx2,
            ..self.write_options(linear)
        };
        if let (Some(_), Some(f)) = (self.hdr_encoding, format) {
            io::hdr8::check(path, f, &write)?;
        }
        let (tone, tone_warning) = self.tone(path, format, &write);
        warnings.extend(tone_warning);
        Ok(Target {
            path: path.to_path_buf(),
            kind,
            format,
            write,
            gain_map: self.ultrahdr.then_some(self.tonemap),
            levels: None,
            tone,
            warnings,
        })
    }

    /// The options as the encoders take them (`linear`: 8- and 16-bit values as data).
    pub(crate) fn write_options(&self, linear: bool) -> WriteOptions {
        WriteOptions {
            linear,
            png16: self.png16,
            gpu_format: self.gpu_format.unwrap_or_default(),
            zstd: self.zstd,
            exr_float: self.exr_float,
            edge_fixup: self.edge_fixup,
            hdr_encoding: self.hdr_encoding,
            cubeforge_keys: self.cubeforge_keys,
        }
    }

    /// The exposure and tone curve an output of `format` gets: both for 8-bit outputs; for
    /// others the exposure alone (linear radiance scaled by 2^EV), and a warning when a curve
    /// was asked for. Undecided while the format is.
    fn tone(
        &self,
        path: &Path,
        format: Option<FileFormat>,
        write: &WriteOptions,
    ) -> (Option<(f32, Tonemap)>, Option<Text>) {
        let (exposure, tonemap) = (self.exposure, self.tonemap);
        let scaled = (exposure != 0.0).then_some((exposure, Tonemap::None));
        match format {
            None => (None, None),
            // The curve makes the SDR picture ([`super::Target::gain_map`]); the radiance is kept.
            Some(FileFormat::UltraHdr) => (scaled, None),
            Some(f) if io::largest_value(f, write.gpu_format).is_none() => {
                let given = exposure != 0.0 || tonemap != Tonemap::None;
                (given.then_some((exposure, tonemap)), None)
            }
            Some(_) => (
                scaled,
                (tonemap != Tonemap::None).then(|| Text::new(super::tone_ignored(path))),
            ),
        }
    }

    /// The memory the encoding takes beyond the job's own work, for a result of `texels`
    /// texels at its first level: the moved (edge fixup) or encoded (RGBM, RGBD) copy every
    /// level is written from, and UltraHDR's gain-map fitting.
    pub fn plan_bytes(&self, texels: u64) -> u64 {
        let copy = self.edge_fixup != EdgeFixup::None || self.hdr_encoding.is_some();
        let per_texel = if copy { COPY_BYTES_PER_TEXEL } else { 0 }
            + if self.ultrahdr {
                io::ultrahdr::ENCODE_BYTES_PER_TEXEL
            } else {
                0
            };
        texels.saturating_mul(per_texel)
    }
}
