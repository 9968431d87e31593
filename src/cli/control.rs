//! `cubeforge control`: bake a control map (reflectivity, transmittance, blur, Fresnel mask)
//! from a recipe.

use super::{warn, Stages};
use cubeforge::control::{self, Baked, Size};
use cubeforge::io::{self, ktx2, FileFormat, GpuFormat, Limits, WriteOptions};
use cubeforge::{Error, Result};
use std::path::{Path, PathBuf};

#[derive(clap::Args, Debug)]
#[command(after_long_help = RECIPE_HELP)]
pub struct Args {
    /// Recipe naming each parameter's source (.toml or .json; image paths relative to it).
    pub recipe: PathBuf,
    /// Output: .png (8-bit, or 16-bit with --png16), .exr (half float) or .ktx2 (with mips).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output size, WIDTHxHEIGHT or N for a square (default: the recipe's size, else its first image's).
    #[arg(long)]
    pub size: Option<Size>,
    /// Write 16-bit PNG instead of 8-bit.
    #[arg(long)]
    pub png16: bool,
    /// Texel format of KTX2 output (never sRGB: control maps hold data; all four channels).
    #[arg(long, value_enum, default_value_t = KtxFormat::Rgba8)]
    pub gpu_format: KtxFormat,
    /// Supercompress KTX2 output with Zstandard at LEVEL (1 to 22; 19 when no level is given,
    /// as in --zstd=19).
    #[arg(long, value_name = "LEVEL", num_args = 0..=1, require_equals = true, default_missing_value = "19", value_parser = clap::value_parser!(i32).range(1..=22))]
    pub zstd: Option<i32>,
    /// Mip levels in KTX2 output (default: the full chain down to 1x1).
    #[arg(long)]
    pub levels: Option<usize>,
    /// Refuse images with more pixels than this (checked before decoding).
    #[arg(long, default_value_t = Limits::default().max_pixels)]
    pub max_pixels: u64,
    /// Memory a command may plan to use, in bytes or with K, M, G (default: half the
    /// machine's memory, or of a container's limit or ulimit -v).
    #[arg(long, value_parser = super::bytes)]
    pub max_memory: Option<u64>,
}

const RECIPE_HELP: &str = "\
Channels hold linear data (never sRGB), each a fraction from 0 to 1: R = reflectivity, \
G = transmittance, B = blur (LOD bias = blur x max_lod_bias), A = Fresnel mask (1 where the \
Fresnel term applies). The recipe's [pack] table reassigns them (r, g, b, a = reflectivity, \
transmittance, blur, fresnel, zero or one). OUTPUT.json, written beside the map, records \
max_lod_bias and the packing.

Each parameter is a number or a table with one source: constant; image = { path, channel = \
r|g|b|a|luminance, srgb }; linear_gradient = { from, to }; radial_gradient = { center, radius }; \
checker = { cells }; stripes = { count, width, angle, offset }; noise = { cells, seed, octaves, \
persistence }. Optional operations, applied in this order: remap = { in, out, gamma }, \
invert = true, multiply = SOURCE, mix = { with = SOURCE, amount = SOURCE }. A missing image, an \
unknown key, channel or parameter, or a value outside [0, 1] is an error naming the recipe line.

Example recipe:
  size = \"512x512\"
  max_lod_bias = 6
  reflectivity = 0.9
  [blur]
  linear_gradient = { from = [0, 0], to = [0, 1] }
  remap = { in = [0.2, 0.8], gamma = 1.5 }
  [fresnel]
  checker = { cells = [8, 8] }
  invert = true";

/// KTX2 texel formats for data: RGBA, linear (the RGB-only HDR formats would drop the
/// Fresnel mask in alpha).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum KtxFormat {
    /// RGBA 8-bit UNORM.
    Rgba8,
    /// BC7 UNORM blocks: RGBA in 1 byte a texel (lossy; -v reports its PSNR).
    Bc7,
    /// RGBA half float.
    Rgba16f,
    /// RGBA 32-bit float.
    Rgba32f,
}

impl KtxFormat {
    fn gpu(self) -> GpuFormat {
        match self {
            KtxFormat::Rgba8 => GpuFormat::Rgba8,
            KtxFormat::Bc7 => GpuFormat::Bc7,
            KtxFormat::Rgba16f => GpuFormat::Rgba16f,
            KtxFormat::Rgba32f => GpuFormat::Rgba32f,
        }
    }
}

pub fn run(a: Args, verbose: bool) -> Result<()> {
    let mut stages = Stages::new(verbose);
    let limits = super::limits(a.max_pixels, a.max_memory);
    // Check the options before reading anything.
    let format = match FileFormat::from_extension(&a.output) {
        Some(f @ (FileFormat::Png | FileFormat::Exr | FileFormat::Ktx2)) => f,
        _ => {
            return Err(Error::file(
                &a.output,
                "a control map is written as .png, .exr or .ktx2",
            ))
        }
    };
    if a.png16 && format != FileFormat::Png {
        return Err(Error::usage("--png16 applies to PNG output only"));
    }
    if a.levels.is_some() && format != FileFormat::Ktx2 {
        return Err(Error::usage("--levels applies to KTX2 output only"));
    }
    if a.zstd.is_some() && format != FileFormat::Ktx2 {
        return Err(io::zstd_needs_ktx2(&a.output));
    }
    let sidecar_path = sidecar_path(&a.output);

    let recipe = control::load(&a.recipe, &limits)?;
    stages.done("read");
    let mut inputs = vec![a.recipe.clone()];
    inputs.extend(recipe.images().iter().map(|f| f.path.clone()));
    // Never over the recipe or an image it reads.
    cubeforge::output::refuse_inputs(&[a.output.clone(), sidecar_path.clone()], &inputs)?;

    let size = recipe
        .output_size(a.size)
        .map_err(|e| Error::file(&a.recipe, e.to_string()))?;
    let full_chain = cubeforge::cube::CubeMap::full_chain_len(size.width.max(size.height));
    if let Some(n) = a.levels {
        if n == 0 || n > full_chain {
            return Err(Error::usage(format!(
                "--levels {n}: a {size} map has 1 to {full_chain} levels"
            )));
        }
    }
    // Say where an oversized size came from: the option, the recipe's line, or its image.
    let (w, h) = (size.width as u64, size.height as u64);
    if w.max(h) > limits.max_dimension as u64 || w * h > limits.max_pixels {
        let from = match (a.size, recipe.size_line) {
            (Some(_), _) => "--size".to_string(),
            (None, Some(l)) => format!("{}: line {l}", a.recipe.display()),
            (None, None) => format!("{}: its first image", a.recipe.display()),
        };
        return Err(Error::usage(format!(
            "{from}: a {size} map is over the limit of {} pixels, {} per side (--max-pixels)",
            limits.max_pixels, limits.max_dimension
        )));
    }
    // The baked map, its sources at output size and the mip chain, RGBA f32.
    limits.check_memory(
        format_args!("{}: a {size} map", a.recipe.display()),
        size.width as u64 * size.height as u64 * 16 * 4,
    )?;
    let baked = recipe.bake(Some(size), &limits)?;
    stages.done("bake");

    let (bytes, what) = match format {
        FileFormat::Ktx2 => {
            let levels = baked.image.mip_chain(a.levels.unwrap_or(full_chain));
            let gpu = a.gpu_format.gpu();
            let mut what = format!("KTX2 {} with {} mip levels", gpu.name(), levels.len());
            if let Some(z) = a.zstd {
                what.push_str(&format!(", Zstandard level {z}"));
            }
            let bytes = ktx2::encode_2d_with(&levels, gpu, a.zstd)
                .map_err(|e| Error::file(&a.output, e))?;
            if gpu.is_lossy() {
                stages.quality(gpu, io::container_psnr(&bytes, gpu, &[&levels[0]]));
            }
            (bytes, what)
        }
        FileFormat::Exr => (
            io::encode_image(&a.output, &baked.image, &WriteOptions::default())?,
            "half-float EXR".to_string(),
        ),
        _ => {
            let write = WriteOptions {
                linear: true,
                png16: a.png16,
                ..WriteOptions::default()
            };
            let bits = if a.png16 { 16 } else { 8 };
            (
                io::encode_image(&a.output, &baked.image, &write)?,
                format!("{bits}-bit PNG"),
            )
        }
    };
    let name = a
        .output
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut sidecar = serde_json::to_vec_pretty(&baked.sidecar(&name))
        .map_err(|e| Error::file(&sidecar_path, e.to_string()))?;
    sidecar.push(b'\n');
    stages.done("encode");
    super::write_files(&[(a.output.clone(), bytes), (sidecar_path.clone(), sidecar)])?;
    stages.done("write");

    report(&a.output, &sidecar_path, &baked, &what)?;
    stages.total();
    Ok(())
}

/// `mask.png` -> `mask.png.json`.
fn sidecar_path(output: &Path) -> PathBuf {
    let mut s = output.as_os_str().to_owned();
    s.push(".json");
    PathBuf::from(s)
}

/// Level 0 and each half-size level after it, `count` in all.
fn report(output: &Path, sidecar: &Path, baked: &Baked, what: &str) -> Result<()> {
    for w in &baked.warnings {
        warn(w);
    }
    super::report(format_args!(
        "{}: {}x{} control map, {what}, linear data",
        output.display(),
        baked.image.width,
        baked.image.height
    ))?;
    for (c, ch) in ["R", "G", "B", "A"].iter().zip(&baked.channels) {
        let note = if ch.holds == control::Slot::Blur && baked.max_lod_bias > 0.0 {
            format!(" (lod bias = blur x {})", baked.max_lod_bias)
        } else {
            String::new()
        };
        super::report(format_args!(
            "  {c} = {:<13} {}{note}",
            ch.holds.name(),
            ch.source
        ))?;
    }
    super::report(format_args!(
        "{}: max_lod_bias {} and the packing",
        sidecar.display(),
        baked.max_lod_bias
    ))
}
