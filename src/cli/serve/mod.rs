//! `view --serve`: the page `view` wrote, over HTTP on this machine, and nothing else: GET and
//! HEAD of the files the job wrote (whatever else the folder holds is 404), each opened only
//! if it is a regular file (never a link, a FIFO or a device, never waited on); requests
//! bounded in size and time (`request`), a `Host` that names the bound address (DNS
//! rebinding), and at most [`CONNECTIONS`] connections at once (503 beyond). 127.0.0.1 unless
//! --bind says otherwise; until Ctrl-C.

mod request;

use cubeforge::{Error, Result};
use request::{Refused, Request, Timed};
use std::io::{self, BufReader, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Connections served at once; one more is answered 503 at once (a browser opens about six).
const CONNECTIONS: usize = 16;

/// How long a connection may take to send its request, and a write may wait on the client.
const TIMEOUT: Duration = Duration::from_secs(10);

/// Shortens [`TIMEOUT`] for tests (milliseconds); not meant for anything else.
const TIMEOUT_VAR: &str = "CUBEFORGE_SERVE_TIMEOUT_MS";

/// What is served: the written files by URL name (the page also at `/`), and where the
/// server listens, which a request's `Host` must name.
struct Site {
    files: Vec<(String, PathBuf)>,
    page: String,
    bound: SocketAddr,
    bind: String,
    timeout: Duration,
}

fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()) {
        Some("html") => "text/html; charset=utf-8",
        Some("js") => "text/javascript; charset=utf-8",
        _ => "application/octet-stream",
    }
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        404 => "Not Found",
        405 => "Method Not Allowed",
        408 => "Request Timeout",
        414 => "URI Too Long",
        421 => "Misdirected Request",
        431 => "Request Header Fields Too Large",
        _ => "Service Unavailable",
    }
}

/// A response with no body.
fn status_only(out: &mut impl Write, status: u16) -> io::Result<()> {
    let extra = match status {
        405 => "Allow: GET, HEAD\r\n",
        503 => "Retry-After: 1\r\n",
        _ => "",
    };
    write!(
        out,
        "HTTP/1.1 {status} {}\r\n{extra}Content-Length: 0\r\nConnection: close\r\n\r\n",
        reason(status)
    )?;
    out.flush()
}

/// Opens `path` for reading if it is a regular file, itself and not through a link. Anything
/// else is refused before it is opened; the open neither follows a link nor waits on a FIFO's
/// writer (a file swapped in between), and the type is read again from the open file, so what
/// is checked is what is read.
fn open_regular(path: &Path) -> io::Result<(std::fs::File, u64)> {
    if !std::fs::symlink_metadata(path)?.is_file() {
        return Err(io::ErrorKind::InvalidInput.into());
    }
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK | libc::O_NOFOLLOW);
    }
    let file = options.open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(io::ErrorKind::InvalidInput.into());
    }
    Ok((file, meta.len()))
}

/// `%XX` escapes decoded; None for a broken escape.
fn percent_decode(s: &str) -> Option<Vec<u8>> {
    let (mut out, bytes) = (Vec::with_capacity(s.len()), s.as_bytes());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    Some(out)
}

/// Characters of a file name kept as they are in the printed URL; the rest as `%XX`.
fn percent_encode(name: &str) -> String {
    name.bytes()
        .map(|b| match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'-' | b'.' | b'_' | b'~' => {
                (b as char).to_string()
            }
            _ => format!("%{b:02X}"),
        })
        .collect()
}

/// The answer to a request read whole.
fn respond(site: &Site, req: &Request, out: &mut TcpStream) -> io::Result<()> {
    if !req
        .host
        .as_deref()
        .is_some_and(|h| request::host_ok(h, site.bound, &site.bind))
    {
        return status_only(out, if req.host.is_none() { 400 } else { 421 });
    }
    if req.method != "GET" && req.method != "HEAD" {
        return status_only(out, 405);
    }
    let path = req.target.split(['?', '#']).next().unwrap_or("/");
    let name = match percent_decode(&path[1..]) {
        Some(n) if n.is_empty() => site.page.clone().into_bytes(),
        Some(n) => n,
        None => return status_only(out, 400),
    };
    let file = site
        .files
        .iter()
        .find(|(n, _)| n.as_bytes() == name.as_slice())
        .map(|(_, p)| p);
    let Some((path, (file, len))) = file.and_then(|p| Some((p, open_regular(p).ok()?))) else {
        return status_only(out, 404);
    };
    write!(
        out,
        "HTTP/1.1 200 OK\r\nContent-Type: {}\r\nContent-Length: {len}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        content_type(path),
    )?;
    if req.method == "GET" {
        io::copy(&mut file.take(len), out)?;
    }
    out.flush()
}

/// After a refusal, what the client still sends is read and dropped for a moment, so that the
/// answer reaches it (closing on unread bytes would reset the connection over the answer).
fn linger(stream: &TcpStream) {
    let _ = stream.shutdown(std::net::Shutdown::Write);
    let mut timed = Timed {
        stream,
        until: Instant::now() + Duration::from_secs(1),
    };
    let _ = io::copy(&mut (&mut timed).take(16 << 20), &mut io::sink());
}

/// One connection: one request read within bounds and answered, then closed.
fn connection(site: &Site, mut stream: TcpStream) -> io::Result<()> {
    stream.set_write_timeout(Some(site.timeout))?;
    let timed = Timed {
        stream: &stream,
        until: Instant::now() + site.timeout,
    };
    let got = request::read(&mut BufReader::new(timed));
    match got {
        Ok(req) => respond(site, &req, &mut stream),
        Err(Refused::Gone) => Ok(()),
        Err(Refused::Status(status)) => {
            status_only(&mut stream, status)?;
            linger(&stream);
            Ok(())
        }
    }
}

/// A connection beyond [`CONNECTIONS`]: 503 at once, without waiting on the client.
fn busy(stream: TcpStream) {
    let _ = stream.set_nonblocking(true);
    let _ = (&stream).read(&mut [0; 8192]);
    let _ = stream.set_write_timeout(Some(Duration::from_secs(1)));
    let _ = status_only(&mut &stream, 503);
}

/// Gives its connection's place back when the connection's thread ends.
struct Slot(Arc<AtomicUsize>);

impl Drop for Slot {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

fn timeout() -> Result<Duration> {
    match std::env::var(TIMEOUT_VAR) {
        Err(_) => Ok(TIMEOUT),
        Ok(v) => match v.parse::<u64>() {
            Ok(ms) if ms > 0 => Ok(Duration::from_millis(ms)),
            _ => Err(Error::usage(format!(
                "{TIMEOUT_VAR} must be a number of milliseconds, at least 1 (got {v:?})"
            ))),
        },
    }
}

/// Serves `written` (the files `view` wrote, the page first) on `bind` at a free port,
/// printing the page's address, until the process is stopped.
pub fn serve(written: &[PathBuf], bind: &str) -> Result<()> {
    let timeout = timeout()?;
    let listener = TcpListener::bind((bind, 0))
        .map_err(|e| Error::usage(format!("--serve: cannot listen on {bind}: {e}")))?;
    let bound = listener
        .local_addr()
        .map_err(|e| Error::usage(format!("--serve: {e}")))?;
    let name = |p: &PathBuf| {
        p.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let files: Vec<(String, PathBuf)> = written.iter().map(|p| (name(p), p.clone())).collect();
    let page = files.first().map(|f| f.0.clone()).unwrap_or_default();
    let dir = written
        .first()
        .and_then(|p| p.parent())
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    super::say(format!(
        "serving {} at http://{bound}/{} (Ctrl-C stops)",
        dir.display(),
        percent_encode(&page)
    ))?;
    let site = Arc::new(Site {
        files,
        page,
        bound,
        bind: bind.to_owned(),
        timeout,
    });
    let active = Arc::new(AtomicUsize::new(0));
    for stream in listener.incoming() {
        let Ok(stream) = stream else {
            // Out of descriptors, say: a moment for connections to end.
            std::thread::sleep(Duration::from_millis(50));
            continue;
        };
        if active.fetch_add(1, Ordering::SeqCst) >= CONNECTIONS {
            active.fetch_sub(1, Ordering::SeqCst);
            busy(stream);
            continue;
        }
        let (slot, site) = (Slot(Arc::clone(&active)), Arc::clone(&site));
        let _ = std::thread::Builder::new().spawn(move || {
            let _slot = slot;
            let _ = connection(&site, stream);
        });
    }
    Ok(())
}
