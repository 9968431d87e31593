//! Where a command's output goes, as the command line names it: `-o -` with `--format` is
//! standard output ([`Destination::Stdout`]); the writing itself is the library's
//! ([`cubeforge::output::deliver`]).

use cubeforge::io::FileFormat;
use cubeforge::output::{self, Destination, Files};

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

/// Writes a command's files, all or none (see [`cubeforge::io::atomic`]).
pub fn write_files(files: &[(std::path::PathBuf, Vec<u8>)]) -> cubeforge::Result<()> {
    output::deliver(
        &Files::new(files.to_vec()),
        &Destination::Path(".".into()),
        &[],
    )
}

/// `-o -` writes to standard output: the name that stands in for it, whose extension (from
/// `--format`) picks the encoder, and whether that is what happens.
pub fn output_name(
    output: &std::path::Path,
    format: Option<&str>,
) -> cubeforge::Result<(std::path::PathBuf, bool)> {
    let d = destination(output, format, |_| true)?;
    Ok((d.name(), d.is_stdout()))
}

/// `-o -` for a command whose output may be several files (a chain, faces): one container
/// to standard output, named by `format`; anything else is refused before the work.
pub fn container_output(
    output: &std::path::Path,
    format: Option<&str>,
) -> cubeforge::Result<(std::path::PathBuf, bool)> {
    let d = destination(output, format, FileFormat::is_container)?;
    Ok((d.name(), d.is_stdout()))
}

/// Writes a command's files (folder outputs replaced whole), or its one file to standard
/// output.
pub fn deliver(
    files: &[(std::path::PathBuf, Vec<u8>)],
    folders: &[std::path::PathBuf],
    to_stdout: bool,
) -> cubeforge::Result<()> {
    let dest = match (to_stdout, files.first()) {
        (true, Some((p, _))) => {
            Destination::Stdout(FileFormat::from_extension(p).unwrap_or(FileFormat::Ktx2))
        }
        _ => Destination::Path(".".into()),
    };
    let out = Files {
        files: files.to_vec(),
        folders: folders.to_vec(),
    };
    quietly(output::deliver(&out, &dest, &[]))
}
