//! `view --serve` over plain HTTP/1.1 (the folder's files and nothing else, on 127.0.0.1),
//! and the outputs `view` refuses.

use super::{done, work, SKY_EXR};
use crate::cli_options::run;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

/// The server, killed when the test ends (passed or not).
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// One request with `Connection: close`; the status code and the body.
fn request(addr: &str, method: &str, path: &str) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap_or_else(|e| panic!("connect {addr}: {e}"));
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    write!(
        s,
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut bytes = Vec::new();
    s.read_to_end(&mut bytes).unwrap();
    let head_end = bytes
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("{method} {path}: no header in {bytes:?}"));
    let head = String::from_utf8_lossy(&bytes[..head_end]).into_owned();
    let status = head
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or_else(|| panic!("{method} {path}: status line {head:?}"));
    assert!(head.starts_with("HTTP/1.1 "), "{head}");
    (status, bytes[head_end + 4..].to_vec())
}

/// `view --serve` writes the folder, prints its address (127.0.0.1, a free port) and serves
/// GET of the folder's files: 200 with the files' bytes; a path out of the folder or to no
/// file is 404; POST is 405.
#[test]
fn serve_answers_with_the_folders_files_only() {
    let dir = work("serve");
    let child = Command::new(env!("CARGO_BIN_EXE_cubeforge"))
        .args(["view", SKY_EXR, "-o", "site", "--serve"])
        .current_dir(&dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("cubeforge runs");
    let mut server = Server(child);
    // The address line, read on a thread so that a server that never prints fails the test.
    let stdout = server.0.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if line.starts_with("serving ") {
                let _ = tx.send(line);
                return;
            }
        }
    });
    let line = rx
        .recv_timeout(Duration::from_secs(120))
        .expect("view --serve prints `serving DIR at URL`");
    let url = line
        .split_whitespace()
        .find(|w| w.starts_with("http://"))
        .unwrap_or_else(|| panic!("no URL in {line:?}"));
    assert!(
        line.ends_with("(Ctrl-C stops)") && url.ends_with("/index.html"),
        "{line}"
    );
    let addr = url
        .trim_start_matches("http://")
        .split('/')
        .next()
        .unwrap()
        .to_owned();
    let (host, port) = addr.rsplit_once(':').unwrap();
    assert_eq!(host, "127.0.0.1", "--serve listens on this machine only");
    let port: u16 = port.parse().unwrap_or_else(|_| panic!("{addr}"));
    // Bound to 127.0.0.1, not to every address: another loopback address is refused (Linux
    // routes all of 127/8 to this machine; elsewhere it is unreachable, refused all the same).
    let other = std::net::SocketAddr::from(([127, 0, 0, 2], port));
    assert!(
        TcpStream::connect_timeout(&other, Duration::from_secs(2)).is_err(),
        "--serve answers on 127.0.0.2 too: it listens on more than 127.0.0.1"
    );

    let site = dir.join("site");
    let file = |name: &str| std::fs::read(site.join(name)).unwrap();
    assert_eq!(request(&addr, "GET", "/"), (200, file("index.html")));
    assert_eq!(
        request(&addr, "GET", "/index.html?material=glass"),
        (200, file("index.html"))
    );
    let (status, body) = request(&addr, "GET", "/data.js");
    assert_eq!(status, 200);
    assert!(body == file("data.js"), "/data.js: other bytes");
    for path in [
        "/../Cargo.toml",
        "/../../Cargo.toml",
        "/%2e%2e/Cargo.toml",
        "/nothing",
        "//etc/passwd",
    ] {
        assert_eq!(request(&addr, "GET", path).0, 404, "GET {path}");
    }
    assert_eq!(request(&addr, "HEAD", "/viewer.js"), (200, Vec::new()));
    assert_eq!(request(&addr, "POST", "/index.html").0, 405);
    assert_eq!(request(&addr, "DELETE", "/data.js").0, 405);
    assert!(site.join("data.js").is_file());
    // Still serving after all that.
    assert_eq!(request(&addr, "GET", "/ui.js"), (200, file("ui.js")));
    drop(server);
    done(&dir);
}

/// A page name without --single-file, --single-file with a folder, and standard output: exit
/// 1 with one line, nothing written.
#[test]
fn outputs_view_refuses() {
    let dir = work("refusals");
    for (args, says) in [
        (&["-o", "x.html"][..], "--single-file"),
        (&["-o", "dir", "--single-file"][..], ".html"),
        (&["-o", "-"][..], "standard output"),
    ] {
        let mut all = vec!["view", SKY_EXR];
        all.extend_from_slice(args);
        let o = run(&all, &dir);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(o.stdout.is_empty(), "{args:?}");
    }
    let left: Vec<_> = std::fs::read_dir(&dir).unwrap().collect();
    assert!(left.is_empty(), "a refused view wrote {left:?}");
    assert!(!Path::new(&dir).join("x.html").exists());
    done(&dir);
}

/// `--linear` reaches the page: the 8-bit demo sky read as data (no sRGB decode) is other
/// data than read as colour (the flag was once dropped on the way to the job).
#[test]
fn linear_reads_an_8_bit_input_as_data() {
    let dir = work("linear");
    let png = super::SKY_PNG;
    for (out, extra) in [("colour", None), ("data", Some("--linear"))] {
        let mut args = vec!["view", png, "-o", out];
        args.extend(extra);
        let o = run(&args, &dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let data = |out: &str| std::fs::read(dir.join(out).join("data.js")).unwrap();
    assert!(data("colour") != data("data"), "--linear changed nothing");
    done(&dir);
}
