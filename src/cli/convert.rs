//! `cubeforge convert`: any layout to any other.

use super::{warn, Stages};
use cubeforge::convert;
use cubeforge::cube::{CubeMap, Interp};
use cubeforge::io::{self, FileFormat, GpuFormat, WriteOptions};
use cubeforge::layout::Kind;
use cubeforge::output::{self, Target};
use cubeforge::resample::{Orientation, Resampler};
use cubeforge::{Error, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    /// One image; six face images in px nx py ny pz nz order; or a folder of px/nx/... faces.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output file, folder for --to faces, or - for standard output (with --format).
    #[arg(short, long, allow_hyphen_values = true)]
    pub output: PathBuf,
    /// Output layout (default: from the output's extension; hcross for images, faces for a folder).
    #[arg(long, value_enum)]
    pub to: Option<Kind>,
    /// Cube face edge in texels (equirect output is 4N x 2N; sphere, angular and octahedral
    /// 2N x 2N).
    #[arg(long)]
    pub size: Option<usize>,
    /// File type of face images (png, jpg, tga, hdr, exr; default exr for HDR input, png for
    /// LDR), or of the output written to standard output (-o -; also ktx2, dds).
    #[arg(long)]
    pub format: Option<String>,
    /// Interpolation between input texels.
    #[arg(long, value_enum, default_value_t = Interp::Bilinear)]
    pub interp: Interp,
    /// Turn off supersampling of coarse outputs (faster, aliases when shrinking).
    #[arg(long)]
    pub no_antialias: bool,
    /// Rotate the environment about +Y, degrees (90 brings the old centre +Z to +X).
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub yaw: f32,
    /// Rotate the environment about +X, degrees.
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub pitch: f32,
    /// Rotate the environment about +Z, degrees.
    #[arg(value_parser = super::angle, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub roll: f32,
    /// Flip handedness (mirror X) for engines with the other convention.
    #[arg(long)]
    pub mirror: bool,
    /// Write 16-bit PNG instead of 8-bit.
    #[arg(long)]
    pub png16: bool,
    /// Texel format of KTX2 and DDS output (default rgba16f; bc6h and bc7 are block
    /// compressed, rgb9e5 and rg11b10 packed HDR in 4 bytes).
    #[arg(long, value_enum)]
    pub gpu_format: Option<GpuFormat>,
    /// Supercompress KTX2 output with Zstandard at LEVEL (1 to 22; 19 when no level is given,
    /// as in --zstd=19). Readers inflate it on load (three.js, Bevy, KTX-Software); DDS has none.
    #[arg(long, value_name = "LEVEL", num_args = 0..=1, require_equals = true, default_missing_value = "19", value_parser = clap::value_parser!(i32).range(1..=22))]
    pub zstd: Option<i32>,
    /// Mip levels in KTX2 and DDS output (default: the full chain down to 1x1).
    #[arg(long)]
    pub levels: Option<usize>,
    /// Which level of a KTX2 or DDS mip chain (or which mN folder of a prefiltered chain) to
    /// read; 0 is the full size.
    #[arg(long, default_value_t = 0)]
    pub level: usize,
    #[command(flatten)]
    pub tone: super::ToneArgs,
    #[command(flatten)]
    pub input: super::InputArgs,
}

pub fn run(mut a: Args, verbose: bool) -> Result<()> {
    let mut stages = Stages::new(verbose);
    let (output, to_stdout) = super::output_name(&a.output, a.format.as_deref())?;
    a.output = output;
    let limits = a.input.limits();
    let read = a.input.read_options();
    // The output's layout and type, and the options it ignores, before the decode.
    let mut target = Target::new(&a.output, a.to, false)?;
    let to = target.kind;
    let container = to.is_container();
    if !container {
        if a.levels.is_some() {
            warn("--levels applies to KTX2 and DDS outputs: ignored");
        }
        if a.gpu_format.is_some() {
            warn("--gpu-format applies to KTX2 and DDS outputs: ignored");
        }
        if a.zstd.is_some() {
            warn("--zstd applies to KTX2 outputs: ignored");
        }
    } else if to == Kind::Dds && a.zstd.is_some() {
        return Err(io::zstd_needs_ktx2(&a.output));
    }
    if a.levels == Some(0) {
        return Err(Error::usage("--levels 0: a map has at least 1 level"));
    }
    if to == Kind::Faces && a.to.is_none() && a.output.extension().is_none() && !a.output.exists() {
        warn(format!(
            "{}: no file extension, so six faces go into this new folder (--to faces)",
            a.output.display()
        ));
    }
    let face_format = match (to, &a.format) {
        (Kind::Faces, Some(f)) => Some(output::face_format(f)?),
        _ => None,
    };
    // The whole plan against the budget before any file is decoded: the input as the
    // headers describe it, the output at the size it will have.
    if let Some(n) = a.size.filter(|&n| n > limits.max_dimension as usize) {
        return Err(Error::usage(format!(
            "--size {n}: over the size limit of {} px per side",
            limits.max_dimension
        )));
    }
    let plan = cubeforge::chain::plan_level(&a.inputs, a.input.from, &read, a.level)?;
    if let Some(size) = a.size.or(plan.face_size).filter(|&s| s > 0) {
        check_memory(&limits, to, size, plan.working_bytes())?;
    }
    let loaded = cubeforge::chain::load_level_planned(&a.inputs, a.input.from, &read, a.level)?;
    stages.done("decode");
    if loaded.meta.replaced_values > 0 {
        warn(format!(
            "{}: replaced {} NaN, infinite or negative values by 0 (and values above 1e28 by 1e28)",
            loaded.files[0].display(),
            loaded.meta.replaced_values
        ));
    }
    let size = a.size.unwrap_or_else(|| loaded.face_size());
    if size == 0 {
        return Err(Error::usage("--size must be at least 1"));
    }
    if let (Some(n), true) = (a.levels, container) {
        let most = CubeMap::full_chain_len(size);
        if n > most {
            return Err(Error::usage(format!(
                "--levels {n}: a cube map of {size} px has 1 to {most} levels"
            )));
        }
    }
    let (w, h) = to.image_size(size);
    if w as u64 * h as u64 > limits.max_pixels || w.max(h) > limits.max_dimension as usize {
        return Err(Error::usage(format!(
            "--size {size} makes a {w}x{h} output, over the size limit (--max-pixels)"
        )));
    }
    // Again with what was decoded (standard input's size is known only now).
    check_memory(&limits, to, size, loaded.working_bytes())?;
    target.face_format = face_format.unwrap_or(if loaded.hdr {
        FileFormat::Exr
    } else {
        FileFormat::Png
    });
    target.write = WriteOptions {
        linear: a.input.linear,
        png16: a.png16,
        gpu_format: a.gpu_format.unwrap_or_default(),
        zstd: a.zstd.filter(|_| container),
    };
    target.levels = a.levels;
    target.tone = a.tone.for_target(&target);

    let resampler = Resampler {
        interp: a.interp,
        antialias: !a.no_antialias,
        orientation: Orientation {
            yaw: a.yaw,
            pitch: a.pitch,
            roll: a.roll,
            mirror: a.mirror,
        },
    };
    let out = convert::convert(&loaded, to, size, &resampler);
    stages.done("resample");
    let encoded = target.encode(out, &loaded.files)?;
    if let Some(w) = &encoded.clamped {
        warn(w);
    }
    stages.done("encode");
    stages.quality(target.write.gpu_format, encoded.psnr);
    super::deliver(&encoded.files, &encoded.folders, to_stdout)?;
    stages.done("write");
    stages.total();
    Ok(())
}

/// The plan's memory: the output (RGBA f32, twice over for mips and encoding) beside the
/// input's texels and pyramid (`input` bytes).
fn check_memory(limits: &io::Limits, to: Kind, size: usize, input: u64) -> Result<()> {
    let (w, h) = to.image_size(size);
    let texels = if to.projection().is_some() || to.is_cells() {
        (w as u64).saturating_mul(h as u64)
    } else {
        (size as u64).saturating_mul(size as u64).saturating_mul(6)
    };
    limits.check_memory(
        format_args!("--size {size} ({w}x{h} output)"),
        texels.saturating_mul(32).saturating_add(input),
    )
}
