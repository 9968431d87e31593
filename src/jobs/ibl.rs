//! `ibl` as a job: the files an engine loads for image-based lighting.

use super::{Job, Progress, Quality, Report, Warning, Warnings};
use crate::convert;
use crate::error::{param, Error, Result};
use crate::ibl::{self, Engine, IblOptions};
use crate::input::Input;
use crate::io::{self, GpuFormat, ReadOptions};
use crate::output::{self, Destination, Files};
use std::path::PathBuf;

/// The files `engine` loads (a specular chain, a diffuse term, SH, tables) in a folder.
///
/// ```
/// use cubeforge::{Engine, IblJob, IblOptions, Job};
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

    /// The specular chain's face edge for an input of `input_face` px faces (None: not known
    /// yet): `--size`, else the engine's default, but never larger than the input's faces
    /// (rounded to the nearest power of two): enlarging adds bytes, not detail.
    fn specular_size(&self, input_face: Option<usize>) -> usize {
        let d = ibl::engines::defaults(self.engine);
        match (self.options.specular_size, input_face) {
            (Some(s), _) => s,
            (None, Some(face)) => d.specular_size.min(nearest_power_of_two(face)),
            (None, None) => d.specular_size,
        }
    }

    /// What the run will make, in one line.
    fn plan_line(&self, loaded: &convert::Loaded, options: &IblOptions) -> String {
        let input = match loaded.files.as_slice() {
            [one] => one.display().to_string(),
            files => format!("{} files", files.len()),
        };
        let made = if ibl::panorama::filters_itself(self.engine) {
            "a panorama the engine prefilters itself".to_owned()
        } else {
            let (size, min, diffuse) = ibl::sizes(self.engine, options);
            format!(
                "a GGX chain of {size} px faces down to {min} px, a {diffuse} px irradiance map \
                 and its SH"
            )
        };
        format!("ibl {}: {made} from {input}", self.engine.name())
    }

    /// The specular and diffuse face edges.
    fn sizes(&self, input_face: Option<usize>) -> (u64, u64) {
        let size = self.specular_size(input_face) as u64;
        (size, ibl::sizes(self.engine, &self.options).2 as u64)
    }

    /// Each chain: the base faces, the chain (4/3 of them), a bordered sampler copy and the
    /// encoding; the diffuse map: its faces, the encoding and a sampler copy.
    fn plan_bytes(&self, input_face: Option<usize>, input: u64) -> u64 {
        let (size, diffuse) = self.sizes(input_face);
        let face = |n: u64| 6 * 16 * n * n;
        let chains = if self.options.sheen { 2 } else { 1 };
        // three.js's panorama: 4 x 2 faces of a power of two from 256 and what its UltraHDR
        // encoding takes; with a GPU format also its mips (4/3), their upside-down copy and
        // the encoding.
        let three = if self.engine == Engine::Three {
            let s = size.next_power_of_two().clamp(256, 4096);
            let ktx2 = if self.options.encoding.gpu_format.is_some() {
                3 * 16
            } else {
                0
            };
            let uhdr = crate::output::Encoding {
                ultrahdr: true,
                ..self.options.encoding
            };
            (8 * s * s * (16 + ktx2)).saturating_add(uhdr.plan_bytes(8 * s * s))
        } else {
            0
        };
        (chains * 4 * face(size))
            .saturating_add(3 * face(diffuse))
            .saturating_add(three)
            .saturating_add(input)
    }
}

impl IblJob {
    /// The input, opened from its headers: a large panorama reduced as it is decoded
    /// (`convert::stream`) when every output is a cube much coarser than it (the engines whose
    /// files all come from the specular base), else whole. Its plan is what will run.
    fn input(&self) -> Result<Input> {
        let cubes_only = matches!(
            self.engine,
            Engine::Bevy | Engine::Gltf | Engine::Babylon | Engine::Generic
        );
        // --sun finds and takes out the sun on the input's own texels.
        if self.inputs.len() != 1
            || !cubes_only
            || self.options.sun
            || !matches!(self.from, None | Some(crate::layout::Kind::Equirect))
        {
            return Input::open(&self.inputs, self.from, &self.read);
        }
        // The finest texel of the specular base: a face's corner, 2 sqrt(2) / 3 of its centre.
        Input::open_reduced(&self.inputs, self.from, &self.read, |face| {
            let size = self.specular_size(Some(face)) as f32;
            2.0 * std::f32::consts::SQRT_2 / 3.0 / size
        })
    }

    /// Refuses a `--gpu-format` the target has no file for, before any work.
    fn check_gpu_format(&self, format: GpuFormat) -> Result<()> {
        let flag = param("gpu_format");
        let target = self.engine.name();
        match self.engine {
            // three.js's KTX2Loader transcodes UASTC HDR to what the device has.
            Engine::Three if format == GpuFormat::UastcHdr4x4 => {
                format.check_built().map_err(Error::usage)
            }
            Engine::Three => Err(Error::usage(format!(
                "{flag} {}: three.js's KTX2Loader is given UASTC HDR (uastc-hdr-4x4), which it transcodes for each device",
                format.name()
            ))),
            Engine::Unity | Engine::Unreal => Err(Error::usage(format!(
                "{flag}: {target} is given a panorama that it filters itself, no KTX2: leave out {flag}"
            ))),
            Engine::Babylon => Err(Error::usage(format!(
                "{flag}: Babylon's .env holds RGBD PNG faces only"
            ))),
            Engine::Filament => io::ktx1::Ktx1Format::from_gpu(format)
                .map(|_| ())
                .map_err(Error::usage),
            // Godot's images know ASTC HDR in 4x4 and 8x8 blocks only.
            // UASTC HDR is written for transcoders, and Godot's KTX loader is not one.
            Engine::Godot if matches!(format, GpuFormat::AstcHdr6x6 | GpuFormat::UastcHdr4x4) => {
                Err(Error::usage(format!(
                    "{flag} {}: Godot reads ASTC HDR in 4x4 blocks (astc-hdr-4x4)",
                    format.name()
                )))
            }
            _ => format.check_built().map_err(Error::usage),
        }
    }
}

impl Job for IblJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        if self.output == std::path::Path::new("-") {
            return Err(Error::usage(
                "-o - (standard output) takes one file, and ibl writes several (a specular chain, a diffuse map, tables): name a folder",
            ));
        }
        if let Some(format) = self.options.encoding.gpu_format {
            self.check_gpu_format(format)?;
        }
        // The folder is replaced whole: refused before the work when it holds an input or
        // what no target wrote.
        let name = self.options.name.as_deref().unwrap_or("env");
        let known = ibl::written_by_targets(&self.output, name);
        output::check_folder_output(&self.output, &self.inputs, &known)?;
        Ok(Vec::new())
    }

    fn memory_estimate(&self) -> Result<u64> {
        let input = self.input()?;
        Ok(self.plan_bytes(input.face_size(), input.plan_bytes()))
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        // The whole plan against the budget before any file is decoded: the input, the
        // specular chain (and the sheen chain), the diffuse map.
        let input = self.input()?;
        let (size, diffuse) = self.sizes(input.face_size());
        let file = input.paths().first().map(PathBuf::as_path);
        self.read.limits.check_memory_for(
            file,
            format_args!(
                "{} {size} and {} {diffuse}",
                param("size"),
                param("diffuse_size")
            ),
            self.plan_bytes(input.face_size(), input.plan_bytes()),
        )?;
        let (mut loaded, notes) = input.load()?;
        loaded.expose(self.options.encoding.exposure);
        progress.stage("decode");
        for w in notes {
            warnings.push(w);
        }
        if let Some(w) = super::display_referred(&loaded) {
            warnings.push(w);
        }
        let face = loaded.face_size();
        let mut options = self.options.clone();
        let mut notes = Vec::new();
        if !ibl::panorama::filters_itself(self.engine) {
            let size = self.specular_size(Some(face));
            let default = ibl::engines::defaults(self.engine).specular_size;
            if self.options.specular_size.is_none() && size < default {
                notes.push(format!(
                    "specular chain at {size} px, the input's face size ({face} px): the \
                     target's {default} px would only enlarge it ({} {default} to have it anyway)",
                    param("size")
                ));
            }
            options.specular_size = Some(size);
        }
        if let Some(asked) = self.options.specular_size.filter(|&s| s > face) {
            warnings.push(format!(
                "{} {asked} enlarges the input's {face} px faces {:.1} times: the files grow, \
                 the detail does not",
                param("size"),
                asked as f64 / face as f64
            ));
        }
        let chains = matches!(self.engine, Engine::Bevy | Engine::Gltf | Engine::Generic);
        if self.options.encoding.cubeforge_keys && !chains {
            warnings.push(format!(
                "{} applies to the KTX2 chains of bevy, gltf and generic: ignored",
                param("cubeforge_keys")
            ));
        }
        progress.begin(&self.plan_line(&loaded, &options));
        let delivery = ibl::deliver(&loaded, self.engine, &self.output, &options, progress)?;
        if let Some(w) = &delivery.clamped {
            warnings.push(w);
        }
        let quality = match (self.options.encoding.gpu_format, delivery.psnr) {
            (Some(format), Some(psnr_db)) => Some(Quality { format, psnr_db }),
            _ => None,
        };
        // The folder is this target's, replaced whole: another target's files go with it.
        let name = options.name.as_deref().unwrap_or("env");
        let files = Files {
            known: ibl::written_by_targets(&self.output, name),
            folders: vec![self.output.clone()],
            ..Files::new(delivery.files)
        };
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
        summary.extend(notes);
        summary.push(delivery.snippet);
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

/// The power of two nearest `n` (in ratio: 724 -> 512, 725 -> 1024), at least 1.
fn nearest_power_of_two(n: usize) -> usize {
    let up = n.max(1).next_power_of_two();
    let down = up / 2;
    if down > 0 && (n as f64 / down as f64) < (up as f64 / n as f64) {
        down
    } else {
        up
    }
}
