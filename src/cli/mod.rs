//! Command-line front end: one file per command. Parses and reports; the library does the work.

mod control;
mod convert;
mod fixtures;
mod info;
mod irradiance;
mod man;
mod prefilter;
mod preview;

use clap::{Parser, Subcommand};
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "cubeforge",
    version,
    about = "Turn photographs into cube maps and check them",
    long_about = "Turn photographs into cube maps and check them: convert between equirect panoramas, \
                  face images, crosses, strips, mirror balls, angular maps, KTX2 and DDS; \
                  describe what a file holds."
)]
pub struct Cli {
    /// Print the time each stage takes (decode, resample, encode, write).
    #[arg(short, long, global = true)]
    pub verbose: bool,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Convert an environment map from any layout to any other.
    Convert(convert::Args),
    /// Describe files: layout, sizes, mip levels, pixel format, colour space, statistics.
    Info(info::Args),
    /// Prefiltered mip chains: box mipmaps, LOD-bias Gaussian blur, cosine-power and GGX radiance.
    Prefilter(prefilter::Args),
    /// The diffuse side: a Lambertian irradiance cube map and 9 spherical-harmonic coefficients.
    Irradiance(irradiance::Args),
    /// Bake a control map (reflectivity, transmittance, blur, Fresnel mask) from a recipe.
    Control(control::Args),
    /// Preview a map on a sphere: reflection, refraction, Fresnel and dispersion (Cg Tutorial ch. 7).
    Preview(preview::Args),
    /// Write the man pages (man/*.1) from these definitions.
    #[command(hide = true)]
    Man(man::Args),
    /// Write the project's generated test inputs (fixtures/).
    #[command(hide = true)]
    Fixtures(fixtures::Args),
}

/// How the inputs are read: shared by the commands that take environment maps.
#[derive(clap::Args, Debug)]
pub struct InputArgs {
    /// Input layout (detected from the aspect ratio; square images need sphere or angular).
    #[arg(long, value_enum)]
    pub from: Option<cubeforge::layout::Kind>,
    /// 8- and 16-bit files hold data, not colour: no sRGB decode on read or encode on write.
    #[arg(long)]
    pub linear: bool,
    /// Refuse images with more pixels than this (checked before decoding).
    #[arg(long, default_value_t = cubeforge::io::Limits::default().max_pixels)]
    pub max_pixels: u64,
}

impl InputArgs {
    pub fn limits(&self) -> cubeforge::io::Limits {
        cubeforge::io::Limits {
            max_pixels: self.max_pixels,
            ..Default::default()
        }
    }

    pub fn read_options(&self) -> cubeforge::io::ReadOptions {
        cubeforge::io::ReadOptions {
            limits: self.limits(),
            linear: self.linear,
        }
    }
}

/// Times stages and prints them with -v.
pub struct Stages {
    verbose: bool,
    last: Instant,
    start: Instant,
}

impl Stages {
    pub fn new(verbose: bool) -> Self {
        let now = Instant::now();
        Stages {
            verbose,
            last: now,
            start: now,
        }
    }
    /// Ends the stage that began at the previous call.
    pub fn done(&mut self, name: &str) {
        let now = Instant::now();
        if self.verbose {
            eprintln!(
                "cubeforge: {name:<10} {:8.3} s",
                (now - self.last).as_secs_f64()
            );
        }
        self.last = now;
    }
    pub fn total(&self) {
        if self.verbose {
            eprintln!(
                "cubeforge: {:<10} {:8.3} s",
                "total",
                self.start.elapsed().as_secs_f64()
            );
        }
    }
}

pub fn warn(msg: impl std::fmt::Display) {
    eprintln!("cubeforge: warning: {msg}");
}

pub fn run() -> i32 {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Convert(a) => convert::run(a, cli.verbose),
        Command::Info(a) => info::run(a),
        Command::Prefilter(a) => prefilter::run(a, cli.verbose),
        Command::Irradiance(a) => irradiance::run(a, cli.verbose),
        Command::Control(a) => control::run(a, cli.verbose),
        Command::Preview(a) => preview::run(a, cli.verbose),
        Command::Man(a) => man::run(a),
        Command::Fixtures(a) => fixtures::run(a),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("cubeforge: error: {e}");
            1
        }
    }
}

/// The clap definition, for the man pages.
pub fn command() -> clap::Command {
    <Cli as clap::CommandFactory>::command()
}
