//! `cubeforge control`: bake a control map (reflectivity, transmittance, blur, Fresnel mask)
//! from a recipe.

use cubeforge::control::Size;
use cubeforge::io::{GpuFormat, Limits};
use cubeforge::{ControlJob, Job, Result};
use std::path::PathBuf;

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
    let job = ControlJob {
        size: a.size,
        png16: a.png16,
        gpu_format: a.gpu_format.gpu(),
        zstd: a.zstd,
        levels: a.levels,
        limits: super::limits(a.max_pixels, a.max_memory),
        ..ControlJob::new(a.recipe, a.output)
    };
    let observer = super::Observer::new(verbose);
    let report = job.run(&observer)?;
    observer.report(&report)
}
