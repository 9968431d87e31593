//! `convert` as a job: any layout or container to any other.

use super::{replaced_values, Job, Progress, Quality, Report, Warning, Warnings};
use crate::chain;
use crate::convert;
use crate::cube::CubeMap;
use crate::error::{param, Error, Result};
use crate::io::{
    self, Container, ExrFloat, FileFormat, GpuFormat, Limits, MapKind, ReadOptions, WriteOptions,
};
use crate::layout::Kind;
use crate::output::{self, Destination, Target};
use crate::resample::Resampler;
use crate::tonemap::Tonemap;
use std::path::PathBuf;

/// Converts an environment map from any layout to any other.
///
/// ```
/// use cubeforge::{ConvertJob, Destination, Job};
///
/// # fn main() -> cubeforge::Result<()> {
/// let out = std::env::temp_dir().join("cubeforge-doc-convert.ktx2");
/// let job = ConvertJob {
///     size: Some(32),
///     ..ConvertJob::new(vec!["fixtures/sky.exr".into()], Destination::Path(out.clone()))
/// };
/// let report = job.run(&())?; // validates, checks the memory plan, writes all or nothing
/// assert_eq!(report.written, [out.clone()]);
/// # std::fs::remove_file(&out).ok();
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct ConvertJob {
    /// One image, six faces (px nx py ny pz nz), or a folder of faces or of a chain.
    pub inputs: Vec<PathBuf>,
    /// Where the result goes.
    pub output: Destination,
    /// The input's layout (None: from the aspect ratio).
    pub from: Option<Kind>,
    /// The output's layout or container (None: from the output's name).
    pub to: Option<MapKind>,
    /// Face edge in texels (None: the input's).
    pub size: Option<usize>,
    /// File type of face images (faces only; None: EXR for HDR input, PNG otherwise).
    pub face_format: Option<FileFormat>,
    /// Interpolation, antialiasing and orientation.
    pub resampler: Resampler,
    /// 16-bit PNG.
    pub png16: bool,
    /// Texel format of KTX2 and DDS output (None: rgba16f).
    pub gpu_format: Option<GpuFormat>,
    /// Zstandard level of KTX2 supercompression.
    pub zstd: Option<i32>,
    /// Sample type of EXR output (half by default; f32 keeps radiance beyond 65504).
    pub exr_float: ExrFloat,
    /// Mip levels of KTX2 and DDS output (None: the full chain).
    pub levels: Option<usize>,
    /// Which level of a mip chain input to read.
    pub level: usize,
    /// Exposure (stops) and tone curve for 8-bit outputs (for UltraHDR, the SDR picture's).
    pub tone: (f32, Tonemap),
    /// A JPEG output as UltraHDR: an SDR picture and a gain map that keeps the radiance.
    pub ultrahdr: bool,
    /// Texel centres moved for per-face (non-seamless) samplers: cube outputs, every level.
    pub edge_fixup: crate::cube::EdgeFixup,
    /// 8-bit outputs as RGBM or RGBD (PNG, or KTX2/DDS of rgba8): HDR kept in 8 bits.
    pub hdr_encoding: Option<crate::io::HdrEncoding>,
    /// Limits and colour handling of the inputs (`linear` applies to the output too).
    pub read: ReadOptions,
}

impl ConvertJob {
    /// A conversion of `inputs` to `output` with every option at its default.
    pub fn new(inputs: Vec<PathBuf>, output: Destination) -> ConvertJob {
        ConvertJob {
            inputs,
            output,
            from: None,
            to: None,
            size: None,
            face_format: None,
            resampler: Resampler::default(),
            png16: false,
            gpu_format: None,
            zstd: None,
            exr_float: ExrFloat::Half,
            levels: None,
            level: 0,
            tone: (0.0, Tonemap::None),
            ultrahdr: false,
            edge_fixup: crate::cube::EdgeFixup::None,
            hdr_encoding: None,
            read: ReadOptions::default(),
        }
    }

    fn limits(&self) -> &Limits {
        &self.read.limits
    }

    /// The output as the encoders see it, before the input is known.
    fn target(&self) -> Result<Target> {
        Target::new(&self.output.name(), self.to, false)
    }

    /// The memory of converting to `size`: the output (RGBA f32, twice over for mips and
    /// encoding; UltraHDR's fitting more) beside the input's texels and pyramid (`input`
    /// bytes).
    fn plan_bytes(&self, to: Kind, size: usize, input: u64) -> u64 {
        let (w, h) = to.image_size(size);
        let texels = if to != Kind::Faces {
            (w as u64).saturating_mul(h as u64)
        } else {
            (size as u64).saturating_mul(size as u64).saturating_mul(6)
        };
        let per_texel = if self.ultrahdr {
            32 + io::ultrahdr::ENCODE_BYTES_PER_TEXEL
        } else {
            32
        };
        // An edge fixup or an 8-bit encoding writes from a moved or encoded copy (mips too).
        let copy = super::writes_a_copy(self.edge_fixup, self.hdr_encoding);
        let per_texel = per_texel + if copy { 24 } else { 0 };
        texels.saturating_mul(per_texel).saturating_add(input)
    }

    fn check_memory(&self, to: Kind, size: usize, input: u64) -> Result<()> {
        let (w, h) = to.image_size(size);
        self.limits().check_memory(
            format_args!("{} {size} ({w}x{h} output)", param("size")),
            self.plan_bytes(to, size, input),
        )
    }
}

impl Job for ConvertJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        let target = self.target()?;
        let to = target.kind;
        let name = self.output.name();
        let mut warnings: Vec<Warning> = super::fixup_ignored(to, self.edge_fixup)
            .into_iter()
            .collect();
        let mut warn = |s: String| warnings.push(Warning::new(s));
        let jpeg = match to {
            MapKind::Layout(Kind::Faces) => self.face_format == Some(FileFormat::Jpeg),
            _ => FileFormat::from_extension(&name) == Some(FileFormat::Jpeg),
        };
        if self.ultrahdr && !jpeg {
            return Err(Error::usage(format!(
                "{} writes JPEG files: name the output .jpg (or give {} jpg for faces)",
                param("ultrahdr"),
                param("format")
            )));
        }
        if to.container().is_none() {
            if self.levels.is_some() {
                warn(format!(
                    "{} applies to KTX2 and DDS outputs: ignored",
                    param("levels")
                ));
            }
            if self.gpu_format.is_some() {
                warn(format!(
                    "{} applies to KTX2 and DDS outputs: ignored",
                    param("gpu_format")
                ));
            }
            if self.zstd.is_some() {
                warn(format!(
                    "{} applies to KTX2 outputs: ignored",
                    param("zstd")
                ));
            }
        } else if to == MapKind::Container(Container::Dds) && self.zstd.is_some() {
            return Err(io::zstd_needs_ktx2(&name));
        }
        if let (Some(c), Some(f)) = (to.container(), self.gpu_format) {
            io::check_gpu_format(&name, c.format(), f)?;
        }
        let format = match to {
            MapKind::Layout(Kind::Faces) => self.face_format,
            _ => FileFormat::from_extension(&name),
        };
        let write = WriteOptions {
            png16: self.png16,
            gpu_format: self.gpu_format.unwrap_or_default(),
            hdr_encoding: self.hdr_encoding,
            ..WriteOptions::default()
        };
        crate::output::check_hdr_encoding(&name, format, &write)?;
        if self.levels == Some(0) {
            return Err(Error::usage(format!(
                "{} 0: a map has at least 1 level",
                param("levels")
            )));
        }
        let faces = to == MapKind::Layout(Kind::Faces);
        if faces && self.to.is_none() && name.extension().is_none() && !name.exists() {
            warn(format!(
                "{}: no file extension, so six faces go into this new folder ({} faces)",
                name.display(),
                param("to")
            ));
        }
        if let Some(f) = self.face_format.filter(|f| f.is_container()) {
            if faces {
                return Err(Error::usage(format!(
                    "{} {}: face images are {}",
                    param("format"),
                    f.extension(),
                    FileFormat::list(FileFormat::is_image, false)
                )));
            }
        }
        if let Some(n) = self.size {
            if n == 0 {
                return Err(Error::usage(format!(
                    "{} must be at least 1",
                    param("size")
                )));
            }
            if n > self.limits().max_dimension as usize {
                return Err(Error::usage(format!(
                    "{} {n}: over the size limit of {} px per side",
                    param("size"),
                    self.limits().max_dimension
                )));
            }
        }
        Ok(warnings)
    }

    fn memory_estimate(&self) -> Result<u64> {
        let to = self.target()?.kind.layout();
        let plan = chain::plan_level(&self.inputs, self.from, &self.read, self.level)?;
        Ok(match self.size.or(plan.face_size).filter(|&s| s > 0) {
            Some(size) => self.plan_bytes(to, size, plan.working_bytes()),
            None => plan.working_bytes(),
        })
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        let mut target = self.target()?;
        let to = target.kind.layout();
        let container = target.kind.container().is_some();
        // The whole plan against the budget before any file is decoded: the input as the
        // headers describe it, the output at the size it will have.
        let plan = chain::plan_level(&self.inputs, self.from, &self.read, self.level)?;
        if let Some(size) = self.size.or(plan.face_size).filter(|&s| s > 0) {
            self.check_memory(to, size, plan.working_bytes())?;
        }
        let loaded = chain::load_level_planned(&self.inputs, self.from, &self.read, self.level)?;
        progress.stage("decode");
        if let Some(w) = convert::skybox_note(&self.inputs) {
            warnings.push(w);
        }
        if let Some(w) = convert::part_note(&loaded, &self.read) {
            warnings.push(w);
        }
        if let Some(w) = replaced_values(&loaded.files[0], loaded.meta.replaced_values as u64) {
            warnings.push(w);
        }
        let size = self.size.unwrap_or_else(|| loaded.face_size());
        if size == 0 {
            return Err(Error::usage(format!(
                "{} must be at least 1",
                param("size")
            )));
        }
        if let (Some(n), true) = (self.levels, container) {
            let most = CubeMap::full_chain_len(size);
            if n > most {
                return Err(Error::usage(format!(
                    "{} {n}: a cube map of {size} px has 1 to {most} levels",
                    param("levels")
                )));
            }
        }
        let (w, h) = to.image_size(size);
        let limits = self.limits();
        if w as u64 * h as u64 > limits.max_pixels || w.max(h) > limits.max_dimension as usize {
            return Err(Error::usage(format!(
                "{} {size} makes a {w}x{h} output, over the size limit ({})",
                param("size"),
                param("max_pixels")
            )));
        }
        // Again with what was decoded (standard input's size is known only now).
        self.check_memory(to, size, loaded.working_bytes())?;
        target.face_format = self.face_format.unwrap_or(if loaded.hdr {
            FileFormat::Exr
        } else {
            FileFormat::Png
        });
        target.write = WriteOptions {
            linear: self.read.linear,
            png16: self.png16,
            gpu_format: self.gpu_format.unwrap_or_default(),
            zstd: self.zstd.filter(|_| container),
            exr_float: self.exr_float,
            gain_map: self.ultrahdr.then_some(self.tone.1),
            edge_fixup: self.edge_fixup,
            hdr_encoding: self.hdr_encoding,
        };
        target.levels = self.levels;
        let (tone, tone_warning) = output::tone_for(&target, self.tone.0, self.tone.1);
        target.tone = tone;
        if let Some(w) = tone_warning {
            warnings.push(w);
        }

        let out = convert::convert_fixed(&loaded, to, size, &self.resampler, self.edge_fixup);
        progress.stage("resample");
        let encoded = target.encode(out, &loaded.files)?;
        if let Some(w) = &encoded.clamped {
            warnings.push(w);
        }
        progress.stage("encode");
        let quality = encoded.psnr.map(|psnr_db| Quality {
            format: target.write.gpu_format,
            psnr_db,
        });
        let gain_map = encoded.gain_map;
        let files = encoded.into_files();
        output::deliver(&files, &self.output, &loaded.files)?;
        progress.stage("write");
        Ok(Report {
            written: files.paths(),
            warnings: warnings.into_vec(),
            summary: gain_map
                .iter()
                .map(|g| crate::error::Text::new(g.summary()))
                .collect(),
            quality,
        })
    }

    fn limits_mut(&mut self) -> &mut crate::io::Limits {
        &mut self.read.limits
    }
}
