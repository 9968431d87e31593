//! `cubeforge view`: a static page that draws the preview's scene live on the GPU, opened
//! from disk or served on this machine (`--serve`).

use cubeforge::internals::ibl::Engine;
use cubeforge::{Result, ViewJob};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// A panorama, six faces, a cube map or a prefiltered chain (KTX2, DDS, chain folder).
    pub input: PathBuf,
    /// The folder for index.html and its data (with --single-file: NAME.html).
    #[arg(short, long)]
    pub output: PathBuf,
    /// One self-contained .html file: the page, its scripts and data inline.
    #[arg(long)]
    pub single_file: bool,
    /// Serve the page on this machine after writing it (a free port, printed) until Ctrl-C:
    /// the files view wrote and nothing else.
    #[arg(long)]
    pub serve: bool,
    /// The address --serve listens on (default 127.0.0.1: this machine only).
    #[arg(
        long,
        value_name = "ADDR",
        requires = "serve",
        default_value = "127.0.0.1"
    )]
    pub bind: String,
    /// A decal image on the sphere (sRGB colour), as preview's --decal.
    #[arg(long)]
    pub decal: Option<PathBuf>,
    /// A control map on the sphere, as preview's --control.
    #[arg(long)]
    pub control: Option<PathBuf>,
    /// LOD bias that a control map's blur = 1 stands for, when it has no sidecar.
    #[arg(value_parser = super::finite_f32, long, default_value_t = 4.0)]
    pub max_lod_bias: f32,
    /// pbr reads a chain with this engine's roughness mapping, as preview's --target.
    #[arg(long, value_enum)]
    pub target: Option<Engine>,
    #[command(flatten)]
    pub input_args: super::InputArgs,
}

const EXAMPLES: &str = "\
Examples:
  # a viewer folder: open view/index.html in any browser (from disk, no network)
  cubeforge view panorama.hdr -o view
  # one self-contained page to mail or attach to a review
  cubeforge view panorama.hdr -o sky.html --single-file";

pub fn job(a: Args) -> Result<ViewJob> {
    Ok(ViewJob {
        from: a.input_args.from,
        single_file: a.single_file,
        decal: a.decal,
        control: a.control,
        max_lod_bias: a.max_lod_bias,
        target: a.target,
        limits: a.input_args.limits(),
        exr_part: a.input_args.part.index(std::slice::from_ref(&a.input))?,
        hdr_encoding: a.input_args.decode.decode,
        linear: a.input_args.linear,
        ..ViewJob::new(a.input, a.output)
    })
}

pub fn run(a: Args, verbose: bool, depfile: Option<&std::path::Path>) -> Result<()> {
    let (output, serve, bind, single) = (a.output.clone(), a.serve, a.bind.clone(), a.single_file);
    super::execute(job(a)?, &output, verbose, depfile)?;
    if serve {
        // What the job wrote, and nothing else the folder holds.
        super::serve::serve(&cubeforge::internals::view::paths(&output, single), &bind)?;
    }
    Ok(())
}
