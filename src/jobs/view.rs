//! `view` as a job: the interactive viewer's page and data for a map.

use super::{Job, Progress, Report, Warning, Warnings};
use crate::error::{Error, Result};
use crate::ibl::Engine;
use crate::image::Image;
use crate::input::Input;
use crate::io::{Limits, ReadOptions};
use crate::output::{self, Destination, Files};
use crate::preview::{self, pbr};
use crate::view;
use std::path::{Path, PathBuf};

/// A control map and the LOD bias its blur = 1 stands for.
type ControlMap = (Image, f32);

/// A static viewer for a map: the preview's scene drawn live by the GPU in a browser.
///
/// ```
/// use cubeforge::{Job, ViewJob};
///
/// # fn main() -> cubeforge::Result<()> {
/// let dir = std::env::temp_dir().join(format!("cubeforge-doc-view-{}", std::process::id()));
/// let report = ViewJob::new("fixtures/sky.exr".into(), dir.clone()).run(&())?;
/// assert!(report.written.iter().any(|p| p.ends_with("index.html")));
/// # std::fs::remove_dir_all(&dir).ok();
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct ViewJob {
    /// A panorama, faces, a cube map or a prefiltered chain (as `preview` reads them).
    pub input: PathBuf,
    /// The folder that receives index.html and its data; with `single_file`, the page itself.
    pub output: PathBuf,
    /// The input's layout (None: from the aspect ratio).
    pub from: Option<crate::layout::Kind>,
    /// One self-contained .html file instead of a folder.
    pub single_file: bool,
    /// The decal on the sphere (sRGB colour).
    pub decal: Option<PathBuf>,
    /// A control map (linear data) and its default blur range.
    pub control: Option<PathBuf>,
    /// The LOD bias a control map's blur = 1 stands for, when it has no sidecar.
    pub max_lod_bias: f32,
    /// pbr reads the chain with this engine's roughness mapping.
    pub target: Option<Engine>,
    /// Size limits and the memory budget.
    pub limits: Limits,
    /// Which part of a multi-part OpenEXR input to show (None: the first).
    pub exr_part: Option<usize>,
    /// An 8-bit input's RGBM or RGBD (None: plain, or what a KTX2 says).
    pub hdr_encoding: Option<crate::io::HdrEncoding>,
    /// An 8- or 16-bit input holds data, not colour: no sRGB decode (`--linear`).
    pub linear: bool,
}

impl ViewJob {
    /// A viewer of `input` in the folder `output`.
    pub fn new(input: PathBuf, output: PathBuf) -> ViewJob {
        ViewJob {
            input,
            output,
            from: None,
            single_file: false,
            decal: None,
            control: None,
            max_lod_bias: 4.0,
            target: None,
            limits: Limits::default(),
            exr_part: None,
            hdr_encoding: None,
            linear: false,
        }
    }

    /// The map the page shows and the engine whose mapping reads it: an `ibl` output folder's
    /// specular file (Bevy's, glTF's, Filament's, Babylon's, the generic one) with that
    /// engine, anything else as it is with `target`.
    fn shown(&self) -> (PathBuf, Option<Engine>) {
        if let Some((file, engine)) = crate::ibl::specular_of(&self.input) {
            return (file, self.target.or(engine));
        }
        (self.input.clone(), self.target)
    }

    /// The environment and the control map the page shows, and whether the input is a
    /// control map alone: then it is on the sphere, under the demo sky with a box chain (so
    /// its blur shows); anything else is the environment.
    fn environment(&self, input: &Path) -> Result<(preview::LoadedEnv, Option<PathBuf>, bool)> {
        let lone_control =
            self.control.is_none() && input.is_file() && preview::control_sidecar(input).is_some();
        if lone_control {
            let sky = crate::cube::CubeMap::from_fn(128, crate::synthetic::demo_sky);
            let env = preview::LoadedEnv {
                sampler: crate::cube::CubeSampler::with_box_mips(&sky.levels[0], None),
                files: Vec::new(),
                hdr: true,
                replaced_values: 0,
                levels: None,
            };
            return Ok((env, Some(input.to_path_buf()), true));
        }
        let opened = Input::open(&[input.to_path_buf()], self.from, &self.read())?;
        let (env, _) = preview::load_environment(&opened)?;
        Ok((env, self.control.clone(), false))
    }

    /// The decal and the control map (with its blur range), their files added to `inputs`.
    fn textures(
        &self,
        control: Option<&Path>,
        inputs: &mut Vec<PathBuf>,
    ) -> Result<(Option<Image>, Option<ControlMap>)> {
        let decal = match &self.decal {
            Some(p) => {
                inputs.push(p.clone());
                Some(preview::read_texture(p, false, &self.limits)?)
            }
            None => None,
        };
        let control = match control {
            Some(p) => {
                inputs.push(p.to_path_buf());
                let (img, max, side) = preview::read_control(p, self.max_lod_bias, &self.limits)?;
                inputs.extend(side);
                Some((img, max))
            }
            None => None,
        };
        Ok((decal, control))
    }

    fn read(&self) -> ReadOptions {
        ReadOptions {
            limits: self.limits,
            linear: self.linear,
            as_stored: false,
            exr_part: self.exr_part,
            exr_level: 0,
            hdr_encoding: self.hdr_encoding,
        }
    }
}

impl Job for ViewJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        if self.output == std::path::Path::new("-") {
            return Err(Error::usage(
                "-o - (standard output): view writes a page and its data; name a folder (or a .html file with --single-file)",
            ));
        }
        let html = self
            .output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("html"));
        if self.single_file && !html {
            return Err(Error::usage(format!(
                "--single-file writes one page: name it NAME.html (got {})",
                self.output.display()
            )));
        }
        if !self.single_file && html {
            return Err(Error::usage(format!(
                "{} is a page: give --single-file, or name a folder for index.html and its data",
                self.output.display()
            )));
        }
        Ok(Vec::new())
    }

    fn memory_estimate(&self) -> Result<u64> {
        let input = Input::open(
            std::slice::from_ref(&self.shown().0),
            self.from,
            &self.read(),
        )?;
        let face = input.face_size().unwrap_or(512) as u64;
        // The map, a GGX chain beside it, and their page data (half floats in base64, twice
        // over while the script is assembled).
        let levels = 64 - face.leading_zeros() as u64;
        // pbr's diffuse: the map's irradiance, and the cube of it the page reads.
        let irradiance = crate::filter::IrradianceLight::plan_bytes(
            face as usize,
            crate::filter::IRRADIANCE_LIGHT_SIZE,
        ) + 4 * view::data_bytes(view::IRRADIANCE_SIZE as u64, 1);
        Ok(input
            .plan_bytes()
            .saturating_mul(3)
            .saturating_add(4 * view::data_bytes(face, levels))
            .saturating_add(irradiance))
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        self.limits.check_memory(
            format_args!("view of {}", self.input.display()),
            self.memory_estimate()?,
        )?;
        let (input, target) = self.shown();
        let (env, control_path, lone_control) = self.environment(&input)?;
        let mut inputs = env.files.clone();
        let (decal, control) = self.textures(control_path.as_deref(), &mut inputs)?;
        progress.stage("decode");
        let mut summary_notes = Vec::new();
        let setup = pbr::prepare(&env, &input, target)?;
        if lone_control {
            summary_notes.push(format!(
                "{}: a control map: shown on the sphere under the demo sky (a box chain, so its blur shows)",
                input.display()
            ));
        }
        // (A lone control map's sky is the demo's: its pbr chain is no news.)
        if let Some(w) = setup.warning.as_ref().filter(|_| !lone_control) {
            warnings.push(w);
        }
        progress.stage("split-sum");
        let info = (!lone_control)
            .then(|| crate::info::describe(&input, self.from, &self.read()).ok())
            .flatten()
            .and_then(|r| serde_json::to_value(r).ok());
        let name = input
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut summary = std::mem::take(&mut summary_notes);
        if input != self.input {
            summary.push(format!(
                "{}: an ibl folder: showing {} with {}'s roughness mapping (material=pbr shows what the engine shades)",
                self.input.display(),
                input.display(),
                target.map_or("no engine", |e| e.name())
            ));
        }
        let extras = view::Extras {
            decal: decal.as_ref(),
            control: control.as_ref().map(|(img, max)| (img, *max)),
            info,
            name: name.clone(),
        };
        let scene = view::scene_script(&env, &setup, &extras);
        let files = Files::new(view::files(
            &self.output,
            self.single_file,
            &format!("{name} - cubeforge view"),
            scene,
        ));
        progress.stage("encode");
        output::deliver(&files, &Destination::Path(self.output.clone()), &inputs)?;
        progress.stage("write");
        let page = if self.single_file {
            self.output.clone()
        } else {
            self.output.join("index.html")
        };
        summary.push(format!(
            "open {} in a browser (from disk, or --serve); its query sets the view, as preview's options: ?material=glass&exposure=0&lod_bias=2",
            page.display()
        ));
        Ok(Report {
            written: files.paths(),
            warnings: warnings.into_vec(),
            summary: super::texts(summary),
            quality: None,
        })
    }

    fn limits_mut(&mut self) -> &mut Limits {
        &mut self.limits
    }
}
