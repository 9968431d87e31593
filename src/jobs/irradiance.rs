//! `irradiance` as a job: the diffuse side, an irradiance map and 9 SH coefficients.

use super::{Job, Progress, Quality, Report, Warning, Warnings};
use crate::convert::{self, Loaded, MapKind};
use crate::error::{param, Error, Result};
use crate::filter::sh_bands::{self, ShSet, ShWindow};
use crate::filter::{self, sh, IrradianceMethod};
use crate::input::Input;
use crate::io::ReadOptions;
use crate::layout::Kind;
use crate::output::{self, Destination, Encoding, Target};
use crate::resample::Resampler;
use std::path::PathBuf;

/// The largest face edge of an irradiance map (it holds no detail).
const MOST: usize = 4096;

/// The base faces the integral reads: 256 hold everything the integral and the SH can see.
const BASE: usize = 256;

/// A Lambertian irradiance map (any layout or container) and, optionally, its 9 SH
/// coefficients as JSON.
#[derive(Clone, Debug)]
pub struct IrradianceJob {
    /// Anything [`crate::ConvertJob`] reads.
    pub inputs: Vec<PathBuf>,
    /// Where the map goes.
    pub output: Destination,
    /// The input's layout (None: from the aspect ratio).
    pub from: Option<Kind>,
    /// The map's layout or container (None: from the output's name).
    pub to: Option<MapKind>,
    /// Face edge of the map.
    pub size: usize,
    /// Where the SH coefficients go (None: not written).
    pub sh: Option<PathBuf>,
    /// Exact integral or the SH coefficients.
    pub method: IrradianceMethod,
    /// Bands of the SH coefficients, 1 to 5 (3, nine coefficients, by default).
    pub sh_bands: usize,
    /// cmgen's windowing of the coefficients (none by default).
    pub sh_window: ShWindow,
    /// How the map is stored (faces EXR unless it says otherwise), and its exposure and
    /// tone curve for 8-bit outputs (the exposure scales the SH coefficients too).
    pub encoding: Encoding,
    /// Limits and colour handling of the inputs.
    pub read: ReadOptions,
}

impl IrradianceJob {
    /// An irradiance map of `inputs` at `output`, 32 px, exact.
    pub fn new(inputs: Vec<PathBuf>, output: Destination) -> IrradianceJob {
        IrradianceJob {
            inputs,
            output,
            from: None,
            to: None,
            size: 32,
            sh: None,
            method: IrradianceMethod::Brute,
            sh_bands: 3,
            sh_window: ShWindow::None,
            encoding: Encoding::default(),
            read: ReadOptions::default(),
        }
    }

    /// The map's output: one level, faces EXR unless the encoding says otherwise.
    fn target(&self) -> Result<Target> {
        let mut target =
            self.encoding
                .resolve(&self.output.name(), self.to, Some(true), self.read.linear)?;
        target.levels = Some(1);
        Ok(target)
    }

    /// The input, the base faces it is resampled to, the map (faces, encoding, a sampler
    /// copy).
    fn plan_bytes(&self, input_face: Option<usize>, input: u64) -> u64 {
        let base = input_face.unwrap_or(BASE).min(BASE) as u64;
        let face = |n: u64| 6 * 16 * n * n;
        let texels = 6 * (self.size as u64).pow(2);
        (2 * face(base) + 3 * face(self.size as u64))
            .saturating_add(self.encoding.plan_bytes(texels))
            .saturating_add(input)
    }
}

impl Job for IrradianceJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        let name = self.output.name();
        if self.output.is_stdout() && self.sh.is_some() {
            return Err(Error::usage(format!(
                "-o - (standard output) takes one file: write the {} coefficients with -o FILE",
                param("sh")
            )));
        }
        let target = self.target()?;
        if target.kind == MapKind::Layout(Kind::Faces) {
            // Replaced whole: refuse a folder that is not cubeforge's before the work.
            output::check_folder_output(&name, &self.inputs, self.sh.as_slice())?;
        }
        let mut warnings = target.warnings;
        if !(1..=sh_bands::MAX_BANDS).contains(&self.sh_bands) {
            return Err(Error::usage(format!(
                "{} {}: use 1 to {}",
                param("sh_bands"),
                self.sh_bands,
                sh_bands::MAX_BANDS
            )));
        }
        let sh_default = self.sh_bands == 3 && self.sh_window == ShWindow::None;
        if !sh_default && self.sh.is_none() && self.method != IrradianceMethod::Sh {
            warnings.push(Warning::new(format!(
                "{} and {} shape the SH coefficients, and nothing uses them: add {} FILE.json or {} sh",
                param("sh_bands"),
                param("sh_window"),
                param("sh"),
                param("method")
            )));
        }
        if self.size == 0 || self.size > MOST {
            return Err(Error::usage(format!(
                "{} {}: use 1 to {MOST}",
                param("size"),
                self.size
            )));
        }
        Ok(warnings)
    }

    fn memory_estimate(&self) -> Result<u64> {
        let input = Input::open(&self.inputs, self.from, &self.read)?;
        Ok(self.plan_bytes(input.face_size(), input.plan_bytes()))
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        let target = self.target()?;
        // The whole plan against the budget before any file is decoded.
        let input = Input::open(&self.inputs, self.from, &self.read)?;
        self.read.limits.check_memory_for(
            input.paths().first().map(PathBuf::as_path),
            format_args!("{} {}", param("size"), self.size),
            self.plan_bytes(input.face_size(), input.plan_bytes()),
        )?;
        let (loaded, notes) = input.load()?;
        progress.stage("decode");
        for w in notes {
            warnings.push(w);
        }
        if let Some(w) = super::display_referred(&loaded) {
            warnings.push(w);
        }
        let base_size = loaded.face_size().min(BASE);
        let base = convert::to_cube(&loaded, base_size, &Resampler::default());
        progress.stage("resample");
        progress.start(6 * self.size as u64, &format!("irradiance {}", self.size));
        let set = ShSet::project(&base.levels[0], self.sh_bands)?.windowed(self.sh_window);
        let irr = match self.method {
            IrradianceMethod::Brute => {
                filter::brute_irradiance_with_progress(&base, self.size, &|n| progress.advance(n))
            }
            IrradianceMethod::Sh => {
                let over_pi = set.irradiance_over_pi();
                crate::cube::CubeMap::from_fn(self.size, |d| sh_bands::eval(&over_pi, d))
            }
        };
        progress.finish();
        progress.stage("filter");

        let out = convert::convert_fixed(
            &Loaded::from_cube(irr),
            target.kind.layout(),
            self.size,
            &Resampler::default(),
            self.encoding.edge_fixup,
        );
        let encoded = target.encode(out, &loaded.files)?;
        if let Some(w) = &encoded.clamped {
            warnings.push(w);
        }
        let quality = encoded.psnr.map(|psnr_db| Quality {
            format: target.write.gpu_format,
            psnr_db,
        });
        let mut files = encoded.into_files();
        // The exposure scales the map as it is written, and the coefficients here.
        let k = f64::from(self.encoding.exposure).exp2();
        let set = set.scaled(k);
        if let Some(p) = &self.sh {
            let json = serde_json::to_vec_pretty(&sh_bands::ShFile::from_set(&set))
                .map_err(|e| Error::usage(e.to_string()))?;
            files.files.push((p.clone(), json));
        }
        progress.stage("encode");
        output::deliver(&files, &self.output, &loaded.files)?;
        progress.stage("write");
        let dc = set.radiance[0].map(|v| v * sh::BASIS[0].3);
        let mut summary: Vec<String> = super::wrote(&files, &self.output).into_iter().collect();
        summary.push(format!(
            "irradiance {} px ({}); mean radiance {:.4} {:.4} {:.4}{}",
            self.size,
            match self.method {
                filter::IrradianceMethod::Brute => "exact sum over the texels".to_string(),
                filter::IrradianceMethod::Sh =>
                    format!("from {} SH coefficients", set.radiance.len()),
            },
            dc[0],
            dc[1],
            dc[2],
            match (&self.sh, set.cutoff) {
                (None, None) => String::new(),
                (_, Some(c)) =>
                    format!("; SH {} bands, windowed to zero at band {c:.2}", set.bands),
                (Some(_), None) => format!("; SH {} bands", set.bands),
            }
        ));
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
