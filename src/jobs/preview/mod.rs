//! `preview` as a job: a material (or a contact sheet of several) on a sphere lit by an
//! environment map, with the programs of The Cg Tutorial, chapter 7, and split-sum PBR.

use super::{Job, Progress, Report, Warning, Warnings};
use crate::error::{param, Error, Result};
use crate::ibl::{self, Engine};
use crate::image::Image;
use crate::input::Input;
use crate::io::{self, FileFormat, Limits, ReadOptions, WriteOptions};
use crate::layout::Kind;
use crate::output::{self, Destination, Files};
use crate::preview::material::{self, Material, Model};
use crate::preview::sun::Sun;
use crate::preview::{self, pbr, Options};
use crate::tonemap::Tonemap;
use std::path::PathBuf;

mod cells;

/// A preview picture: `material` (or each of `grid`) on the unit sphere, lit by `env`.
///
/// ```
/// use cubeforge::{Destination, Job, PreviewJob};
///
/// # fn main() -> cubeforge::Result<()> {
/// let out = std::env::temp_dir().join("cubeforge-doc-glass.png");
/// let mut job = PreviewJob::new("fixtures/sky.exr".into(), Destination::Path(out.clone()));
/// job.material = "glass".into();
/// job.view.size = 32;
/// job.run(&())?;
/// # std::fs::remove_file(&out).ok();
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct PreviewJob {
    /// The environment: anything [`crate::ConvertJob`] reads, or a prefiltered chain.
    pub env: PathBuf,
    /// The picture (.png .jpg .tga tone-mapped, .exr .hdr linear), or standard output.
    pub output: Destination,
    /// The environment's layout (None: from the aspect ratio).
    pub from: Option<Kind>,
    /// A preset or a .toml material file (the one swept by the roughness, metallic and bias
    /// grids).
    pub material: String,
    /// A contact sheet of several materials (presets or files).
    pub grid: Vec<String>,
    /// A contact sheet of `material` at several LOD biases.
    pub grid_bias: Vec<f32>,
    /// A contact sheet of a pbr `material` at several roughness values (one row).
    pub grid_roughness: Vec<f32>,
    /// ... and several metallic values (one row each).
    pub grid_metallic: Vec<f32>,
    /// Camera, shading, parallax, samples and background ([`PreviewJob::default_samples`]).
    pub view: Options,
    /// Decal texture on the sphere's (u, v), over the materials' own decal colours.
    pub decal: Option<PathBuf>,
    /// A control map from [`crate::ControlJob`].
    pub control: Option<PathBuf>,
    /// The LOD bias a control map's blur of 1 means when its sidecar does not say.
    pub max_lod_bias: f32,
    /// Exposure (stops) and tone curve for tone-mapped outputs; linear ones (EXR, HDR) are
    /// scaled by the exposure alone.
    pub tone: (f32, Tonemap),
    /// pbr materials: read the chain with this engine's roughness mapping.
    pub target: Option<Engine>,
    /// pbr materials: the map's sun taken out and shone as a directional light
    /// ([`crate::internals::preview::sun`]), as `ibl --sun` hands it to an engine.
    pub sun: bool,
    /// Limits on the inputs and the memory budget.
    pub limits: Limits,
}

impl PreviewJob {
    /// Chrome at 512 px, 4 samples a pixel for tone-mapped outputs, 1 for linear ones.
    pub fn new(env: PathBuf, output: Destination) -> PreviewJob {
        let samples = Self::default_samples(&output);
        PreviewJob {
            env,
            output,
            from: None,
            material: "chrome".into(),
            grid: Vec::new(),
            grid_bias: Vec::new(),
            grid_roughness: Vec::new(),
            grid_metallic: Vec::new(),
            view: Options {
                samples,
                ..Options::default()
            },
            decal: None,
            control: None,
            max_lod_bias: 4.0,
            tone: (0.0, Tonemap::None),
            target: None,
            sun: false,
            limits: Limits::default(),
        }
    }

    /// Samples per pixel by default: 4 for tone-mapped outputs (edges smoothed), 1 for
    /// linear ones (each pixel the radiance through its centre).
    pub fn default_samples(output: &Destination) -> usize {
        if tone_mapped(output) {
            4
        } else {
            1
        }
    }

    /// The materials (one, or a grid's), resolved.
    fn materials(&self) -> Result<Vec<Material>> {
        let specs: Vec<&String> = if self.grid.is_empty() {
            vec![&self.material]
        } else {
            self.grid.iter().collect()
        };
        specs
            .iter()
            .map(|s| material::resolve(s.trim(), self.limits.session))
            .collect()
    }

    /// Pictures in the sheet.
    fn cells(&self) -> u64 {
        self.grid
            .len()
            .max(self.grid_bias.len())
            .max(self.grid_roughness.len().max(1) * self.grid_metallic.len().max(1)) as u64
    }

    /// The environment opened from its headers.
    fn input(&self) -> Result<Input> {
        Input::open(std::slice::from_ref(&self.env), self.from, &self.read())
    }

    fn read(&self) -> ReadOptions {
        ReadOptions {
            limits: self.limits,
            linear: false,
            as_stored: false,
            ..Default::default()
        }
    }

    /// The pbr options: sweeps of a pbr material with values in [0, 1], a target that applies.
    fn check_pbr(&self, materials: &[Material]) -> Result<()> {
        let sweeps = [
            ("grid_roughness", &self.grid_roughness),
            ("grid_metallic", &self.grid_metallic),
        ];
        for (name, values) in sweeps {
            if values.is_empty() {
                continue;
            }
            if materials[0].model != Model::Pbr {
                return Err(Error::usage(format!(
                    "{} needs a pbr material (pbr, gold, copper, plastic-glossy, plastic-rough or a file with model = \"pbr\"); \"{}\" has model \"{}\"",
                    param(name),
                    materials[0].name,
                    materials[0].model.name()
                )));
            }
            if let Some(v) = values.iter().find(|v| !(0.0..=1.0).contains(*v)) {
                return Err(Error::usage(format!(
                    "{} values must be between 0 and 1 (got {v})",
                    param(name)
                )));
            }
        }
        let lit = [(self.sun, "sun"), (self.view.ground, "ground")];
        if let (Some(m), Some((_, flag))) = (
            materials.iter().find(|m| m.model != Model::Pbr),
            lit.iter().find(|(on, _)| *on),
        ) {
            return Err(Error::usage(format!(
                "{} needs pbr materials, which the light shades (pbr, gold, copper, plastic-glossy, plastic-rough or a file with model = \"pbr\"); \"{}\" has model \"{}\"",
                param(flag),
                m.name,
                m.model.name()
            )));
        }
        if let Some(e) = self.target {
            if !materials.iter().any(|m| m.model == Model::Pbr) {
                return Err(Error::usage(format!(
                    "{} picks the roughness mapping a pbr material reads the chain with; the material is not pbr",
                    param("target")
                )));
            }
            if ibl::panorama::filters_itself(e) {
                return Err(Error::usage(format!(
                    "{} {}: that engine prefilters the panorama itself, with a mapping of its own; use bevy, gltf, babylon, filament or generic",
                    param("target"),
                    e.name()
                )));
            }
        }
        Ok(())
    }
}

/// Whether the picture is stored in 8 bits (tone-mapped) rather than linear.
fn tone_mapped(output: &Destination) -> bool {
    FileFormat::from_extension(&output.name())
        .is_some_and(|f| io::largest_value(f, Default::default()).is_none())
}

impl PreviewJob {
    /// Everything that can be checked before anything is read, in the order the errors are
    /// reported; the materials resolved on the way (a material file is read once a run).
    fn checked(&self) -> Result<(Vec<Warning>, Vec<Material>)> {
        let name = self.output.name();
        let mut warnings = Vec::new();
        match FileFormat::from_extension(&name) {
            Some(f) if f.is_container() => {
                return Err(Error::file(
                    &name,
                    format!(
                        "the preview is an image: name it {}",
                        FileFormat::list(FileFormat::is_image, true)
                    ),
                ))
            }
            Some(_) => {
                // A linear picture takes the exposure (radiance scaled), not the curve.
                if !tone_mapped(&self.output) && self.tone.1 != Tonemap::None {
                    warnings.push(Warning::new(output::tone_ignored(&name)));
                }
            }
            None => return Err(io::unknown_ext(&name)),
        }
        let materials = self.materials()?;
        self.check_pbr(&materials)?;
        self.view.validate()?;
        if !(self.max_lod_bias >= 0.0 && self.max_lod_bias.is_finite()) {
            return Err(Error::usage(format!(
                "{} must be a number >= 0",
                param("max_lod_bias")
            )));
        }
        // The picture (every cell of a grid) against the pixel limit, before anything is read.
        let size = self.view.size as u64;
        let pixels = size.saturating_mul(size) * self.cells();
        if pixels > self.limits.max_pixels {
            return Err(Error::usage(format!(
                "{} {} makes {pixels} pixels, over the limit of {} ({})",
                param("size"),
                self.view.size,
                self.limits.max_pixels,
                param("max_pixels")
            )));
        }
        Ok((warnings, materials))
    }

    /// Each cell's picture and its samples' buffers, RGBA f32, beside the environment as its
    /// headers describe it (its decode's peak too) and the textures on the sphere (the
    /// largest one's decode on top).
    fn estimate_with(&self, env: &Input, materials: &[Material]) -> Result<u64> {
        let read = self.read();
        let mut input = env.plan_bytes();
        if self.sun {
            // The faces the sun is taken out of and the sampler made from them: about the
            // input's bytes again.
            input = input.saturating_mul(2);
        }
        let mut textures: Vec<&PathBuf> = self.decal.iter().chain(&self.control).collect();
        if self.decal.is_none() {
            textures.extend(materials.iter().filter_map(|m| m.decal.as_ref()));
        }
        textures.sort();
        textures.dedup();
        let mut peak = 0u64;
        for t in textures {
            if let Some(c) = io::claim(t, &read)? {
                input = input.saturating_add(c.held_bytes);
                peak = peak.max(c.decode_bytes - c.held_bytes.min(c.decode_bytes));
            }
        }
        if materials.iter().any(|m| m.model == Model::Pbr) {
            // The diffuse light: the map's irradiance and the copies it is summed from.
            let face = env.face_size().unwrap_or(pbr::PREFILTER_MAX_SIZE);
            input = input.saturating_add(crate::filter::IrradianceLight::plan_bytes(
                face,
                crate::filter::IRRADIANCE_LIGHT_SIZE,
            ));
        }
        let size = self.view.size as u64;
        let pixels = size.saturating_mul(size) * self.cells();
        Ok(pixels
            .saturating_mul(16 * 3)
            .saturating_add(input.saturating_add(peak)))
    }
}

impl Job for PreviewJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        Ok(self.checked()?.0)
    }

    fn memory_estimate(&self) -> Result<u64> {
        let materials = self.materials()?;
        self.estimate_with(&self.input()?, &materials)
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        let (checked, materials) = self.checked()?;
        warnings.extend(checked);
        let input = self.input()?;
        self.limits.check_memory_for(
            input.paths().first().map(|p| p.as_path()),
            format_args!("{} {}", param("size"), self.view.size),
            self.estimate_with(&input, &materials)?,
        )?;
        let (env, notes) = preview::load_environment(&input)?;
        let (env, sun) = self.take_sun(env, progress, &mut warnings);
        for w in notes {
            warnings.push(w);
        }
        let mut inputs: Vec<PathBuf> = env.files.clone();
        let textures = cells::load_textures(self, &materials, progress, &mut inputs)?;
        progress.stage("decode");
        let split_sum = if materials.iter().any(|m| m.model == Model::Pbr) {
            let mut setup = pbr::prepare(&env, &self.env, self.target)?;
            setup.split_sum = setup.split_sum.with_sun(sun.as_ref().map(Sun::from));
            if let Some(w) = &setup.warning {
                warnings.push(w);
            }
            progress.stage("split-sum");
            progress.note(&setup.note);
            Some(setup)
        } else {
            None
        };
        if let Some(w) = cells::without_chain(self, &env, &materials, &textures) {
            warnings.push(w);
        }
        let img = cells::render(
            self,
            &materials,
            &env,
            split_sum.as_ref(),
            &textures,
            progress,
        )?;
        progress.stage("render");
        let name = self.output.name();
        if let Some(f) = FileFormat::from_extension(&name) {
            if let Some(w) = io::clamp_warning(&name, f, Default::default(), [&img]) {
                warnings.push(w);
            }
        }
        let files = Files::new(vec![(name.clone(), encode(&name, &img)?)]);
        progress.stage("encode");
        output::deliver(&files, &self.output, &inputs)?;
        progress.stage("write");
        Ok(Report {
            written: files.paths(),
            warnings: warnings.into_vec(),
            summary: super::texts(super::wrote(&files, &self.output).into_iter().collect()),
            quality: None,
        })
    }

    fn limits_mut(&mut self) -> &mut crate::io::Limits {
        &mut self.limits
    }
}

impl PreviewJob {
    /// With `sun`, the map's sun taken out of `env` and returned as a light (a warning when
    /// the map has none); else `env` as it is.
    fn take_sun(
        &self,
        env: preview::LoadedEnv,
        progress: &dyn Progress,
        warnings: &mut Warnings<'_>,
    ) -> (preview::LoadedEnv, Option<crate::flux::sun::Light>) {
        if !self.sun {
            return (env, None);
        }
        let (env, light) = preview::sun::take_out(env);
        progress.stage("sun");
        match &light {
            Some(l) => progress.note(&format!(
                "{}: the sun towards ({:.4}, {:.4}, {:.4}), irradiance ({:.4}, {:.4}, {:.4}), taken out of the map and shone as a directional light",
                self.env.display(),
                l.direction.x,
                l.direction.y,
                l.direction.z,
                l.irradiance[0],
                l.irradiance[1],
                l.irradiance[2]
            )),
            None => warnings.push(format!(
                "{}: --sun: the map has no sun (no compact light holds {:.0}% of the light facing it): rendered with the map alone",
                self.env.display(),
                crate::flux::sun::MIN_SHARE * 100.0
            )),
        }
        (env, light)
    }
}

fn encode(name: &std::path::Path, img: &Image) -> Result<Vec<u8>> {
    crate::output::encode_image(name, img, &WriteOptions::default())
}
