//! Where a command's output goes, as the command line names it: `-o -` with `--format` is
//! standard output ([`Destination::Stdout`]); the writing itself is the library's
//! ([`cubeforge::internals::output::deliver`]).

use cubeforge::internals::io::FileFormat;
use cubeforge::internals::output::{self, Destination, Files};

/// Set when the command's output file goes to standard output (`-o -`): summaries then go
/// to standard error.
pub(super) static DATA_ON_STDOUT: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// Writes text to standard output and flushes: a reader that went away ends the process
/// quietly, any other failure is one error line.
pub(super) fn write_stdout(
    write: impl FnOnce(&mut Vec<u8>) -> std::io::Result<()>,
) -> cubeforge::Result<()> {
    let mut text = Vec::new();
    let _ = write(&mut text);
    quietly(output::write_stdout(&text))
}

/// Writes a summary line to standard output (see [`output::write_summary`]): a standard
/// output closed at start or on /dev/null takes it; a reader that went away ends the process
/// quietly.
pub(super) fn write_summary(text: &str) -> cubeforge::Result<()> {
    quietly(output::write_summary(format!("{text}\n").as_bytes()))
}

/// A closed pipe on standard output ends the process quietly (`| head`).
pub(super) fn quietly(r: cubeforge::Result<()>) -> cubeforge::Result<()> {
    match r {
        Err(e) if output::is_closed_pipe(&e) => std::process::exit(0),
        r => r,
    }
}

/// The destination `-o` and `--format` name, standard output when `output` is `-` and the
/// format is one of those `allowed`.
pub fn destination(
    output: &std::path::Path,
    format: Option<&str>,
    allowed: impl Fn(FileFormat) -> bool,
) -> cubeforge::Result<Destination> {
    let dest = Destination::parse(output, format, allowed)?;
    if dest.is_stdout() {
        DATA_ON_STDOUT.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    Ok(dest)
}

/// Writes a command's files through the library's one write path, all or none: a missing
/// folder is made with them (see [`cubeforge::internals::io::atomic`]).
pub fn write_files(files: &[(std::path::PathBuf, Vec<u8>)]) -> cubeforge::Result<()> {
    output::deliver(
        &Files::new(files.to_vec()),
        &Destination::Path(".".into()),
        &[],
    )
}

/// `--edge-fixup`, shared by the commands that write cube maps.
#[derive(clap::Args, Debug)]
pub struct EdgeFixupArg {
    /// For samplers without seamless cube filtering (GLES 2, WebGL 1, DX9): warp (cmft's:
    /// texel centres pulled out by t + a t^3, a = n^2/(n-1)^3) or stretch (spread edge to
    /// edge; shaders scale the lookup's minor axes by (n-1)/n), every level; see
    /// docs/conventions.md.
    #[arg(long, value_enum, default_value_t = cubeforge::internals::cube::EdgeFixup::None)]
    pub edge_fixup: cubeforge::internals::cube::EdgeFixup,
}

/// `--hdr-encoding`, shared by the commands that write maps.
#[derive(clap::Args, Debug)]
pub struct HdrEncodingArg {
    /// HDR in 8 bits: RGBM (L = rgb a R: rgbm6 as cmft writes, rgbm7 as three.js's RGBMLoader
    /// assumes, rgbm8, rgbm16 as its setMaxRange(16)) or Babylon's RGBD (L = rgb^2.2 / a, up
    /// to 255), into an 8-bit PNG or a KTX2/DDS with --gpu-format rgba8; prints the loader
    /// line; read back with --decode (PNGs, and KTX2s with --cubeforge-keys, say so themselves).
    #[arg(long, value_enum, value_name = "ENCODING")]
    pub hdr_encoding: Option<cubeforge::internals::io::HdrEncoding>,
}

/// `--cubeforge-keys`, shared by the commands that write KTX2 cube maps.
#[derive(clap::Args, Debug)]
pub struct CubeforgeKeysArg {
    /// KTX2 outputs also carry cubeforge's keys (cubeforge.hdrEncoding, cubeforge.edgeFixup,
    /// cubeforge.levels), which cubeforge reads back; `ktx validate -e` rejects such files
    /// (warning 7010), so by default they are left out: see docs/formats.md.
    #[arg(long)]
    pub cubeforge_keys: bool,
}

/// The flag groups of a command that writes prefiltered cube maps (prefilter, irradiance),
/// borrowed from its arguments.
pub struct CubeOutput<'a> {
    pub gpu_format: Option<cubeforge::GpuFormat>,
    pub zstd: &'a super::ZstdArg,
    pub exr: &'a super::ExrArg,
    pub fixup: &'a EdgeFixupArg,
    pub hdr8: &'a HdrEncodingArg,
    pub keys: &'a CubeforgeKeysArg,
}

impl CubeOutput<'_> {
    /// The `Encoding` these flags name, spelled once for every command that has them: faces
    /// in a folder written as `face_format`, radiance scaled by `exposure` stops.
    pub fn encoding(&self, face_format: FileFormat, exposure: f32) -> cubeforge::Encoding {
        cubeforge::Encoding {
            gpu_format: self.gpu_format,
            zstd: self.zstd.zstd,
            exr_float: self.exr.exr_float,
            edge_fixup: self.fixup.edge_fixup,
            hdr_encoding: self.hdr8.hdr_encoding,
            cubeforge_keys: self.keys.cubeforge_keys,
            face_format: Some(face_format),
            exposure,
            ..cubeforge::Encoding::default()
        }
    }
}
