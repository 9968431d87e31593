//! `cubeforge control`: bake a control map (reflectivity, transmittance, blur, Fresnel mask)
//! from a recipe.

use cubeforge::internals::control::Size;
use cubeforge::internals::io::GpuFormat;
use cubeforge::{ControlJob, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES, after_long_help = format!("{RECIPE_HELP}\n\n{EXAMPLES}"))]
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
    #[command(flatten)]
    pub zstd: super::ZstdArg,
    /// Mip levels in KTX2 output (default: the full chain down to 1x1).
    #[arg(long)]
    pub levels: Option<usize>,
    #[command(flatten)]
    pub limits: super::LimitArgs,
}

const RECIPE_HELP: &str = "\
Channels hold linear data (never sRGB), each a fraction from 0 to 1: R = reflectivity, \
G = transmittance, B = blur (LOD bias = blur x max_lod_bias), A = Fresnel mask (1 where the \
Fresnel term applies). The recipe's [pack] table reassigns them (r, g, b, a = reflectivity, \
transmittance, blur, fresnel, zero or one). OUTPUT.json, written beside the map, records \
max_lod_bias and the packing.

A recipe (TOML, or JSON) gives each parameter a number or a table with one source \
(constant, image, linear_gradient, radial_gradient, checker, stripes, noise) and optional \
operations (remap, invert, multiply, mix). A missing image, an unknown key, channel or \
parameter, or a value outside [0, 1] is an error naming the recipe line. The recipe \
reference: docs/control-maps.md in the repository.";

/// Printed after the options (`-h`, `--help`, the man page); tests/it/help_examples.rs
/// runs every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples:
  # recipes to start from: fixtures/control/ in the repository
  cubeforge control recipe.toml -o control.png
  # a 2D KTX2 texture with its mip chain, BC7 blocks, Zstandard
  cubeforge control recipe.toml -o control.ktx2 --gpu-format bc7 --zstd
  # another size than the recipe's
  cubeforge control recipe.toml -o control_wide.exr --size 1024x512";

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

/// The library job these flags describe (what `run` runs, and what a batch manifest builds).
pub fn job(a: Args) -> Result<ControlJob> {
    let job = ControlJob {
        size: a.size,
        encoding: cubeforge::Encoding {
            png16: a.png16,
            gpu_format: Some(a.gpu_format.gpu()),
            zstd: a.zstd.zstd,
            ..Default::default()
        },
        levels: a.levels,
        limits: a.limits.limits(),
        ..ControlJob::new(a.recipe, a.output)
    };
    Ok(job)
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    let output = a.output.clone();
    super::execute(job(a)?, &output, verbose, depfile)
}
