//! `cubeforge irradiance`: the diffuse side: an irradiance cube map and SH coefficients.

use cubeforge::internals::filter::sh_bands::ShWindow;
use cubeforge::internals::filter::IrradianceMethod;
use cubeforge::internals::io::{FileFormat, GpuFormat};
use cubeforge::internals::output;
use cubeforge::MapKind;
use cubeforge::{Destination, Encoding, IrradianceJob, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Anything `convert` reads: one image, six faces, or a folder of faces.
    #[arg(required = true)]
    pub inputs: Vec<PathBuf>,
    /// As for convert: a folder receives px.exr ... (replacing what it held whole); a file gets
    /// a layout or container; - is standard output (with --format).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output layout (default: from the output's name, as for convert).
    #[arg(long, value_enum)]
    pub to: Option<MapKind>,
    /// Face edge of the irradiance map (it holds no detail: 32 is plenty).
    #[arg(long, default_value_t = 32)]
    pub size: usize,
    /// Also write the SH coefficients (radiance, irradiance, irradiance / pi) as JSON.
    #[arg(long)]
    pub sh: Option<PathBuf>,
    /// brute: exact integral (default; right next to HDR suns); sh: from the SH coefficients.
    #[arg(long, value_enum, default_value_t = IrradianceMethod::Brute)]
    pub method: IrradianceMethod,
    /// SH bands, 1 to 5 (as cmgen --sh=N): 3 is 9 coefficients per channel, 5 is 25 (cmft's).
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub sh_bands: usize,
    /// cmgen's windowing against ringing: no (default), auto (the mildest sinc^4 taper under
    /// which the irradiance is nowhere negative), or the cutoff band where it reaches zero.
    #[arg(long, default_value = "no", value_name = "no|auto|CUTOFF")]
    pub sh_window: ShWindow,
    /// File type of face images (default exr).
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
  # a 32 px irradiance cube map (KTX2) and the 9 SH coefficients as JSON
  cubeforge irradiance panorama.hdr -o irradiance.ktx2 --sh sh.json
  # cmft's 25 coefficients, windowed as cmgen's auto does
  cubeforge irradiance panorama.hdr -o irr25.ktx2 --sh sh25.json --sh-bands 5 --sh-window auto
  # six 16 px EXR faces
  cubeforge irradiance panorama.hdr -o irradiance/ --size 16";

/// The library job these flags describe (what `run` runs, and what a batch manifest builds).
pub fn job(a: Args) -> Result<IrradianceJob> {
    let output = super::destination(&a.output, Some(&a.format), |_| true)?;
    let face_format = match output {
        Destination::Stdout(_) => FileFormat::Exr,
        Destination::Path(_) => output::face_format(&a.format)?,
    };
    let out = super::out::CubeOutput {
        gpu_format: a.gpu_format,
        zstd: &a.zstd,
        exr: &a.exr,
        fixup: &a.fixup,
        hdr8: &a.hdr8,
        keys: &a.keys,
    };
    let encoding = Encoding {
        tonemap: a.tone.tonemap,
        ..out.encoding(face_format, a.tone.exposure)
    };
    let job = IrradianceJob {
        from: a.input.from,
        to: a.to,
        size: a.size,
        sh: a.sh,
        method: a.method,
        sh_bands: a.sh_bands,
        sh_window: a.sh_window,
        encoding,
        read: a.input.read_options(&a.inputs)?,
        ..IrradianceJob::new(a.inputs, output)
    };
    Ok(job)
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    let output = a.output.clone();
    super::execute(job(a)?, &output, verbose, depfile)
}
