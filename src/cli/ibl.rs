//! `cubeforge ibl`: the files an engine loads for image-based lighting, in one command.

use super::Stages;
use cubeforge::convert;
use cubeforge::ibl::{self, Engine, IblOptions};
use cubeforge::io::GpuFormat;
use cubeforge::Result;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
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
    /// Texel format of the KTX2 files (default: the target's).
    #[arg(long, value_enum)]
    pub gpu_format: Option<GpuFormat>,
    /// Supercompress the KTX2 files with Zstandard at LEVEL (1 to 22; 19 when no level is
    /// given, as in --zstd=19): Bevy (its default `zstd` feature), three.js and KTX-Software
    /// inflate it on load.
    #[arg(long, value_name = "LEVEL", num_args = 0..=1, require_equals = true, default_missing_value = "19", value_parser = clap::value_parser!(i32).range(1..=22))]
    pub zstd: Option<i32>,
    /// Turn the environment about +Y first, degrees (90 brings +Z to +X).
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub yaw: f32,
    /// gltf: also write the Charlie (sheen) chain.
    #[arg(long)]
    pub sheen: bool,
    #[command(flatten)]
    pub input: super::InputArgs,
}

pub fn run(a: Args, verbose: bool) -> Result<()> {
    let mut stages = Stages::new(verbose);
    if a.output == std::path::Path::new("-") {
        return Err(cubeforge::Error::usage(
            "-o - (standard output) takes one file, and ibl writes several (a specular chain, a diffuse map, tables): name a folder",
        ));
    }
    let read = a.input.read_options();
    // The whole plan against the budget before any file is decoded: the input, the
    // specular chain (and the sheen chain), the diffuse map.
    let plan = cubeforge::chain::plan(&a.inputs, a.input.from, &read)?;
    let defaults = ibl::engines::defaults(a.target);
    let size = a.size.map_or(defaults.specular_size as u64, u64::from);
    let diffuse = a
        .diffuse_size
        .map_or(defaults.diffuse_size as u64, u64::from);
    let face = |n: u64| 6 * 16 * n * n;
    // Each chain: the base faces, the chain (4/3 of them), a bordered sampler copy and the
    // encoding; the diffuse map: its faces, the encoding and a sampler copy.
    let chains = if a.sheen { 2 } else { 1 };
    a.input.limits().check_memory(
        format_args!("--size {size} and --diffuse-size {diffuse}"),
        (chains * 4 * face(size))
            .saturating_add(3 * face(diffuse))
            .saturating_add(plan.working_bytes()),
    )?;
    let loaded = convert::load_planned(&a.inputs, a.input.from, &read)?;
    stages.done("decode");
    let opts = IblOptions {
        name: Some(a.name.clone()),
        specular_size: a.size.map(|v| v as usize),
        min_size: a.min_size.map(|v| v as usize),
        diffuse_size: a.diffuse_size.map(|v| v as usize),
        samples: a.samples,
        gpu_format: a.gpu_format,
        zstd: a.zstd,
        sheen: a.sheen,
        yaw: a.yaw,
    };
    let stages_cell = std::sync::Mutex::new(&mut stages);
    let delivery = ibl::deliver(&loaded, a.target, &a.output, &opts, &|s| {
        if let Ok(mut st) = stages_cell.lock() {
            st.done(s);
        }
    })?;
    if let Some(w) = &delivery.clamped {
        super::warn(w);
    }
    if let Some(f) = a.gpu_format {
        stages.quality(f, delivery.psnr);
    }
    super::write_files(&delivery.files)?;
    stages.done("write");
    for (p, bytes) in &delivery.files {
        super::report(format_args!("{} ({} bytes)", p.display(), bytes.len()))?;
    }
    super::report(&delivery.snippet)?;
    stages.total();
    Ok(())
}
