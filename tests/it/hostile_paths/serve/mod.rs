//! Issue 44, items 3, 6 and 8: the viewer's page and `view --serve` against hostile input. The
//! page: an input path that closes the inline script (`page`); query names that are
//! Object.prototype's (`page`). The server: files it did not write, links out of the folder,
//! FIFOs, endless request lines, idle clients, foreign `Host` headers and floods of
//! connections (`server`). Every socket read here has a timeout and every server is killed
//! when its test ends, passed or not.

mod page;
mod server;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

pub(crate) const SKY_EXR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/sky.exr");

/// How long a test waits on any one answer before it fails (the server answers in
/// milliseconds; a blocked server must fail the test, not hang it).
const WAIT: Duration = Duration::from_secs(10);

/// A running `cubeforge view ... --serve`, killed when dropped.
pub(crate) struct Server {
    child: Child,
    /// `127.0.0.1:PORT`, as printed.
    pub addr: String,
    /// The page's URL path (`/index.html`, `/NAME.html`).
    pub page: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Server {
    /// `cubeforge view ARGS --serve` in `dir`, with `CUBEFORGE_SERVE_TIMEOUT_MS` when given;
    /// returns once it prints its address.
    pub(crate) fn start(dir: &Path, args: &[&str], timeout_ms: Option<u64>) -> Server {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_cubeforge"));
        cmd.arg("view")
            .args(args)
            .arg("--serve")
            .current_dir(dir)
            .stdout(Stdio::piped())
            .stderr(Stdio::null());
        if let Some(ms) = timeout_ms {
            cmd.env("CUBEFORGE_SERVE_TIMEOUT_MS", ms.to_string());
        }
        let mut child = cmd.spawn().expect("cubeforge runs");
        let stdout = child.stdout.take().unwrap();
        let mut server = Server {
            child,
            addr: String::new(),
            page: String::new(),
        };
        // The address line, read on a thread so that a server that never prints fails the test.
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if line.starts_with("serving ") {
                    let _ = tx.send(line);
                }
            }
        });
        let line = rx
            .recv_timeout(Duration::from_secs(120))
            .expect("view --serve prints `serving DIR at URL`");
        let url = line
            .split_whitespace()
            .find_map(|w| w.strip_prefix("http://"))
            .unwrap_or_else(|| panic!("no URL in {line:?}"));
        let (addr, page) = url.split_at(url.find('/').expect("a path"));
        server.addr = addr.to_owned();
        server.page = page.to_owned();
        server
    }

    pub(crate) fn port(&self) -> u16 {
        self.addr.rsplit_once(':').unwrap().1.parse().unwrap()
    }

    pub(crate) fn connect(&self) -> TcpStream {
        let s = TcpStream::connect(&self.addr).unwrap_or_else(|e| panic!("{}: {e}", self.addr));
        s.set_read_timeout(Some(WAIT)).unwrap();
        s.set_write_timeout(Some(WAIT)).unwrap();
        s
    }

    /// Sends `head` (a whole request head, CRLFs and all) on a new connection; the status and
    /// body of the answer.
    pub(crate) fn raw(&self, head: &str) -> (u16, Vec<u8>) {
        let mut s = self.connect();
        s.write_all(head.as_bytes()).unwrap();
        answer(&mut s, head.lines().next().unwrap_or(""))
    }

    /// `METHOD PATH` with this server's own `Host`.
    pub(crate) fn ask(&self, method: &str, path: &str) -> (u16, Vec<u8>) {
        self.raw(&format!(
            "{method} {path} HTTP/1.1\r\nHost: {}\r\nConnection: close\r\n\r\n",
            self.addr
        ))
    }

    pub(crate) fn get(&self, path: &str) -> (u16, Vec<u8>) {
        self.ask("GET", path)
    }
}

/// The answer on `s` read to its end (within [`WAIT`]): its status code and body. A reset
/// after the answer keeps what came before it.
pub(crate) fn answer(s: &mut TcpStream, what: &str) -> (u16, Vec<u8>) {
    let start = Instant::now();
    let mut bytes = Vec::new();
    let read = s.read_to_end(&mut bytes);
    assert!(
        start.elapsed() < WAIT,
        "{what:.80}: no answer in {WAIT:?} ({read:?}, {} bytes): the server is blocked",
        bytes.len()
    );
    let head_end = bytes
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("{what:.80}: no answer head in {bytes:?} ({read:?})"));
    let head = String::from_utf8_lossy(&bytes[..head_end]).into_owned();
    assert!(head.starts_with("HTTP/1.1 "), "{what:.80}: {head}");
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("{what:.80}: status line {head:?}"));
    (status, bytes[head_end + 4..].to_vec())
}

/// A FIFO at `path` (mkfifo(3)).
pub(crate) fn fifo(path: &Path) {
    use std::os::unix::ffi::OsStrExt;
    let c = std::ffi::CString::new(path.as_os_str().as_bytes()).unwrap();
    // SAFETY: a NUL-terminated path that lives across the call.
    let made = unsafe { libc::mkfifo(c.as_ptr(), 0o644) };
    assert_eq!(made, 0, "mkfifo {}", path.display());
}
