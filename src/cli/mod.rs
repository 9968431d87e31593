//! Command-line front end: one file per command. Parses and reports; the library does the work.

mod batch;
mod completions;
mod control;
mod convert;
mod fixtures;
mod ibl;
mod info;
mod irradiance;
mod lut;
mod man;
mod observer;
mod out;
mod prefilter;
mod preview;
mod read;
mod serve;
mod signals;
mod view;

#[allow(unused_imports)] // the Python package's way in (python/src/run.rs)
pub use batch::{job_of_words, prepare_words, Prepared, Ran};
use clap::{Parser, Subcommand};
use cubeforge::internals::tonemap::Tonemap;
pub use observer::Observer;
pub use out::{destination, write_files};
use out::{write_stdout, DATA_ON_STDOUT};
pub use read::PartArg;
use std::time::Instant;

#[derive(Parser, Debug)]
#[command(
    name = "cubeforge",
    version,
    about = "Turn photographs into cube maps and check them",
    long_about = "Turn photographs into cube maps and check them: from a panorama to the files an \
                  engine loads for image-based lighting (ibl: Bevy, glTF, Babylon.js, Filament, \
                  Godot, Unity, Unreal); convert between equirect panoramas, face images, \
                  crosses, strips, mirror balls, angular and octahedral maps, KTX2 and DDS; \
                  prefiltered mip chains, irradiance, BRDF tables, control maps; a sphere \
                  preview; describe what a file holds.",
    after_help = EXAMPLES
)]
pub struct Cli {
    /// Print the time each stage takes (decode, resample, encode, write); batch: the jobs
    /// that are up to date too.
    #[arg(short, long, global = true)]
    pub verbose: bool,
    /// Print errors only: no warnings, summaries or progress bars (for build scripts).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    /// Write a Make-style depfile at PATH: the output (as -o names it) and every file the
    /// command read (inputs, faces, decals, recipes, materials, sidecars), for make, Ninja
    /// and asset cookers.
    #[arg(long, global = true, value_name = "PATH")]
    pub depfile: Option<std::path::PathBuf>,
    #[command(subcommand)]
    pub command: Command,
}

/// Printed after the commands (`-h`, `--help`, the man page); tests/it/help_examples.rs runs
/// every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples (panorama.hdr: an equirect HDR photograph, e.g. one of polyhaven.com's, CC0):
  # the files Bevy loads for image-based lighting (others: ibl --help)
  cubeforge ibl panorama.hdr -o bevy/ --target bevy
  # six EXR faces, then a KTX2 cube map with its mip chain
  cubeforge convert panorama.hdr -o faces/ --to faces
  cubeforge convert faces/ -o sky.ktx2
  # a blurry chain, seen on a chrome ball at LOD biases 0 to 3
  cubeforge prefilter panorama.hdr -o blur.ktx2 --filter gaussian --size 256
  cubeforge preview blur.ktx2 -o bias.png --size 256 --grid-bias 0,1,2,3
  # what a file holds: layout, levels, format, statistics, flux
  cubeforge info blur.ktx2";

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
    /// One command to the files an engine loads: specular chain, diffuse term, SH, tables.
    Ibl(ibl::Args),
    /// BRDF lookup tables for split-sum shading: GGX DFG (scale/bias or multiscatter), Charlie sheen.
    Lut(lut::Args),
    /// Bake a control map (reflectivity, transmittance, blur, Fresnel mask) from a recipe.
    Control(control::Args),
    /// Preview a map on a sphere: reflection, refraction, Fresnel and dispersion (Cg Tutorial ch. 7), split-sum pbr.
    Preview(preview::Args),
    /// Look at a map live on the GPU: a static page with the preview's materials, in any browser.
    View(view::Args),
    /// Run a manifest of jobs over many inputs: each job as its command line would run it.
    Batch(batch::Args),
    /// Print a shell completion script: `source <(cubeforge completions bash)`.
    Completions(completions::Args),
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
    /// Input layout (detected from the aspect ratio; square images need sphere, angular
    /// or octahedral).
    #[arg(long, value_enum)]
    pub from: Option<cubeforge::internals::layout::Kind>,
    /// 8- and 16-bit files hold data, not colour: no sRGB decode on read or encode on write.
    #[arg(long)]
    pub linear: bool,
    #[command(flatten)]
    pub part: PartArg,
    #[command(flatten)]
    pub decode: read::DecodeArg,
    #[command(flatten)]
    pub limits: LimitArgs,
}

impl InputArgs {
    pub fn limits(&self) -> cubeforge::internals::io::Limits {
        self.limits.limits()
    }

    /// How `inputs` are read: `--part NAME` is looked up in them.
    pub fn read_options(
        &self,
        inputs: &[std::path::PathBuf],
    ) -> cubeforge::Result<cubeforge::internals::io::ReadOptions> {
        Ok(cubeforge::internals::io::ReadOptions {
            limits: self.limits(),
            linear: self.linear,
            as_stored: false,
            exr_part: self.part.index(inputs)?,
            exr_level: 0,
            hdr_encoding: self.decode.decode,
        })
    }
}

/// The size limits: pixels of any image read, and the memory a command may plan.
#[derive(clap::Args, Debug)]
pub struct LimitArgs {
    /// Refuse images with more pixels than this (checked before decoding).
    #[arg(long, default_value_t = cubeforge::internals::io::Limits::default().max_pixels)]
    pub max_pixels: u64,
    #[command(flatten)]
    pub memory: MemoryArg,
}

impl LimitArgs {
    pub fn limits(&self) -> cubeforge::internals::io::Limits {
        limits(self.max_pixels, self.memory.max_memory)
    }
}

/// The memory budget alone (for commands that read no image).
#[derive(clap::Args, Debug)]
pub struct MemoryArg {
    /// Memory a command may plan to use, in bytes or with K, M, G (default: half the
    /// machine's memory, or of a container's limit or ulimit -v); a bigger plan is refused
    /// before it starts.
    #[arg(long, value_parser = bytes)]
    pub max_memory: Option<u64>,
}

/// The sample type of EXR outputs.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ExrArg {
    /// Sample type of EXR output: half (16-bit floats, largest 65504) or f32 (twice the size;
    /// keeps an unclipped sun, which photographs put at 1e5 and more).
    #[arg(long, value_enum, value_name = "TYPE", default_value_t = cubeforge::internals::io::ExrFloat::Half)]
    pub exr_float: cubeforge::internals::io::ExrFloat,
}

/// Radiance scaled for outputs that keep it linear.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ExposureArg {
    /// Scale the radiance by 2^EV before anything is computed (0 keeps it): brings a sun
    /// within a format's range, or a dim scan up.
    #[arg(value_parser = exposure, long, value_name = "EV", default_value_t = 0.0, allow_hyphen_values = true)]
    pub exposure: f32,
}

/// Zstandard supercompression of KTX2 outputs.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ZstdArg {
    /// Supercompress KTX2 output with Zstandard at LEVEL (1 to 22; 19 when no level is given,
    /// as in --zstd=19). Readers inflate it on load (three.js, Bevy with its default `zstd`
    /// feature, KTX-Software); DDS has none.
    #[arg(long, value_name = "LEVEL", num_args = 0..=1, require_equals = true, default_missing_value = "19", value_parser = clap::value_parser!(i32).range(1..=22))]
    pub zstd: Option<i32>,
}

/// Exposure and tone curve for outputs of 8 bits a channel: HDR input would clip at 1.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct ToneArgs {
    /// Exposure in stops: radiance scaled by 2^EV, before the tone curve of 8-bit outputs (float
    /// outputs keep it linear, scaled).
    #[arg(value_parser = exposure, long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub exposure: f32,
    /// Tone curve for 8-bit outputs (PNG, JPEG, TGA, rgba8 KTX2 and DDS); EXR, HDR and
    /// float containers stay linear.
    #[arg(long, value_enum, default_value_t = Tonemap::None)]
    pub tonemap: Tonemap,
}

/// Runs a command's job and prints its report; with `--depfile`, then writes the depfile:
/// `output` depends on every file the job read. A depfile that would land on the output, in
/// an output folder or on any file the job wrote is refused (before the work where the
/// output names it, else before the depfile is written: the outputs stay whole).
pub fn execute(
    mut job: impl cubeforge::Job,
    output: &std::path::Path,
    verbose: bool,
    depfile: Option<&std::path::Path>,
) -> cubeforge::Result<()> {
    if depfile.is_some() && output == std::path::Path::new("-") {
        return Err(cubeforge::Error::usage(
            "--depfile needs -o FILE: standard output has no name for a depfile's target",
        ));
    }
    if let Some(path) = depfile {
        cubeforge::internals::output::depfile::check(path, output)?;
    }
    let guard = depfile.map(|_| cubeforge::Session::open());
    if let Some(g) = &guard {
        job.limits_mut().session = g.session();
    }
    let observer = Observer::new(verbose);
    let report = job.run(&observer)?;
    if let (Some(path), Some(g)) = (depfile, &guard) {
        let reads = g.session().take_reads();
        cubeforge::internals::output::depfile::write(path, output, &reads, &report.written)?;
    }
    observer.report(&report)
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
    /// A line of detail shown with -v only (after the stages so far).
    pub fn note(&self, text: impl std::fmt::Display) {
        if self.verbose {
            tell(format_args!("cubeforge: {text}"));
        }
    }
    /// With -v, a lossy container format's quality (level 0 read back against the map).
    pub fn quality(&self, format: cubeforge::internals::io::GpuFormat, psnr: Option<f64>) {
        if let Some(db) = psnr {
            let how = if format.is_float() {
                "RGB after v/(1+v)"
            } else {
                "RGBA as stored"
            };
            self.note(format_args!(
                "{} quality: PSNR {db:.2} dB at level 0 ({how}, peak 1)",
                format.name()
            ));
        }
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

/// Set by --quiet: warnings, summaries and progress bars stay silent.
static QUIET: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

pub fn quiet() -> bool {
    QUIET.load(std::sync::atomic::Ordering::Relaxed)
}

pub fn warn(msg: impl std::fmt::Display) {
    if !quiet() {
        let text = cubeforge::internals::error::name_params(&msg.to_string(), true);
        tell(format_args!(
            "cubeforge: warning: {}",
            cubeforge::internals::error::escape_text(&text)
        ));
    }
}

/// A summary line on standard output, silenced by --quiet (what a command made, not what
/// it was asked to print).
pub fn report(text: impl std::fmt::Display) -> cubeforge::Result<()> {
    if quiet() {
        return Ok(());
    }
    // With `-o -` standard output carries the file: summaries go to standard error.
    if DATA_ON_STDOUT.load(std::sync::atomic::Ordering::Relaxed) {
        tell(text);
        return Ok(());
    }
    // A summary, not the command's data: a closed standard output is no reason to fail.
    let text = cubeforge::internals::error::name_params(&text.to_string(), true);
    out::write_summary(&text)
}

/// A progress bar on standard error for work counted in `total` units; none when standard
/// error is not a terminal or with --quiet.
pub fn progress(total: u64, prefix: String) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if quiet() || !std::io::stderr().is_terminal() {
        return None;
    }
    let b = indicatif::ProgressBar::new(total);
    b.set_style(
        indicatif::ProgressStyle::with_template(
            "{prefix} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    b.set_prefix(prefix);
    Some(b)
}

/// Writes a line to standard output. A reader that went away (`| head`) ends the process
/// quietly; any other failure (`> /dev/full`) is an error, never a panic.
pub fn say(text: impl std::fmt::Display) -> cubeforge::Result<()> {
    use std::io::Write;
    // Parameters named by the library are flags here (`--from`).
    let text = cubeforge::internals::error::name_params(&text.to_string(), true);
    write_stdout(|out| writeln!(out, "{text}"))
}

/// Writes a line to standard error; a failure is ignored (there is nowhere left to say it).
pub fn tell(text: impl std::fmt::Display) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{text}");
}

/// The limits from the size options.
pub fn limits(max_pixels: u64, max_memory: Option<u64>) -> cubeforge::internals::io::Limits {
    let default = cubeforge::internals::io::Limits::default();
    cubeforge::internals::io::Limits {
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

/// Stops of exposure: 2^32 times the largest input (1e28) is still a float.
pub fn exposure(s: &str) -> Result<f32, String> {
    within(s, -32.0, 32.0)
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
pub(crate) fn one_line(e: &clap::Error) -> String {
    let text = e.render().to_string();
    let parts: Vec<&str> = text
        .lines()
        .map(str::trim)
        .filter(|l| {
            !l.is_empty() && !l.starts_with("Usage:") && !l.starts_with("For more information")
        })
        .collect();
    // A line ending in a colon introduces the next ("not provided:" then the flags).
    let mut line = String::new();
    for p in parts {
        if !line.is_empty() {
            line.push_str(if line.ends_with(':') { " " } else { "; " });
        }
        line.push_str(p);
    }
    line.trim_start_matches("error: ").to_owned()
}

/// The library names the limit; the command line says which flag raises it.
fn how_to_raise(e: &cubeforge::Error) -> &'static str {
    match e {
        cubeforge::Error::Limit {
            kind: cubeforge::LimitKind::Pixels,
            ..
        } => "; raise it with --max-pixels if the file is genuine",
        cubeforge::Error::Limit {
            kind: cubeforge::LimitKind::Memory,
            ..
        } => "; raise it with --max-memory",
        _ => "",
    }
}

pub fn run() -> i32 {
    use std::io::Write;
    let cli = match Cli::try_parse_from(help_flag_read(zstd_level_joined(std::env::args_os()))) {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                // `cubeforge` alone, or a command without its arguments: the usage, on
                // standard error, and the status of a usage error (as clap gives).
                let _ = e.print();
                return 2;
            }
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                // Help and the version go to standard output, as asked: a closed pipe is
                // not an error, a full disk or a closed standard output is.
                if !e.use_stderr() {
                    let text = e.render().to_string();
                    if let Err(e) = write_stdout(|out| out.write_all(text.as_bytes())) {
                        tell(format_args!("cubeforge: error: {e}"));
                        return 1;
                    }
                    return 0;
                }
                let _ = e.print();
                return 0;
            }
            tell(format_args!("cubeforge: error: {}", one_line(&e)));
            return 2;
        }
    };
    signals::remove_temporaries_on_signals();
    QUIET.store(cli.quiet, std::sync::atomic::Ordering::Relaxed);
    match dispatch(cli) {
        Ok(()) => 0,
        Err(e) => {
            // One line, whatever the message holds (a file's text, a JSON error, a name with
            // a line break or an escape sequence), every control character written out.
            let text = e.with_flags();
            let line = cubeforge::internals::error::escape_text(&text);
            tell(format_args!("cubeforge: error: {line}{}", how_to_raise(&e)));
            1
        }
    }
}

/// Runs the command the line names.
fn dispatch(cli: Cli) -> cubeforge::Result<()> {
    let (v, dep) = (cli.verbose, cli.depfile.as_deref());
    match cli.command {
        Command::Convert(a) => convert::run(a, v, dep),
        Command::Prefilter(a) => prefilter::run(a, v, dep),
        Command::Irradiance(a) => irradiance::run(a, v, dep),
        Command::Ibl(a) => ibl::run(a, v, dep),
        Command::Lut(a) => lut::run(a, v, dep),
        Command::Control(a) => control::run(a, v, dep),
        Command::Preview(a) => preview::run(a, v, dep),
        Command::View(a) => view::run(a, v, dep),
        _ if dep.is_some() => Err(cubeforge::Error::usage(
            "--depfile applies to commands that write a file (batch: --depfiles)",
        )),
        Command::Info(a) => info::run(a),
        Command::Batch(a) => batch::run(a, v),
        Command::Completions(a) => completions::run(a),
        Command::Man(a) => man::run(a),
        Command::Fixtures(a) => fixtures::run(a),
    }
}

/// The arguments with `--zstd N` read as `--zstd=N` when N is a number: the level is optional,
/// so clap alone would take N for an input file ("9: No such file"); clap checks its range.
fn zstd_level_joined(args: impl Iterator<Item = std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    let mut out: Vec<std::ffi::OsString> = Vec::new();
    let mut options = true;
    for a in args {
        let level = a
            .to_str()
            .filter(|s| (1..=3).contains(&s.len()) && s.bytes().all(|b| b.is_ascii_digit()));
        match (level, out.last()) {
            (Some(n), Some(prev)) if options && prev == "--zstd" => {
                *out.last_mut().expect("checked") = format!("--zstd={n}").into();
            }
            _ => {
                options &= a != "--";
                out.push(a);
            }
        }
    }
    out
}

/// `help --help` and `help COMMAND --help` read as `help help` and `help COMMAND`: clap's
/// `help` command takes every word for a command's name, `--help` too, and failed.
fn help_flag_read(args: Vec<std::ffi::OsString>) -> Vec<std::ffi::OsString> {
    if args.get(1).is_none_or(|a| a != "help") {
        return args;
    }
    let flag = |a: &std::ffi::OsString| a == "--help" || a == "-h";
    if !args[2..].iter().any(flag) {
        return args;
    }
    let mut out: Vec<std::ffi::OsString> = args.into_iter().filter(|a| !flag(a)).collect();
    if out.len() == 2 {
        out.push("help".into());
    }
    out
}

/// The clap definition, for the man pages.
pub fn command() -> clap::Command {
    <Cli as clap::CommandFactory>::command()
}
