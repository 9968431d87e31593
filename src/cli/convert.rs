//! `cubeforge convert`: any layout to any other.

use cubeforge::internals::cube::Interp;
use cubeforge::internals::io::{FileFormat, GpuFormat};
use cubeforge::internals::output;
use cubeforge::internals::resample::{Orientation, Resampler};
use cubeforge::MapKind;
use cubeforge::{ConvertJob, Destination, Encoding, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// One image; six face images in px nx py ny pz nz order; or a folder of px/nx/... faces.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// Output file, folder for --to faces, or - for standard output (with --format).
    #[arg(short, long, allow_hyphen_values = true)]
    pub output: PathBuf,
    /// Output layout (default: from the output's extension; hcross for images, faces for a folder).
    #[arg(long, value_enum)]
    pub to: Option<MapKind>,
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
    /// Flip handedness (mirror X) for engines with the other convention, and for OpenEXR's
    /// exrenvmap, whose latlong maps are cubeforge's equirect mirrored (`exrenvmap -li` of a
    /// panorama written without it gives mirrored faces).
    #[arg(long)]
    pub mirror: bool,
    /// Write 16-bit PNG instead of 8-bit.
    #[arg(long)]
    pub png16: bool,
    /// Write a .jpg as UltraHDR: an SDR picture (--tonemap's curve, ACES by default) with a
    /// gain map that rebuilds the radiance (three.js's UltraHDRLoader, Android, Chrome).
    #[arg(long)]
    pub ultrahdr: bool,
    /// Texel format of KTX2 and DDS output (default rgba16f; bc6h and bc7 are block
    /// compressed, rgb9e5 and rg11b10 packed HDR in 4 bytes; astc-hdr-4x4 and astc-hdr-6x6,
    /// KTX2 only, are HDR blocks for phones, in builds with the cargo feature astc;
    /// uastc-hdr-4x4, KTX2 only, is one file for every device, transcoded to BC6H where ASTC
    /// HDR is missing, in builds with the feature uastc).
    #[arg(long, value_enum)]
    pub gpu_format: Option<GpuFormat>,
    #[command(flatten)]
    pub zstd: super::ZstdArg,
    /// Mip levels in KTX2 and DDS output (default: the full chain down to 1x1).
    #[arg(long)]
    pub levels: Option<usize>,
    /// Which level of a KTX2 or DDS mip chain, of a mip-mapped OpenEXR file, or which mN
    /// folder of a prefiltered chain to read; 0 is the full size.
    #[arg(long, default_value_t = 0)]
    pub level: usize,
    #[command(flatten)]
    pub exr: super::ExrArg,
    #[command(flatten)]
    pub tone: super::ToneArgs,
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
  # a panorama (e.g. a .hdr from polyhaven.com) to six faces px.exr ...
  cubeforge convert panorama.hdr -o faces/ --to faces
  # the faces to a KTX2 cube map with its mips, BC6H, Zstandard
  cubeforge convert faces/ -o sky.ktx2 --gpu-format bc6h --zstd
  # a horizontal cross, 8-bit sRGB, the HDR range tone-mapped
  cubeforge convert panorama.hdr -o cross.png --size 256 --tonemap aces
  # an UltraHDR panorama: any JPEG reader sees the SDR picture, HDR readers the radiance
  cubeforge convert panorama.hdr -o panorama.jpg --to equirect --ultrahdr
  # a photographed mirror ball (square images need --from) to a panorama
  cubeforge convert ball.exr --from sphere -o from_ball.exr --to equirect";

/// The library job these flags describe (what `run` runs, and what a batch manifest builds).
pub fn job(a: Args) -> Result<ConvertJob> {
    let output = super::destination(&a.output, a.format.as_deref(), |_| true)?;
    let face_format = match (&output, &a.format) {
        (Destination::Path(_), Some(f)) => {
            Some(FileFormat::from_ext_str(f).ok_or_else(|| output::face_format(f).unwrap_err())?)
        }
        _ => None,
    };
    let job = ConvertJob {
        from: a.input.from,
        to: a.to,
        size: a.size,
        resampler: Resampler {
            interp: a.interp,
            antialias: !a.no_antialias,
            orientation: Orientation {
                yaw: a.yaw,
                pitch: a.pitch,
                roll: a.roll,
                mirror: a.mirror,
            },
        },
        encoding: Encoding {
            gpu_format: a.gpu_format,
            zstd: a.zstd.zstd,
            exr_float: a.exr.exr_float,
            png16: a.png16,
            edge_fixup: a.fixup.edge_fixup,
            hdr_encoding: a.hdr8.hdr_encoding,
            cubeforge_keys: a.keys.cubeforge_keys,
            face_format,
            ultrahdr: a.ultrahdr,
            exposure: a.tone.exposure,
            tonemap: a.tone.tonemap,
        },
        levels: a.levels,
        level: a.level,
        read: a.input.read_options(&a.inputs)?,
        ..ConvertJob::new(a.inputs, output)
    };
    Ok(job)
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    let output = a.output.clone();
    super::execute(job(a)?, &output, verbose, depfile)
}
