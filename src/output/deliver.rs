//! The one write path: every command's files (faces, crosses, containers, chains, engine
//! deliveries, control maps, tables, previews, depfiles, the batch's state) land here. The
//! one output check refuses FIFOs and devices, inputs and two outputs onto one file, the
//! files are staged and committed all or none ([`crate::io::atomic`]), and standard output
//! is a destination of its own, never a file name made up by a front end.

use crate::error::{param, Error, Result};
use crate::io::{self, FileFormat};
use std::path::{Path, PathBuf};

/// Where a command's result goes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Destination {
    /// A file, or a folder for outputs of several files (faces, a chain).
    Path(PathBuf),
    /// Standard output, as one file of this type (a pipe or a redirection, never a terminal).
    Stdout(FileFormat),
}

impl Destination {
    /// `-` with `format` means standard output: the format must be one of those `allowed`
    /// (the refusal lists them). Any other path is itself. Standard output that is closed
    /// is refused here, before the work.
    pub fn parse(
        output: &Path,
        format: Option<&str>,
        allowed: impl Fn(FileFormat) -> bool,
    ) -> Result<Destination> {
        if output != Path::new("-") {
            return Ok(Destination::Path(output.to_path_buf()));
        }
        match format.and_then(FileFormat::from_ext_str) {
            Some(f) if allowed(f) => {
                stdout_open()?;
                Ok(Destination::Stdout(f))
            }
            _ => {
                let why = if FileFormat::ALL.iter().all(|&f| allowed(f)) {
                    ""
                } else if allowed(FileFormat::Ktx2) {
                    " (one file: a cube-map container)"
                } else {
                    " (one file: an image)"
                };
                let given = format.map(|f| format!(", not {f}")).unwrap_or_default();
                Err(Error::usage(format!(
                    "-o - (standard output) needs {} {}{why}{given}",
                    param("format"),
                    FileFormat::list(&allowed, false),
                )))
            }
        }
    }

    /// The name encoders see: the path, or `-.EXT` for standard output (the extension picks
    /// the encoder).
    pub fn name(&self) -> PathBuf {
        match self {
            Destination::Path(p) => p.clone(),
            Destination::Stdout(f) => PathBuf::from(format!("-.{}", f.extension())),
        }
    }

    /// Whether the result goes to standard output.
    pub fn is_stdout(&self) -> bool {
        matches!(self, Destination::Stdout(_))
    }
}

/// What a command writes: files in order, and the folders among their parents that are
/// outputs in their own right (six faces, a chain), replaced whole.
#[derive(Clone, Debug, Default)]
pub struct Files {
    /// Each file's final path and its bytes.
    pub files: Vec<(PathBuf, Vec<u8>)>,
    /// Folder outputs, replaced whole.
    pub folders: Vec<PathBuf>,
    /// Files an earlier run of another kind may have left in the folder outputs (another
    /// `ibl` target's): cubeforge's, so they go with the folder instead of stopping it.
    pub known: Vec<PathBuf>,
}

impl Files {
    /// Files with no folder output.
    pub fn new(files: Vec<(PathBuf, Vec<u8>)>) -> Files {
        Files {
            files,
            folders: Vec::new(),
            known: Vec::new(),
        }
    }

    /// The paths written, in order.
    pub fn paths(&self) -> Vec<PathBuf> {
        self.files.iter().map(|(p, _)| p.clone()).collect()
    }
}

/// Writes `out` to `dest`: refuses what [`super::check_outputs`] refuses (a FIFO or a device,
/// two outputs onto one file, one of `inputs`, a folder output that holds one), then stages
/// and commits every file, all or none; or writes its one file to standard
/// output. A reader that went away from standard output is an [`Error::Io`] of kind
/// `BrokenPipe` on `-`, for the front end to end quietly.
pub fn deliver(out: &Files, dest: &Destination, inputs: &[PathBuf]) -> Result<()> {
    if let Destination::Stdout(_) = dest {
        if out.files.len() != 1 {
            return Err(Error::usage(format!(
                "-o - (standard output) takes one file, and this output is {} files",
                out.files.len()
            )));
        }
        use std::io::IsTerminal;
        if std::io::stdout().is_terminal() {
            return Err(Error::usage(
                "-o -: standard output is a terminal; redirect it to a file or a pipe",
            ));
        }
        return write_stdout(&out.files[0].1);
    }
    super::check_outputs(&out.paths(), &out.folders, inputs)?;
    let staged = io::stage_replacing(&out.files, &out.folders, &out.known)?;
    // Tests stop here to signal a command that has written its temporaries.
    if let Some(ms) = std::env::var("CUBEFORGE_TEST_PAUSE_BEFORE_COMMIT_MS")
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
    {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
    staged.commit()
}

/// Writes `bytes`, a command's data (a file, `info`'s text, help), to standard output and
/// flushes. Refuses a standard output that was closed when the process started.
pub fn write_stdout(bytes: &[u8]) -> Result<()> {
    // `cubeforge convert ... -o - >&-` must not exit 0 having written nothing.
    stdout_open()?;
    write_summary(bytes)
}

/// Writes `bytes`, a summary of what a command did (its files are its product), to standard
/// output and flushes: a standard output closed at start, or opened on /dev/null, takes it
/// and says nothing. A full disk is still an error.
pub fn write_summary(bytes: &[u8]) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_all(bytes)
        .and_then(|()| out.flush())
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::BrokenPipe => Error::io("-", e),
            _ => Error::usage(format!(
                "cannot write to standard output: {}",
                io::io_msg(&e)
            )),
        })
}

/// Whether `e` is standard output's reader having gone away (`| head`): not a failure.
pub fn is_closed_pipe(e: &Error) -> bool {
    matches!(e, Error::Io { path, source } if path == Path::new("-")
        && source.kind() == std::io::ErrorKind::BrokenPipe)
}

/// Refuses a closed standard output.
pub fn stdout_open() -> Result<()> {
    if stdout_closed() {
        return Err(Error::usage(
            "cannot write to standard output: it is closed",
        ));
    }
    Ok(())
}

/// Whether the process started with standard output closed (`>&-`). Rust's start-up puts a
/// read-write /dev/null on a closed standard stream, which cannot be told from the one a
/// parent opens on purpose (Python's `stdout=subprocess.DEVNULL`, build systems, test
/// harnesses), so the descriptor is looked at before that start-up, by a constructor.
fn stdout_closed() -> bool {
    STDOUT_CLOSED_AT_START.load(std::sync::atomic::Ordering::Relaxed)
}

static STDOUT_CLOSED_AT_START: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// Runs before `main` (and before Rust's start-up touches the standard streams) in every
/// program that links cubeforge.
#[cfg(any(target_os = "linux", target_os = "android", target_os = "macos"))]
#[used]
#[cfg_attr(
    any(target_os = "linux", target_os = "android"),
    link_section = ".init_array"
)]
#[cfg_attr(target_os = "macos", link_section = "__DATA,__mod_init_func")]
static RECORD_STDOUT: extern "C" fn() = record_stdout;

#[cfg(any(target_os = "linux", target_os = "android", target_os = "macos"))]
extern "C" fn record_stdout() {
    // SAFETY: F_GETFD only reads descriptor 1's flags; -1 (EBADF) means it is not open.
    let closed = unsafe { libc::fcntl(1, libc::F_GETFD) } == -1;
    STDOUT_CLOSED_AT_START.store(closed, std::sync::atomic::Ordering::Relaxed);
}
