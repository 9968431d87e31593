//! `ibl` as a job: the files an engine loads for image-based lighting.

use super::{Job, Progress, Quality, Report, Warning, Warnings};
use crate::chain;
use crate::convert;
use crate::error::{param, Error, Result};
use crate::ibl::{self, Engine, IblOptions};
use crate::io::ReadOptions;
use crate::output::{self, Destination, Files};
use std::path::PathBuf;

/// The files `engine` loads (a specular chain, a diffuse term, SH, tables) in a folder.
///
/// ```
/// use cubeforge::ibl::{Engine, IblOptions};
/// use cubeforge::{IblJob, Job};
///
/// # fn main() -> cubeforge::Result<()> {
/// let dir = std::env::temp_dir().join(format!("cubeforge-doc-bevy-{}", std::process::id()));
/// let job = IblJob {
///     options: IblOptions { specular_size: Some(16), samples: Some(4), ..IblOptions::default() },
///     ..IblJob::new(vec!["fixtures/sky.exr".into()], dir.clone(), Engine::Bevy)
/// };
/// let report = job.run(&())?;
/// assert!(report.written.iter().any(|p| p.ends_with("env_specular.ktx2")));
/// # std::fs::remove_dir_all(&dir).ok();
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct IblJob {
    /// Anything [`crate::ConvertJob`] reads.
    pub inputs: Vec<PathBuf>,
    /// The folder that receives the files (made if missing).
    pub output: PathBuf,
    /// The engine whose files to write.
    pub engine: Engine,
    /// The input's layout (None: from the aspect ratio).
    pub from: Option<crate::layout::Kind>,
    /// Sizes, samples, formats, names (None: the engine's defaults).
    pub options: IblOptions,
    /// Limits and colour handling of the inputs.
    pub read: ReadOptions,
}

impl IblJob {
    /// `engine`'s files from `inputs` into `output`, everything at the engine's defaults.
    pub fn new(inputs: Vec<PathBuf>, output: PathBuf, engine: Engine) -> IblJob {
        IblJob {
            inputs,
            output,
            engine,
            from: None,
            options: IblOptions::default(),
            read: ReadOptions::default(),
        }
    }

    /// The specular and diffuse face edges.
    fn sizes(&self) -> (u64, u64) {
        let d = ibl::engines::defaults(self.engine);
        let size = self.options.specular_size.unwrap_or(d.specular_size) as u64;
        let diffuse = self.options.diffuse_size.unwrap_or(d.diffuse_size) as u64;
        (size, diffuse)
    }

    /// Each chain: the base faces, the chain (4/3 of them), a bordered sampler copy and the
    /// encoding; the diffuse map: its faces, the encoding and a sampler copy.
    fn plan_bytes(&self, input: u64) -> u64 {
        let (size, diffuse) = self.sizes();
        let face = |n: u64| 6 * 16 * n * n;
        let chains = if self.options.sheen { 2 } else { 1 };
        (chains * 4 * face(size))
            .saturating_add(3 * face(diffuse))
            .saturating_add(input)
    }
}

impl Job for IblJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        if self.output == std::path::Path::new("-") {
            return Err(Error::usage(
                "-o - (standard output) takes one file, and ibl writes several (a specular chain, a diffuse map, tables): name a folder",
            ));
        }
        Ok(Vec::new())
    }

    fn memory_estimate(&self) -> Result<u64> {
        let plan = chain::plan(&self.inputs, self.from, &self.read)?;
        Ok(self.plan_bytes(plan.working_bytes()))
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        // The whole plan against the budget before any file is decoded: the input, the
        // specular chain (and the sheen chain), the diffuse map.
        let (size, diffuse) = self.sizes();
        self.read.limits.check_memory(
            format_args!(
                "{} {size} and {} {diffuse}",
                param("size"),
                param("diffuse_size")
            ),
            self.memory_estimate()?,
        )?;
        let loaded = convert::load_planned(&self.inputs, self.from, &self.read)?;
        progress.stage("decode");
        let delivery = ibl::deliver(&loaded, self.engine, &self.output, &self.options, &|s| {
            progress.stage(s)
        })?;
        if let Some(w) = &delivery.clamped {
            warnings.push(w);
        }
        let quality = match (self.options.gpu_format, delivery.psnr) {
            (Some(format), Some(psnr_db)) => Some(Quality { format, psnr_db }),
            _ => None,
        };
        let files = Files::new(delivery.files);
        output::deliver(
            &files,
            &Destination::Path(self.output.clone()),
            &loaded.files,
        )?;
        progress.stage("write");
        let mut summary: Vec<String> = files
            .files
            .iter()
            .map(|(p, bytes)| format!("{} ({} bytes)", p.display(), bytes.len()))
            .collect();
        summary.push(delivery.snippet);
        Ok(Report {
            written: files.paths(),
            warnings: warnings.into_vec(),
            summary: super::texts(summary),
            quality,
        })
    }
}
