//! `control` as a job: bake a control map from a recipe, with the sidecar that records its
//! packing.

use super::{Job, Progress, Quality, Report, Warning, Warnings};
use crate::control::{self, Size};
use crate::cube::CubeMap;
use crate::error::{param, Error, Result};
use crate::image::Image;
use crate::io::{self, ktx2, FileFormat, GpuFormat, Limits};
use crate::output::{self, Destination, Encoding, Files};
use std::path::{Path, PathBuf};

/// Bakes a control map (reflectivity, transmittance, blur, Fresnel mask) from a recipe into
/// .png, .exr or .ktx2 (with mips), and `OUTPUT.json` beside it.
#[derive(Clone, Debug)]
pub struct ControlJob {
    /// The recipe (.toml or .json; image paths relative to it).
    pub recipe: PathBuf,
    /// The map written.
    pub output: PathBuf,
    /// Output size (None: the recipe's, else its first image's).
    pub size: Option<Size>,
    /// How the map is stored: 16-bit PNG, the KTX2 texel format (rgba8 by default; bc7,
    /// rgba16f or rgba32f: data, never sRGB) and its supercompression, the EXR sample type.
    pub encoding: Encoding,
    /// Mip levels of KTX2 output (None: the full chain).
    pub levels: Option<usize>,
    /// Limits on the recipe's images and the memory budget.
    pub limits: Limits,
}

impl ControlJob {
    /// Bakes `recipe` into `output` with every option at its default.
    pub fn new(recipe: PathBuf, output: PathBuf) -> ControlJob {
        ControlJob {
            recipe,
            output,
            size: None,
            encoding: Encoding::default(),
            levels: None,
            limits: Limits::default(),
        }
    }

    fn format(&self) -> Result<FileFormat> {
        super::lut::table_format(&self.output, "a control map", self.encoding.png16)
    }

    /// The KTX2 texel format: linear RGBA8 unless the encoding names another.
    fn gpu_format(&self) -> GpuFormat {
        self.encoding.gpu_format.unwrap_or(GpuFormat::Rgba8)
    }

    /// `mask.png` -> `mask.png.json`.
    pub fn sidecar_path(&self) -> PathBuf {
        sidecar_path(&self.output)
    }

    /// Refuses a level count the map cannot have and a size over the limits, saying where the
    /// size came from: the option, the recipe's line (`size_line`), or its first image.
    fn check_size(&self, size: Size, full_chain: usize, size_line: Option<usize>) -> Result<()> {
        let limits = &self.limits;
        if let Some(n) = self.levels {
            if n == 0 || n > full_chain {
                return Err(Error::usage(format!(
                    "{} {n}: a {size} map has 1 to {full_chain} levels",
                    param("levels")
                )));
            }
        }
        // Say where an oversized size came from: the option, the recipe's line, or its image.
        let (w, h) = (size.width as u64, size.height as u64);
        if w.max(h) > limits.max_dimension as u64 || w * h > limits.max_pixels {
            let from = match (self.size, size_line) {
                (Some(_), _) => param("size"),
                (None, Some(l)) => format!("{}: line {l}", self.recipe.display()),
                (None, None) => format!("{}: its first image", self.recipe.display()),
            };
            return Err(Error::usage(format!(
                "{from}: a {size} map is over the limit of {} pixels, {} per side ({})",
                limits.max_pixels,
                limits.max_dimension,
                param("max_pixels")
            )));
        }
        Ok(())
    }

    /// The map's bytes in `format`, what they are (for the summary) and a lossy format's
    /// quality.
    fn encode(
        &self,
        format: FileFormat,
        image: &Image,
        full_chain: usize,
    ) -> Result<(Vec<u8>, String, Option<Quality>)> {
        let mut quality = None;
        // Data, not colour: no sRGB encode.
        let write = self.encoding.write_options(true);
        let (bytes, what) = match format {
            FileFormat::Ktx2 => {
                let levels = image.mip_chain(self.levels.unwrap_or(full_chain));
                let gpu = self.gpu_format();
                let mut what = format!("KTX2 {} with {} mip levels", gpu.name(), levels.len());
                if let Some(z) = self.encoding.zstd {
                    what.push_str(&format!(", Zstandard level {z}"));
                }
                let bytes = ktx2::encode_2d_with(&levels, gpu, self.encoding.zstd, &[])
                    .map_err(|e| Error::file(&self.output, e))?;
                if gpu.is_lossy() {
                    quality =
                        io::container_psnr(&bytes, gpu, &[&levels[0]]).map(|psnr_db| Quality {
                            format: gpu,
                            psnr_db,
                        });
                }
                (bytes, what)
            }
            FileFormat::Exr => (
                crate::output::encode_image_as(format, &self.output, image, &write)?,
                "half-float EXR".to_string(),
            ),
            _ => {
                let bits = if self.encoding.png16 { 16 } else { 8 };
                (
                    crate::output::encode_image_as(format, &self.output, image, &write)?,
                    format!("{bits}-bit PNG"),
                )
            }
        };
        Ok((bytes, what, quality))
    }
}

impl Job for ControlJob {
    fn validate(&self) -> Result<Vec<Warning>> {
        let format = self.format()?;
        if self.levels.is_some() && format != FileFormat::Ktx2 {
            return Err(Error::usage(format!(
                "{} applies to KTX2 output only",
                param("levels")
            )));
        }
        if self.encoding.zstd.is_some() && format != FileFormat::Ktx2 {
            return Err(io::zstd_needs_ktx2(&self.output));
        }
        if !matches!(
            self.gpu_format(),
            GpuFormat::Rgba8 | GpuFormat::Bc7 | GpuFormat::Rgba16f | GpuFormat::Rgba32f
        ) {
            return Err(Error::usage(format!(
                "{} {}: control maps are rgba8, bc7, rgba16f or rgba32f (linear RGBA)",
                param("gpu_format"),
                self.gpu_format().name()
            )));
        }
        Ok(Vec::new())
    }

    /// The baked map, its sources at output size and the mip chain, RGBA f32 (the recipe is
    /// read for its size; its images are checked one by one as they are decoded).
    fn memory_estimate(&self) -> Result<u64> {
        let recipe = control::load(&self.recipe, &self.limits)?;
        let size = recipe
            .output_size(self.size)
            .map_err(|e| Error::file(&self.recipe, e.to_string()))?;
        Ok(size.width as u64 * size.height as u64 * 16 * 4)
    }

    fn run(&self, progress: &dyn Progress) -> Result<Report> {
        let mut warnings = Warnings::new(progress);
        warnings.extend(self.validate()?);
        let format = self.format()?;
        let limits = &self.limits;
        let sidecar_path = self.sidecar_path();
        let recipe = control::load(&self.recipe, limits)?;
        progress.stage("read");
        let mut inputs = vec![self.recipe.clone()];
        inputs.extend(recipe.images().iter().map(|f| f.path.clone()));
        // Never over the recipe or an image it reads.
        output::refuse_inputs(&[self.output.clone(), sidecar_path.clone()], &inputs)?;

        let size = recipe
            .output_size(self.size)
            .map_err(|e| Error::file(&self.recipe, e.to_string()))?;
        let full_chain = CubeMap::full_chain_len(size.width.max(size.height));
        self.check_size(size, full_chain, recipe.size_line)?;
        let (w, h) = (size.width as u64, size.height as u64);
        limits.check_memory(
            format_args!("{}: a {size} map", self.recipe.display()),
            w * h * 16 * 4,
        )?;
        let baked = recipe.bake(Some(size), limits)?;
        progress.stage("bake");

        let (bytes, what, quality) = self.encode(format, &baked.image, full_chain)?;
        let name = self
            .output
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut sidecar = serde_json::to_vec_pretty(&baked.sidecar(&name))
            .map_err(|e| Error::file(&sidecar_path, e.to_string()))?;
        sidecar.push(b'\n');
        progress.stage("encode");
        let files = Files::new(vec![
            (self.output.clone(), bytes),
            (sidecar_path.clone(), sidecar),
        ]);
        output::deliver(&files, &Destination::Path(self.output.clone()), &inputs)?;
        progress.stage("write");
        for w in &baked.warnings {
            warnings.push(w);
        }
        let mut summary = vec![format!(
            "{}: {}x{} control map, {what}, linear data",
            self.output.display(),
            baked.image.width,
            baked.image.height
        )];
        for (c, ch) in ["R", "G", "B", "A"].iter().zip(&baked.channels) {
            let note = if ch.holds == control::Slot::Blur && baked.max_lod_bias > 0.0 {
                format!(" (lod bias = blur x {})", baked.max_lod_bias)
            } else {
                String::new()
            };
            summary.push(format!(
                "  {c} = {:<13} {}{note}",
                ch.holds.name(),
                ch.source
            ));
        }
        summary.push(format!(
            "{}: max_lod_bias {} and the packing",
            sidecar_path.display(),
            baked.max_lod_bias
        ));
        Ok(Report {
            written: files.paths(),
            warnings: warnings.into_vec(),
            summary: super::texts(summary),
            quality,
        })
    }

    fn limits_mut(&mut self) -> &mut crate::io::Limits {
        &mut self.limits
    }
}

/// `mask.png` -> `mask.png.json`.
fn sidecar_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}
