//! `cubeforge lut`: the BRDF lookup tables a split-sum shader samples beside the prefiltered
//! chain.

use super::Stages;
use cubeforge::io::{self, ktx2, FileFormat, GpuFormat, WriteOptions};
use cubeforge::lut::{self, LutOptions};
use cubeforge::{Error, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_long_help = LAYOUT_HELP)]
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
    /// Memory the table may plan to use, in bytes or with K, M, G (default: half the
    /// machine's memory, or of a container's limit or ulimit -v).
    #[arg(long, value_parser = super::bytes)]
    pub max_memory: Option<u64>,
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

pub fn run(a: Args, verbose: bool) -> Result<()> {
    let mut stages = Stages::new(verbose);
    let format = match FileFormat::from_extension(&a.output) {
        Some(f @ (FileFormat::Png | FileFormat::Exr | FileFormat::Ktx2)) => f,
        _ => {
            return Err(Error::file(
                &a.output,
                "a lookup table is written as .png, .exr or .ktx2",
            ))
        }
    };
    if a.png16 && format != FileFormat::Png {
        return Err(Error::usage("--png16 applies to PNG output only"));
    }
    let size = a.size as usize;
    // The table (RGBA f32), its encoding and a KTX2's mip chain, before any work.
    super::limits(u64::MAX, a.max_memory)
        .check_memory(format_args!("--size {size}"), (size as u64).pow(2) * 16 * 3)?;
    let opts = LutOptions {
        multiscatter: a.multiscatter,
        samples: a.samples,
    };
    let (table, what) = if a.charlie {
        (
            lut::charlie(size, &opts),
            "Charlie sheen table (E in R, G, B)",
        )
    } else if a.multiscatter {
        (
            lut::dfg(size, &opts),
            "multiscatter DFG table (R = DFG1, G = DFG2)",
        )
    } else {
        (lut::dfg(size, &opts), "DFG table (R = scale, G = bias)")
    };
    stages.done("integrate");

    let (bytes, encoding) = match format {
        FileFormat::Ktx2 => (
            ktx2::encode_2d(std::slice::from_ref(&table), GpuFormat::Rgba16f),
            "KTX2 RGBA16F".to_string(),
        ),
        FileFormat::Exr => (
            io::encode_image(&a.output, &table, &WriteOptions::default())?,
            "half-float EXR".to_string(),
        ),
        _ => {
            let above = io::count_out_of_range([&table], 1.0);
            if above > 0 {
                super::warn(format_args!(
                    "{}: {above} values above 1 written as 1 (PNG holds 0 to 1); .exr or .ktx2 keep them",
                    a.output.display()
                ));
            }
            let write = WriteOptions {
                linear: true,
                png16: a.png16,
                ..WriteOptions::default()
            };
            let bits = if a.png16 { 16 } else { 8 };
            (
                io::encode_image(&a.output, &table, &write)?,
                format!("{bits}-bit PNG, linear"),
            )
        }
    };
    if format != FileFormat::Png {
        if let Some(w) = io::clamp_warning(&a.output, format, GpuFormat::Rgba16f, [&table]) {
            super::warn(w);
        }
    }
    stages.done("encode");
    super::write_files(&[(a.output.clone(), bytes)])?;
    stages.done("write");
    super::report(format_args!(
        "{}: {size}x{size} {what}, {} samples a texel, {encoding}; x = n.v, y = roughness, roughness 0 in the top row",
        a.output.display(),
        a.samples
    ))?;
    stages.total();
    Ok(())
}
