//! `cubeforge prefilter`: mip chains for blurred and glossy reflections.

use super::Stages;
use cubeforge::chain::LevelsFile;
use cubeforge::convert;
use cubeforge::filter::{self, ChainOptions, FilterKind, LevelInfo, LightingModel};
use cubeforge::io::{self, FileFormat, GpuFormat, WriteOptions};
use cubeforge::output;
use cubeforge::resample::Resampler;
use cubeforge::{Error, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
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
    /// Number of levels (default: the full chain down to 1 x 1).
    #[arg(long)]
    pub levels: Option<usize>,
    /// Stop the chain at the level whose faces are N texels (the smallest at least N); the
    /// roughness m / (levels - 1) then reaches 1 there. Filament stops at 16: a 1 x 1 rough
    /// level shows the cube's corners at a high LOD bias.
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
    /// Texel format of KTX2 and DDS output.
    #[arg(long, value_enum, default_value_t = GpuFormat::Rgba16f)]
    pub gpu_format: GpuFormat,
    /// Supercompress KTX2 output with Zstandard at LEVEL (1 to 22; 19 when no level is given,
    /// as in --zstd=19). Readers inflate it on load (three.js, Bevy, KTX-Software); DDS has none.
    #[arg(long, value_name = "LEVEL", num_args = 0..=1, require_equals = true, default_missing_value = "19", value_parser = clap::value_parser!(i32).range(1..=22))]
    pub zstd: Option<i32>,
    #[command(flatten)]
    pub input: super::InputArgs,
}

pub fn run(mut a: Args, verbose: bool) -> Result<()> {
    let mut stages = Stages::new(verbose);
    let (output, to_stdout) = super::container_output(&a.output, Some(&a.format))?;
    a.output = output;
    if to_stdout {
        a.format = "exr".into();
    }
    let container = FileFormat::from_extension(&a.output).filter(|f| f.is_container());
    if container.is_none() && a.output.extension().is_some() && !a.output.is_dir() {
        return Err(Error::file(
            &a.output,
            "prefilter writes a .ktx2 or .dds cube map, or a folder (no extension)",
        ));
    }
    let face_format = FileFormat::from_ext_str(&a.format)
        .filter(|f| !f.is_container())
        .ok_or_else(|| {
            Error::usage(format!(
                "--format {}: use exr, hdr, png, tga or jpg",
                a.format
            ))
        })?;
    match container {
        Some(FileFormat::Ktx2) => {}
        Some(_) if a.zstd.is_some() => return Err(io::zstd_needs_ktx2(&a.output)),
        _ if a.zstd.is_some() => super::warn("--zstd applies to KTX2 outputs: ignored"),
        _ => {}
    }
    if a.samples == 0 {
        return Err(Error::usage("--samples must be at least 1"));
    }
    if container.is_none() {
        // A folder output is replaced whole: refuse one that is not cubeforge's before the work.
        output::check_folder_output(&a.output, &a.inputs, &[])?;
    }
    let read = a.input.read_options();
    if let Some(size) = a.size.filter(|&n| n == 0 || n > 16384) {
        return Err(Error::usage(format!("--size {size}: use 1 to 16384")));
    }
    // The whole plan against the budget before any file is decoded.
    let plan = cubeforge::chain::plan(&a.inputs, a.input.from, &read)?;
    if let Some(size) = a.size.or(plan.face_size) {
        check_memory(&a.input.limits(), size, plan.working_bytes())?;
    }
    let loaded = convert::load_planned(&a.inputs, a.input.from, &read)?;
    stages.done("decode");
    if loaded.meta.replaced_values > 0 {
        super::warn(format!(
            "{}: replaced {} NaN, infinite or negative values by 0 (and values above 1e28 by 1e28)",
            loaded.files[0].display(),
            loaded.meta.replaced_values
        ));
    }
    let size = a.size.unwrap_or_else(|| loaded.face_size());
    if size == 0 || size > 16384 {
        return Err(Error::usage(format!("--size {size}: use 1 to 16384")));
    }
    if let Some(min) = a.min_size.filter(|&m| m as usize > size) {
        return Err(Error::usage(format!(
            "--min-size {min} is larger than level 0, whose faces are {size} px"
        )));
    }
    check_memory(&a.input.limits(), size, loaded.working_bytes())?;
    let base = convert::to_cube(&loaded, size, &Resampler::default());
    stages.done("resample");

    let opts = ChainOptions {
        filter: a.filter,
        levels: a.levels,
        min_size: a.min_size.map(|m| m as usize),
        samples: a.samples,
        gloss_scale: a.gloss_scale,
        gloss_bias: a.gloss_bias,
        lighting: a.lighting,
    };
    let plan = filter::plan(&opts, size);
    // An exact sum costs about what 64 samples do.
    let per_texel = |i: &LevelInfo| match (i.samples, i.power.or(i.sigma)) {
        (Some(s), _) => s as u64,
        (None, Some(_)) => 64,
        _ => 1,
    };
    let cost = |i: &LevelInfo| (6 * i.size * i.size) as u64 * per_texel(i);
    let total: u64 = plan.iter().map(|(i, _)| cost(i)).sum();
    let bar = super::progress(total, format!("{} {size}", a.filter.name()));
    let costs: Vec<u64> = plan.iter().map(|(i, _)| cost(i)).collect();
    let (chain, infos) = filter::prefilter(&base, &opts, &|level| {
        if let Some(b) = &bar {
            b.inc(costs[level]);
        }
    });
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    stages.done("filter");

    let description = LevelsFile::new(&opts, size, infos);
    let write = WriteOptions {
        linear: a.input.linear,
        zstd: a.zstd.filter(|_| container == Some(FileFormat::Ktx2)),
        ..WriteOptions::default()
    };
    let encoded = cubeforge::chain::encode(
        &a.output,
        &chain,
        &description,
        face_format,
        &write,
        a.gpu_format,
        &loaded.files,
    )?;
    if let Some(w) = &encoded.clamped {
        super::warn(w);
    }
    stages.quality(a.gpu_format, encoded.psnr);
    stages.done("encode");
    let mut files = encoded.files;
    if to_stdout && files.len() > 1 {
        // A DDS chain's description goes beside it: there is no beside on standard output.
        super::warn(
            "-o -: the DDS chain's levels description (NAME.dds.levels.json) is not written",
        );
        files.truncate(1);
    }
    super::deliver(&files, &encoded.folders, to_stdout)?;
    stages.done("write");
    for i in &description.levels {
        let what = match (i.roughness, i.power, i.sigma) {
            (Some(r), _, _) => format!("roughness {r:.3} (alpha {:.4})", r * r),
            (_, Some(p), _) => format!("power {p:.1}"),
            (_, _, Some(s)) => format!("sigma {:.5} rad ({:.3} deg)", s, s.to_degrees()),
            _ => "2x2 box mean".to_string(),
        };
        let samples = match (i.samples, i.power.or(i.sigma)) {
            (Some(s), _) => format!(", {s} samples"),
            // A narrow cosine or Gaussian lobe: summed over the texels it covers.
            (None, Some(_)) => ", exact sum".to_string(),
            _ => String::new(),
        };
        super::report(format_args!(
            "level {:2}  {:5} px  {what}{samples}",
            i.level, i.size
        ))?;
    }
    if let (Some(min), Some(last)) = (a.min_size, description.levels.last()) {
        super::report(format_args!(
            "stopped at {} px (--min-size {min}): {} levels instead of {}",
            last.size,
            description.levels.len(),
            cubeforge::cube::CubeMap::full_chain_len(size)
        ))?;
    }
    stages.total();
    Ok(())
}

/// The plan's memory: the base faces, the chain (4/3 of them), a bordered sampler copy and
/// the encoding, beside the input's texels and pyramid (`input` bytes).
fn check_memory(limits: &io::Limits, size: usize, input: u64) -> Result<()> {
    limits.check_memory(
        format_args!("--size {size}"),
        (6 * 16 * 4 * (size as u64).pow(2)).saturating_add(input),
    )
}
