//! `prefilter` as a job: a mip chain for blurred or glossy reflections.

use super::{Job, Progress, Quality, Report, Warning, Warnings};
use crate::chain::{self, LevelsFile};
use crate::convert;
use crate::cube::CubeMap;
use crate::error::{param, Error, Result};
use crate::filter::{self, ChainOptions, LevelInfo};
use crate::input::Input;
use crate::io::{self, FileFormat, ReadOptions};
use crate::output::{self, Destination, Encoding, Files, Target};
use crate::resample::Resampler;
use crate::tonemap::{self, Tonemap};
use std::path::PathBuf;

/// The largest face edge of a chain's first level.
const MOST: usize = 16384;

/// Prefilters a map into a mip chain: a KTX2, DDS, KTX1 or .env container with every level,
/// or a folder of `m{level}/` faces with `levels.json`.
///
/// ```
/// use cubeforge::{ChainOptions, Destination, FilterKind, Job, PrefilterJob};
///
/// # fn main() -> cubeforge::Result<()> {
/// let out = std::env::temp_dir().join("cubeforge-doc-ggx.ktx2");
/// let job = PrefilterJob {
///     size: Some(64),
///     chain: ChainOptions { filter: FilterKind::Ggx, samples: 8, ..ChainOptions::default() },
///     ..PrefilterJob::new(vec!["fixtures/sky.exr".into()], Destination::Path(out.clone()))
/// };
/// let report = job.run(&())?;
/// // What it wrote (the KTX2 and its levels description beside it), the 64, 32 and 16 px
/// // levels (chains stop at 16 px unless `min_size` says otherwise), and the line that says
/// // where it stopped.
/// assert_eq!(report.summary.len(), 5);
/// # std::fs::remove_file(&out).ok();
/// # std::fs::remove_file(out.with_extension("ktx2.levels.json")).ok();
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct PrefilterJob {
    /// Anything [`crate::ConvertJob`] reads.
    pub inputs: Vec<PathBuf>,
    /// A container, a folder, or standard output (a container).
    pub output: Destination,
    /// The input's layout (None: from the aspect ratio).
    pub from: Option<crate::layout::Kind>,
    /// Face edge of level 0 (None: the input's).
    pub size: Option<usize>,
    /// The filter and the levels. With neither `levels` nor `min_size` set the chain stops at
    /// [`filter::DEFAULT_MIN_SIZE`] px faces; `min_size: Some(1)` makes the full chain.
    pub chain: ChainOptions,
    /// How the chain is stored: texel format, compression, sample type, 8-bit encoding, edge
    /// fixup, the folder's face type (EXR by default), and the exposure (2^EV) the radiance is
    /// scaled by before filtering.
    pub encoding: Encoding,
    /// Limits and colour handling of the inputs.
    pub read: ReadOptions,
}

impl PrefilterJob {
    /// The chain as built from a level 0 of `size`: with no level count and no floor given it
    /// stops at [`filter::DEFAULT_MIN_SIZE`] px faces (at level 0 when that is smaller), but
    /// for Babylon's .env, which holds every level down to 1 x 1.
    fn chain_for(&self, size: usize) -> ChainOptions {
        let mut chain = self.chain;
        let env = self.container() == Some(FileFormat::Env);
        if chain.levels.is_none() && chain.min_size.is_none() && !env {
            chain.min_size = Some(filter::DEFAULT_MIN_SIZE.min(size.max(1)));
        }
        chain
    }

    /// A chain of `inputs` at `output` with every option at its default (GGX).
    pub fn new(inputs: Vec<PathBuf>, output: Destination) -> PrefilterJob {
        PrefilterJob {
            inputs,
            output,
            from: None,
            size: None,
            chain: ChainOptions::default(),
            encoding: Encoding::default(),
            read: ReadOptions::default(),
        }
    }

    fn container(&self) -> Option<FileFormat> {
        FileFormat::from_extension(&self.output.name()).filter(|f| f.is_container())
    }

    /// The chain's output: a container by its name, else a folder of faces (EXR unless the
    /// encoding says otherwise).
    fn target(&self) -> Result<Target> {
        let to = match self.container() {
            Some(_) => None,
            None => Some(crate::layout::Kind::Faces.into()),
        };
        self.encoding
            .resolve(&self.output.name(), to, Some(true), self.read.linear)
    }

    /// The base faces, the chain (4/3 of them), a bordered sampler copy and the encoding,
    /// beside the input's texels and pyramid (`input` bytes).
    fn plan_bytes(&self, size: usize, input: u64) -> u64 {
        let texels = 6 * (size as u64).pow(2);
        (16 * 4 * texels)
            .saturating_add(self.encoding.plan_bytes(texels))
            .saturating_add(input)
    }

    /// The plan of a chain of `size` from `file`, which a refusal names.
    fn check_memory(&self, file: Option<&PathBuf>, size: usize, input: u64) -> Result<()> {
        self.read.limits.check_memory_for(
            file.map(PathBuf::as_path),
            format_args!("{} {size}", param("size")),
            self.plan_bytes(size, input),
        )
    }

    /// Level 0's face edge (`--size`, else the input's), checked with `--min-size` and the
    /// memory plan of the input as it was read.
    fn base_size(&self, loaded: &convert::Loaded) -> Result<usize> {
        let size = self.size.unwrap_or_else(|| loaded.face_size());
        Self::check_size(size)?;
        if let Some(min) = self.chain.min_size.filter(|&m| m > size) {
            return Err(Error::usage(format!(
                "{} {min} is larger than level 0, whose faces are {size} px",
                param("min_size")
            )));
        }
        self.check_memory(loaded.files.first(), size, loaded.working_bytes())?;
        Ok(size)
    }

    /// 8-bit files clip at 1, unless an HDR encoding holds more (its own range is the
    /// encoder's clamp warning).
    fn clip_warning(&self, target: &Target, chain: &CubeMap) -> Option<String> {
        let eight_bit = target
            .format()
            .is_some_and(|f| io::largest_value(f, target.write.gpu_format).is_none());
        if !eight_bit || target.write.hdr_encoding.is_some() {
            return None;
        }
        let (n, top) = tonemap::clipped(chain.levels.iter().flatten(), Tonemap::None, 0.0);
        let exposure = self.encoding.exposure;
        (n > 0).then(|| output::clip_warning(&self.output.name(), n, top, exposure, false))
    }

    /// A DDS or KTX2 chain's description goes beside it: there is no beside on standard
    /// output, so only the file is kept there, with the warning that says so.
    fn keep_one_on_stdout(&self, target: &Target, files: &mut Files) -> Option<String> {
        if !self.output.is_stdout() || files.files.len() <= 1 {
            return None;
        }
        let warning = format!(
            "-o -: the chain's levels description (NAME.{}.levels.json) is not written{}",
            files.files[0]
                .0
                .extension()
                .unwrap_or_default()
                .to_string_lossy(),
            match target.format() {
                Some(io::FileFormat::Ktx2) =>
                    format!(" ({} puts it in the file)", param("cubeforge_keys")),
                _ => String::new(),
            }
        );
        files.files.truncate(1);
        Some(warning)
    }

    /// The report's line per level, and where the chain stopped short of the full one.
    fn level_lines(
        &self,
        description: &LevelsFile,
        options: &ChainOptions,
        size: usize,
    ) -> Vec<String> {
        let mut lines: Vec<String> = description.levels.iter().map(level_line).collect();
        let full = CubeMap::full_chain_len(size);
        if let (Some(min), Some(last)) = (options.min_size, description.levels.last()) {
            if description.levels.len() < full {
                let default = if self.chain.min_size.is_none() {
                    format!(", the default; {} 1 for the full chain", param("min_size"))
                } else {
                    String::new()
                };
                lines.push(format!(
                    "stopped at {} px ({} {min}{default}): {} levels instead of {full}",
                    last.size,
                    param("min_size"),
                    description.levels.len(),
                ));
            }
        }
        lines
    }

    fn check_size(size: usize) -> Result<()> {
        if size == 0 || size > MOST {
            return Err(Error::usage(format!(
                "{} {size}: use 1 to {MOST}",
                param("size")
            )));
        }
        Ok(())
    }
}

impl Job for PrefilterJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        let name = self.output.name();
        let container = self.container();
        if container.is_none() && name.extension().is_some() && !name.is_dir() {
            return Err(Error::file(
                &name,
                format!(
                    "prefilter writes a cube map ({}) or a folder (a name without an extension)",
                    FileFormat::list(FileFormat::is_container, true)
                ),
            ));
        }
        let warnings = self.target()?.warnings;
        if self.chain.samples == 0 {
            return Err(Error::usage(format!(
                "{} must be at least 1",
                param("samples")
            )));
        }
        if container.is_none() {
            // A folder output is replaced whole: refuse one that is not cubeforge's before
            // the work.
            output::check_folder_output(&name, &self.inputs, &[])?;
        }
        if let Some(size) = self.size {
            Self::check_size(size)?;
        }
        Ok(warnings)
    }

    fn memory_estimate(&self) -> Result<u64> {
        let input = Input::open(&self.inputs, self.from, &self.read)?;
        Ok(match self.size.or(input.face_size()) {
            Some(size) => self.plan_bytes(size, input.plan_bytes()),
            None => input.plan_bytes(),
        })
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        let target = self.target()?;
        // The whole plan against the budget before any file is decoded.
        let input = Input::open(&self.inputs, self.from, &self.read)?;
        if let Some(size) = self.size.or(input.face_size()) {
            self.check_memory(input.paths().first(), size, input.plan_bytes())?;
        }
        let (loaded, notes) = input.load()?;
        progress.stage("decode");
        for w in notes {
            warnings.push(w);
        }
        let size = self.base_size(&loaded)?;
        let mut base = convert::to_cube(&loaded, size, &Resampler::default());
        base.levels[0]
            .iter_mut()
            .for_each(|f| crate::tonemap::scale(f, self.encoding.exposure));
        progress.stage("resample");

        let chain_options = self.chain_for(size);
        let levels = filter::plan(&chain_options, size);
        let (chain, infos) = filter::prefilter_reported(&base, &chain_options, levels, progress);
        progress.stage("filter");

        let description = LevelsFile::new(&chain_options, size, infos);
        let encoded = chain::encode(&target, &chain, &description, &loaded.files)?;
        if let Some(w) = &encoded.clamped {
            warnings.push(w);
        }
        if let Some(w) = self.clip_warning(&target, &chain) {
            warnings.push(w);
        }
        let quality = encoded.psnr.map(|psnr_db| Quality {
            format: target.write.gpu_format,
            psnr_db,
        });
        progress.stage("encode");
        let mut files: Files = encoded.into_files();
        if let Some(w) = self.keep_one_on_stdout(&target, &mut files) {
            warnings.push(w);
        }
        output::deliver(&files, &self.output, &loaded.files)?;
        progress.stage("write");
        let mut summary: Vec<String> = super::wrote(&files, &self.output).into_iter().collect();
        summary.extend(self.level_lines(&description, &chain_options, size));
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

/// One level as the report lists it: its size, its lobe and how it was summed.
fn level_line(i: &LevelInfo) -> String {
    let what = match (i.roughness, i.power, i.sigma) {
        (Some(r), _, _) => format!("roughness {r:.3} (alpha {:.4})", r * r),
        (_, Some(p), _) => format!("power {p:.1}"),
        (_, _, Some(s)) => format!("sigma {:.5} rad ({:.3} deg)", s, s.to_degrees()),
        _ => "2x2 box mean".to_string(),
    };
    let samples = match (i.samples, i.power.or(i.sigma)) {
        (Some(s), _) => format!(", {s} samples"),
        // A narrow cosine or Gaussian lobe: summed over the texels it covers.
        (None, Some(_)) => ", exact sum".to_string(),
        _ => String::new(),
    };
    format!("level {:2}  {:5} px  {what}{samples}", i.level, i.size)
}
