//! `convert` as a job: any layout or container to any other.

use super::{Job, Progress, Quality, Report, Warning, Warnings};
use crate::convert;
use crate::convert::MapKind;
use crate::cube::CubeMap;
use crate::error::{param, Error, Result};
use crate::input::Input;
use crate::io::{Limits, ReadOptions};
use crate::layout::Kind;
use crate::output::{self, Destination, Encoding, Target};
use crate::resample::Resampler;
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
    /// Interpolation, antialiasing and orientation.
    pub resampler: Resampler,
    /// How the result is stored: every output option, and the tone of 8-bit outputs (for
    /// UltraHDR, the SDR picture's).
    pub encoding: Encoding,
    /// Mip levels of KTX2 and DDS output (None: the full chain).
    pub levels: Option<usize>,
    /// Which level of a mip chain input to read.
    pub level: usize,
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
            resampler: Resampler::default(),
            encoding: Encoding::default(),
            levels: None,
            level: 0,
            read: ReadOptions::default(),
        }
    }

    fn limits(&self) -> &Limits {
        &self.read.limits
    }

    /// The output as the encoders see it: before the input is known (`hdr` None), faces
    /// whose type follows it are undecided.
    fn target(&self, hdr: Option<bool>) -> Result<Target> {
        let mut target =
            self.encoding
                .resolve(&self.output.name(), self.to, hdr, self.read.linear)?;
        target.levels = self.levels;
        Ok(target)
    }

    /// The memory of converting to `size`: the output (RGBA f32, twice over for mips and
    /// encoding) and what the encoding adds, beside the input's texels and pyramid (`input`
    /// bytes).
    fn plan_bytes(&self, to: Kind, size: usize, input: u64) -> u64 {
        let (w, h) = to.image_size(size);
        let texels = if to != Kind::Faces {
            (w as u64).saturating_mul(h as u64)
        } else {
            (size as u64).saturating_mul(size as u64).saturating_mul(6)
        };
        texels
            .saturating_mul(32)
            .saturating_add(self.encoding.plan_bytes(texels))
            .saturating_add(input)
    }

    /// The input opened at the level converted.
    fn input(&self) -> Result<Input> {
        Input::open_level(&self.inputs, self.from, &self.read, self.level)
    }

    /// The plan of a `to` output of `size` from `file`, which a refusal names.
    fn check_memory(
        &self,
        file: Option<&PathBuf>,
        to: Kind,
        size: usize,
        input: u64,
    ) -> Result<()> {
        let (w, h) = to.image_size(size);
        self.limits().check_memory_for(
            file.map(PathBuf::as_path),
            format_args!("{} {size} ({w}x{h} output)", param("size")),
            self.plan_bytes(to, size, input),
        )
    }
}

impl Job for ConvertJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        let target = self.target(None)?;
        let to = target.kind;
        let name = self.output.name();
        let mut warnings: Vec<Warning> = Vec::new();
        let mut warn = |s: String| warnings.push(Warning::new(s));
        if to.container().is_none() && self.levels.is_some() {
            warn(format!(
                "{} applies to KTX2 and DDS outputs: ignored",
                param("levels")
            ));
        }
        warnings.extend(target.warnings);
        let mut warn = |s: String| warnings.push(Warning::new(s));
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
        let to = self.target(None)?.kind.layout();
        let input = self.input()?;
        Ok(match self.size.or(input.face_size()).filter(|&s| s > 0) {
            Some(size) => self.plan_bytes(to, size, input.plan_bytes()),
            None => input.plan_bytes(),
        })
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        let early = self.validate()?;
        warnings.extend(early.clone());
        let to = self.target(None)?.kind.layout();
        let container = self.target(None)?.kind.container().is_some();
        // The whole plan against the budget before any file is decoded: the input as the
        // headers describe it, the output at the size it will have.
        let input = self.input()?;
        if let Some(size) = self.size.or(input.face_size()).filter(|&s| s > 0) {
            self.check_memory(input.paths().first(), to, size, input.plan_bytes())?;
        }
        let (loaded, notes) = input.load()?;
        progress.stage("decode");
        for w in notes {
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
        self.check_memory(loaded.files.first(), to, size, loaded.working_bytes())?;
        // The format decided now that the input's is known (faces follow it): the tone
        // warning that only now applies.
        let target = self.target(Some(loaded.hdr))?;
        for w in target.warnings.iter().filter(|w| !early.contains(w)) {
            warnings.push(w);
        }

        let out =
            convert::convert_fixed(&loaded, to, size, &self.resampler, self.encoding.edge_fixup);
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
        let mut summary: Vec<String> = super::wrote(&files, &self.output).into_iter().collect();
        summary.extend(gain_map.iter().map(|g| g.summary()));
        summary.extend(target.notes());
        Ok(Report {
            written: files.paths(),
            warnings: warnings.into_vec(),
            summary: super::texts(summary),
            quality,
        })
    }

    fn limits_mut(&mut self) -> &mut crate::io::Limits {
        &mut self.read.limits
    }
}
