//! `cubeforge lut`: the BRDF lookup tables a split-sum shader samples beside the prefiltered
//! chain.

use cubeforge::internals::jobs::LutKind;
use cubeforge::internals::lut;
use cubeforge::{LutJob, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES, after_long_help = format!("{LAYOUT_HELP}\n\n{EXAMPLES}"))]
pub struct Args {
    /// Output: .png (8-bit, or 16-bit with --png16), .exr (half float) or .ktx2 (RGBA16F).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Table edge, texels (n.v across, roughness down).
    #[arg(value_parser = clap::value_parser!(u32).range(2..=4096), long, default_value_t = lut::DEFAULT_SIZE as u32)]
    pub size: u32,
    /// Filament's multiscatter layout: R = DFG1 (bias), G = DFG2 (scale + bias).
    #[arg(long, conflicts_with = "charlie")]
    pub multiscatter: bool,
    /// The Charlie sheen table (Khronos lut_charlie.png) instead of the GGX one.
    #[arg(long)]
    pub charlie: bool,
    /// Hammersley samples per texel.
    #[arg(value_parser = clap::value_parser!(u32).range(1..=65536), long, default_value_t = lut::DEFAULT_SAMPLES)]
    pub samples: u32,
    /// Write 16-bit PNG instead of 8-bit.
    #[arg(long)]
    pub png16: bool,
    #[command(flatten)]
    pub memory: super::MemoryArg,
}

const LAYOUT_HELP: &str = "\
Layout: column x holds n.v = (x + 0.5) / size, row y perceptual roughness (y + 0.5) / size, \
row 0 (roughness 0) at the top of the image and first in memory: sample at uv = (n.v, \
roughness) with no flip, as the Khronos glTF Sample Viewer's lut_ggx.png and Filament's \
dfg.inc. Channels are linear data. GGX (height-correlated Smith, Schlick Fresnel): R = scale, \
G = bias, specular = F0 * R + F90 * G. --multiscatter: R = DFG1, G = DFG2, \
specular = mix(R, G, F0), energy compensation 1 + F0 * (1 / G - 1). --charlie: the sheen \
albedo E in R, G and B (the Sample Viewer reads B); above 1 at grazing n.v and low roughness, \
which PNG clamps (use .exr or .ktx2 to keep it).";

/// Printed after the options (`-h`, `--help`, the man page); tests/it/help_examples.rs
/// runs every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples:
  # GGX DFG (R scale, G bias), 16-bit, laid out as lut_ggx.png
  cubeforge lut -o dfg.png --png16
  # Filament's multiscatter DFG, half float
  cubeforge lut -o dfg_multiscatter.exr --multiscatter
  # the Charlie sheen table, half float (PNG clamps it at 1)
  cubeforge lut -o charlie.exr --charlie";

/// The library job these flags describe (what `run` runs, and what a batch manifest builds).
pub fn job(a: Args) -> Result<LutJob> {
    let job = LutJob {
        kind: if a.charlie {
            LutKind::Charlie
        } else if a.multiscatter {
            LutKind::Multiscatter
        } else {
            LutKind::Dfg
        },
        size: a.size as usize,
        samples: a.samples,
        encoding: cubeforge::Encoding {
            png16: a.png16,
            ..Default::default()
        },
        limits: super::limits(u64::MAX, a.memory.max_memory),
        ..LutJob::new(a.output)
    };
    Ok(job)
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    let output = a.output.clone();
    super::execute(job(a)?, &output, verbose, depfile)
}
