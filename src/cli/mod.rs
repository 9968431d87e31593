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
    /// Memory a command may plan to use, in bytes or with K, M, G (default: half the
    /// machine's memory); a bigger plan is refused before it starts.
    #[arg(long, value_parser = bytes)]
    pub max_memory: Option<u64>,
}

impl InputArgs {
    pub fn limits(&self) -> cubeforge::io::Limits {
        limits(self.max_pixels, self.max_memory)
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
            tell(format_args!(
                "cubeforge: {name:<10} {:8.3} s",
                (now - self.last).as_secs_f64()
            ));
        }
        self.last = now;
    }
    pub fn total(&self) {
        if self.verbose {
            tell(format_args!(
                "cubeforge: {:<10} {:8.3} s",
                "total",
                self.start.elapsed().as_secs_f64()
            ));
        }
    }
}

pub fn warn(msg: impl std::fmt::Display) {
    tell(format_args!("cubeforge: warning: {msg}"));
}

/// Writes a line to standard output. A reader that went away (`| head`) ends the process
/// quietly; any other failure (`> /dev/full`) is an error, never a panic.
pub fn say(text: impl std::fmt::Display) -> cubeforge::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match writeln!(out, "{text}").and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => Err(cubeforge::Error::usage(format!(
            "cannot write to standard output: {}",
            cubeforge::io::io_msg(&e)
        ))),
    }
}

/// Writes a line to standard error; a failure is ignored (there is nowhere left to say it).
pub fn tell(text: impl std::fmt::Display) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{text}");
}

/// The limits from the size options.
pub fn limits(max_pixels: u64, max_memory: Option<u64>) -> cubeforge::io::Limits {
    let default = cubeforge::io::Limits::default();
    cubeforge::io::Limits {
        max_pixels,
        max_memory: max_memory.unwrap_or(default.max_memory),
        ..default
    }
}

/// A byte count: a number with an optional K, M or G (powers of 1024).
pub fn bytes(s: &str) -> Result<u64, String> {
    let t = s.trim();
    let (num, unit) = match t.char_indices().find(|(_, c)| c.is_ascii_alphabetic()) {
        Some((i, _)) => (&t[..i], t[i..].to_ascii_uppercase()),
        None => (t, String::new()),
    };
    let shift = match unit.trim_end_matches("IB").trim_end_matches('B') {
        "" => 0,
        "K" => 10,
        "M" => 20,
        "G" => 30,
        "T" => 40,
        _ => return Err(format!("'{s}': use a number of bytes, or K, M, G")),
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => {
            Ok((v * (1u64 << shift) as f64).min(u64::MAX as f64) as u64)
        }
        _ => Err(format!("'{s}' is not a positive amount of memory")),
    }
}

/// A number option that must be finite (clap parser).
pub fn finite_f32(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("{s} is not a finite number")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}

fn within(s: &str, lo: f32, hi: f32) -> Result<f32, String> {
    let v = finite_f32(s)?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is outside {lo}..={hi}"))
    }
}

/// Degrees of a rotation: ten turns either way at most.
pub fn angle(s: &str) -> Result<f32, String> {
    within(s, -3600.0, 3600.0)
}

/// cmft's gloss scale: the power 2^(scale x gloss + bias) must stay a float.
pub fn gloss_scale(s: &str) -> Result<f32, String> {
    within(s, 0.0, 64.0)
}

/// See `gloss_scale`.
pub fn gloss_bias(s: &str) -> Result<f32, String> {
    within(s, -64.0, 64.0)
}

/// A clap error on one line: the message and clap's tip, without the usage block.
fn one_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let parts: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect();
    parts.join("; ").trim_start_matches("error: ").to_owned()
}

pub fn run() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion)
                || matches!(
                    e.kind(),
                    ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
                )
            {
                // Help goes to stdout, as asked; a closed pipe is not an error.
                let _ = e.print();
                return 0;
            }
            tell(format_args!("cubeforge: error: {}", one_line(&e)));
            return 2;
        }
    };
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
            // One line, whatever the message holds (a file's text, a JSON error).
            let e = e.to_string().replace(['\n', '\r'], " ");
            tell(format_args!("cubeforge: error: {e}"));
            1
        }
    }
}

/// The clap definition, for the man pages.
pub fn command() -> clap::Command {
    <Cli as clap::CommandFactory>::command()
}
