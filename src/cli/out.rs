//! Where a command's output goes: files written all or none (folder outputs replaced whole),
//! or one file on standard output (`-o -`), which must be open and whose failures are said.

use cubeforge::io::FileFormat;

/// Set when the command's output file goes to standard output (`-o -`).
pub(super) static DATA_ON_STDOUT: std::sync::atomic::AtomicBool =
    std::sync::atomic::AtomicBool::new(false);

/// Writes to standard output and flushes: a reader that went away ends the process quietly,
/// any other failure is one error line.
pub(super) fn write_stdout(
    write: impl FnOnce(&mut std::io::StdoutLock<'static>) -> std::io::Result<()>,
) -> cubeforge::Result<()> {
    use std::io::Write;
    // `cubeforge convert ... -o - >&-` must not exit 0 having written nothing.
    stdout_open()?;
    let mut out = std::io::stdout().lock();
    match write(&mut out).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => Err(cubeforge::Error::usage(format!(
            "cannot write to standard output: {}",
            cubeforge::io::io_msg(&e)
        ))),
    }
}

/// Writes a command's files, all or none (see [`cubeforge::io::atomic`]).
pub fn write_files(files: &[(std::path::PathBuf, Vec<u8>)]) -> cubeforge::Result<()> {
    write_output(files, &[])
}

/// [`write_files`], where each of `folders` (six faces, a chain) replaces its folder whole.
fn write_output(
    files: &[(std::path::PathBuf, Vec<u8>)],
    folders: &[std::path::PathBuf],
) -> cubeforge::Result<()> {
    let staged = cubeforge::io::stage_with(files, folders)?;
    // Tests stop here to signal a command that has written its temporaries.
    if let Some(ms) = std::env::var("CUBEFORGE_TEST_PAUSE_BEFORE_COMMIT_MS")
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
    {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
    staged.commit()
}

/// `-o -` writes to standard output: the name that stands in for it, whose extension (from
/// `--format`) picks the encoder, and whether that is what happens.
pub fn output_name(
    output: &std::path::Path,
    format: Option<&str>,
) -> cubeforge::Result<(std::path::PathBuf, bool)> {
    stdout_name(output, format, |_| true, "needs")
}

/// `-o -` for a command whose output may be several files (a chain, faces): one container
/// to standard output, named by `format`; anything else is refused before the work.
pub fn container_output(
    output: &std::path::Path,
    format: Option<&str>,
) -> cubeforge::Result<(std::path::PathBuf, bool)> {
    stdout_name(
        output,
        format,
        FileFormat::is_container,
        "takes one file, a container: add",
    )
}

/// The name standing in for standard output when `output` is `-` and `format` is one of
/// those `allowed` (the refusal lists them after `says`).
fn stdout_name(
    output: &std::path::Path,
    format: Option<&str>,
    allowed: impl Fn(FileFormat) -> bool,
    says: &str,
) -> cubeforge::Result<(std::path::PathBuf, bool)> {
    if output != std::path::Path::new("-") {
        return Ok((output.to_path_buf(), false));
    }
    match format.and_then(FileFormat::from_ext_str) {
        Some(f) if allowed(f) => {
            stdout_for_data()?;
            let name = format!("-.{}", f.extension());
            Ok((std::path::PathBuf::from(name), true))
        }
        _ => {
            let list: Vec<&str> = FileFormat::ALL
                .iter()
                .filter(|&&f| allowed(f))
                .map(|f| f.extension())
                .collect();
            Err(cubeforge::Error::usage(format!(
                "-o - (standard output) {says} --format {}",
                list.join(", ")
            )))
        }
    }
}

/// Whether the process started with standard output closed (`>&-`).
static STDOUT_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Run first: remembers whether the process started with standard output closed. Rust's
/// start-up puts /dev/null on a closed standard stream (opened for reading and writing), so
/// writes to it succeed and go nowhere: `cubeforge convert ... -o - >&-` would exit 0 having
/// written nothing. A shell's `> /dev/null` opens it for writing only, so the two differ.
pub fn remember_closed_stdout() {
    #[cfg(unix)]
    // SAFETY: fcntl and fstat only read the descriptor's flags and status into `st`, and
    // stat reads a NUL-terminated path.
    unsafe {
        let mut st: libc::stat = std::mem::zeroed();
        let mut null: libc::stat = std::mem::zeroed();
        let flags = libc::fcntl(1, libc::F_GETFL);
        let closed = flags != -1
            && flags & libc::O_ACCMODE == libc::O_RDWR
            && libc::fstat(1, &mut st) == 0
            && libc::stat(c"/dev/null".as_ptr(), &mut null) == 0
            && (st.st_dev, st.st_ino) == (null.st_dev, null.st_ino);
        STDOUT_CLOSED.store(closed, std::sync::atomic::Ordering::Relaxed);
    }
}

/// Standard output will carry the output file: refused when closed (before any work), and
/// from now on summaries go to standard error.
fn stdout_for_data() -> cubeforge::Result<()> {
    DATA_ON_STDOUT.store(true, std::sync::atomic::Ordering::Relaxed);
    stdout_open()
}

/// Refuses a closed standard output.
fn stdout_open() -> cubeforge::Result<()> {
    if STDOUT_CLOSED.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(cubeforge::Error::usage(
            "cannot write to standard output: it is closed",
        ));
    }
    Ok(())
}

/// Writes a command's files (folder outputs replaced whole), or its one file to standard
/// output.
pub fn deliver(
    files: &[(std::path::PathBuf, Vec<u8>)],
    folders: &[std::path::PathBuf],
    to_stdout: bool,
) -> cubeforge::Result<()> {
    if !to_stdout {
        return write_output(files, folders);
    }
    if files.len() != 1 {
        return Err(cubeforge::Error::usage(format!(
            "-o - (standard output) takes one file, and this output is {} files",
            files.len()
        )));
    }
    use std::io::{IsTerminal, Write};
    if std::io::stdout().is_terminal() {
        return Err(cubeforge::Error::usage(
            "-o -: standard output is a terminal; redirect it to a file or a pipe",
        ));
    }
    files
        .iter()
        .try_for_each(|(_, bytes)| write_stdout(|out| out.write_all(bytes)))
}
