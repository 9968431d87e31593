//! `cubeforge info`: describe files and folders.

use cubeforge::internals::info;
use cubeforge::internals::io::ReadOptions;
use cubeforge::{Error, Result};
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Files to describe, or folders: six faces (px.EXT ... or posx.EXT ...), or a prefiltered
    /// chain (m0/ m1/ ... and levels.json, as `cubeforge prefilter` writes one).
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Layout of single images: settles a square image (sphere, angular or octahedral) and
    /// overrides what the aspect ratio says.
    #[arg(long, value_enum)]
    pub from: Option<cubeforge::internals::layout::Kind>,
    /// Print JSON: one object for one file, an array for several.
    #[arg(long)]
    pub json: bool,
    /// Treat 8- and 16-bit values as data (no sRGB decode) for the statistics.
    #[arg(long)]
    pub linear: bool,
    #[command(flatten)]
    pub part: super::PartArg,
    #[command(flatten)]
    pub decode: super::read::DecodeArg,
    #[command(flatten)]
    pub limits: super::LimitArgs,
}

/// Printed after the options (`-h`, `--help`, the man page); tests/it/help_examples.rs
/// runs every `cubeforge` line of it.
const EXAMPLES: &str = "\
Examples:
  # layout, size, format, luminance, NaN/Inf/negative counts, flux
  cubeforge info panorama.hdr
  # a square image: say which layout it is
  cubeforge info ball.exr --from sphere
  # the same as JSON (an array for several files)
  cubeforge info panorama.hdr --json";

pub fn run(args: Args) -> Result<()> {
    let opts = ReadOptions {
        limits: args.limits.limits(),
        linear: args.linear,
        as_stored: true,
        exr_part: args.part.index(&args.files)?,
        exr_level: 0,
        hdr_encoding: args.decode.decode,
    };
    let mut reports = Vec::new();
    let mut failed = 0;
    for f in &args.files {
        // An `ibl` output folder: what its specular file holds (as `view` and `preview` read).
        let shown = cubeforge::internals::ibl::specular_of(f).map(|(file, _)| file);
        match info::describe(shown.as_ref().unwrap_or(f), args.from, &opts) {
            Ok(r) => reports.push(r),
            // One file: its error is the one line (no summary after it).
            Err(e) if args.files.len() == 1 => return Err(e),
            Err(e) => {
                // One line, even for a name that holds a line break.
                let text = e.with_flags();
                let e = cubeforge::internals::error::escape_text(&text);
                super::tell(format_args!("cubeforge: error: {e}"));
                failed += 1;
            }
        }
    }
    if args.json {
        let text = if args.files.len() == 1 {
            reports
                .first()
                .map(|r| serde_json::to_string_pretty(r).unwrap_or_default())
        } else {
            serde_json::to_string_pretty(&reports).ok()
        };
        if let Some(t) = text {
            super::say(t)?;
        }
    } else {
        for r in &reports {
            super::say(r)?;
        }
    }
    if failed > 0 {
        return Err(Error::usage(format!(
            "{failed} of {} files could not be read",
            args.files.len()
        )));
    }
    Ok(())
}
