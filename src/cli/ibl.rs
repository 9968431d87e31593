//! `cubeforge ibl`: the files an engine loads for image-based lighting, in one command.

use cubeforge::internals::ibl::{Engine, IblOptions};
use cubeforge::internals::io::GpuFormat;
use cubeforge::{IblJob, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Anything `convert` reads: a panorama, six faces, a folder of faces, a cube map.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Folder that receives the engine's files (made if missing).
    #[arg(short, long)]
    pub output: PathBuf,
    /// The engine whose files to write.
    #[arg(long, value_enum)]
    pub target: Engine,
    /// File names start with this (env_specular.ktx2, ...).
    #[arg(long, default_value = "env")]
    pub name: String,
    /// Face edge of the specular chain's first level (default: the target's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub size: Option<u32>,
    /// The specular chain stops at this face edge (default: the target's; Filament 16).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub min_size: Option<u32>,
    /// Face edge of the diffuse (irradiance) cube map (default: the target's).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=8192))]
    pub diffuse_size: Option<u32>,
    /// Importance samples per texel at the sharpest filtered level (doubled per level after it).
    #[arg(value_parser = clap::value_parser!(u32).range(1..=65536), long)]
    pub samples: Option<u32>,
    /// Texel format of the KTX2 files (default: the target's; astc-hdr-4x4 for phones with
    /// bevy, gltf, generic and godot, whose panorama it writes as a 2D KTX2; uastc-hdr-4x4
    /// adds a 2D KTX2 panorama to three's files, for its KTX2Loader).
    #[arg(long, value_enum)]
    pub gpu_format: Option<GpuFormat>,
    #[command(flatten)]
    pub zstd: super::ZstdArg,
    #[command(flatten)]
    pub keys: super::out::CubeforgeKeysArg,
    /// Turn the environment about +Y first, degrees (90 brings +Z to +X).
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub yaw: f32,
    /// gltf: also write the Charlie (sheen) chain.
    #[arg(long)]
    pub sheen: bool,
    /// Take the sun out of the maps (replaced by the sky around it) and add a directional
    /// light in its place to the snippet, with sun.json beside the files (a map with no sun:
    /// the maps as they are, no light).
    #[arg(long)]
    pub sun: bool,
    #[command(flatten)]
    pub exposure: super::ExposureArg,
    #[command(flatten)]
    pub exr: super::ExrArg,
    #[command(flatten)]
    pub input: super::InputArgs,
}

/// Printed after the options (`-h`, `--help`, the man page); tests/it/help_examples.rs
/// runs every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples:
  # Bevy (EnvironmentMapLight): env_specular.ktx2, env_diffuse.ktx2
  cubeforge ibl panorama.hdr -o bevy/ --target bevy
  # glTF Sample Viewer: env_ggx.ktx2, env_lambertian.ktx2, lut_ggx.png;
  # --sheen adds env_charlie.ktx2 and lut_charlie.png
  cubeforge ibl panorama.hdr -o gltf/ --target gltf --sheen
  # Babylon.js: env.env
  cubeforge ibl panorama.hdr -o babylon/ --target babylon
  # Filament: env_ibl.ktx, env_irradiance.ktx, env_skybox.ktx, sh.txt
  cubeforge ibl panorama.hdr -o filament/ --target filament
  # Godot 4, Unity, Unreal: a panorama the engine filters itself
  cubeforge ibl panorama.hdr -o godot/ --target godot
  cubeforge ibl panorama.hdr -o unity/ --target unity
  cubeforge ibl panorama.hdr -o unreal/ --target unreal
  # three.js: env.jpg (UltraHDR, for UltraHDRLoader) and env.hdr, 1024 x 512 or wider
  cubeforge ibl panorama.hdr -o three/ --target three
  # no engine in particular: KTX2 chains, SH as JSON, a DFG table
  cubeforge ibl panorama.hdr -o generic/ --target generic";

/// The library job these flags describe (what `run` runs, and what a batch manifest builds).
pub fn job(a: Args) -> Result<IblJob> {
    let job = IblJob {
        from: a.input.from,
        options: IblOptions {
            name: Some(a.name),
            specular_size: a.size.map(|v| v as usize),
            min_size: a.min_size.map(|v| v as usize),
            diffuse_size: a.diffuse_size.map(|v| v as usize),
            samples: a.samples,
            encoding: cubeforge::Encoding {
                gpu_format: a.gpu_format,
                zstd: a.zstd.zstd,
                exr_float: a.exr.exr_float,
                exposure: a.exposure.exposure,
                cubeforge_keys: a.keys.cubeforge_keys,
                ..Default::default()
            },
            sheen: a.sheen,
            yaw: a.yaw,
            sun: a.sun,
        },
        read: a.input.read_options(&a.inputs)?,
        ..IblJob::new(a.inputs, a.output, a.target)
    };
    Ok(job)
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    let output = a.output.clone();
    super::execute(job(a)?, &output, verbose, depfile)
}
