//! `cubeforge prefilter`: mip chains for blurred and glossy reflections.

use cubeforge::internals::filter::{self, ChainOptions, FilterKind, LightingModel};
use cubeforge::internals::io::{FileFormat, GpuFormat};
use cubeforge::{Destination, Error, PrefilterJob, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Anything `convert` reads: one image, six faces, or a folder of faces.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// A .ktx2 or .dds cube map with every level, a folder that receives m{level}/{face}.EXT
    /// and levels.json (replacing what it held whole), or - for standard output (with
    /// --format ktx2, dds, ktx or env).
    #[arg(short, long)]
    pub output: PathBuf,
    /// box: plain mipmaps; gaussian: LOD-bias blur; cosine: Phong lobes (cmft); ggx: split-sum
    /// GGX radiance; charlie: sheen radiance (the Khronos glTF-IBL-Sampler's Charlie chain).
    #[arg(long, value_enum)]
    pub filter: FilterKind,
    /// Face edge of level 0 (default: the input's).
    #[arg(long)]
    pub size: Option<usize>,
    /// Number of levels (default: down to 16 x 16 faces; see --min-size).
    #[arg(long)]
    pub levels: Option<usize>,
    /// Stop the chain at the level whose faces are N texels (the smallest at least N); the
    /// roughness m / (levels - 1) then reaches 1 there. Default 16, as Filament: a 1 x 1 rough
    /// level shows the cube's corners at a high LOD bias. 1 makes the full chain.
    #[arg(value_parser = clap::value_parser!(u32).range(1..=16384), long, value_name = "N", conflicts_with = "levels")]
    pub min_size: Option<u32>,
    /// Importance samples per texel at the sharpest filtered level (charlie: 4 times as many,
    /// its lobe is a ring); doubled per level after it (wider lobes), up to 32 times.
    #[arg(value_parser = clap::value_parser!(u32).range(1..=65536), long, default_value_t = filter::DEFAULT_SAMPLES)]
    pub samples: u32,
    /// cosine: specular power = 2^(gloss-scale * glossiness + gloss-bias), as cmft.
    #[arg(value_parser = super::gloss_scale, long, default_value_t = 10.0)]
    pub gloss_scale: f32,
    /// cosine: see --gloss-scale.
    #[arg(value_parser = super::gloss_bias, long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub gloss_bias: f32,
    /// cosine: cmft's lighting model (phongbrdf: power + 1, blinn: power / 4, blinnbrdf: / 4 + 1).
    #[arg(long, value_enum, default_value_t = LightingModel::Phong)]
    pub lighting: LightingModel,
    /// File type of the level images in a folder output (default exr); with -o -, the
    /// container written to standard output (ktx2, dds, ktx, env).
    #[arg(long, default_value = "exr")]
    pub format: String,
    /// Texel format of KTX2 and DDS output (default rgba16f).
    #[arg(long, value_enum)]
    pub gpu_format: Option<GpuFormat>,
    #[command(flatten)]
    pub zstd: super::ZstdArg,
    #[command(flatten)]
    pub exr: super::ExrArg,
    #[command(flatten)]
    pub exposure: super::ExposureArg,
    #[command(flatten)]
    pub fixup: super::out::EdgeFixupArg,
    #[command(flatten)]
    pub hdr8: super::out::HdrEncodingArg,
    #[command(flatten)]
    pub keys: super::out::CubeforgeKeysArg,
    #[command(flatten)]
    pub input: super::InputArgs,
}

/// Printed after the options (`-h`, `--help`, the man page); tests/it/help_examples.rs
/// runs every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples:
  # split-sum GGX radiance: level m of L holds roughness m / (L - 1)
  cubeforge prefilter panorama.hdr -o ggx.ktx2 --filter ggx --size 256
  # a blurry chain for LOD-bias lookups
  cubeforge prefilter panorama.hdr -o blur.ktx2 --filter gaussian --size 256
  # cmft's cosine-power lobes into a folder: m0/px.exr ... levels.json
  cubeforge prefilter panorama.hdr -o cosine/ --filter cosine";

/// The library job these flags describe (what `run` runs, and what a batch manifest builds).
pub fn job(a: Args) -> Result<PrefilterJob> {
    let output = super::destination(&a.output, Some(&a.format), FileFormat::is_container)?;
    let face_format = match output {
        Destination::Stdout(_) => FileFormat::Exr,
        Destination::Path(_) => FileFormat::from_ext_str(&a.format).ok_or_else(|| {
            Error::usage(format!(
                "--format {}: use {}",
                a.format,
                FileFormat::list(FileFormat::is_image, false)
            ))
        })?,
    };
    let out = super::out::CubeOutput {
        gpu_format: a.gpu_format,
        zstd: &a.zstd,
        exr: &a.exr,
        fixup: &a.fixup,
        hdr8: &a.hdr8,
        keys: &a.keys,
    };
    let encoding = out.encoding(face_format, a.exposure.exposure);
    let job = PrefilterJob {
        from: a.input.from,
        size: a.size,
        chain: ChainOptions {
            filter: a.filter,
            levels: a.levels,
            min_size: a.min_size.map(|m| m as usize),
            samples: a.samples,
            gloss_scale: a.gloss_scale,
            gloss_bias: a.gloss_bias,
            lighting: a.lighting,
        },
        encoding,
        read: a.input.read_options(&a.inputs)?,
        ..PrefilterJob::new(a.inputs, output)
    };
    Ok(job)
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    let output = a.output.clone();
    super::execute(job(a)?, &output, verbose, depfile)
}
