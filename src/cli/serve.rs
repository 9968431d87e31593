//! `view --serve`: the viewer's folder over HTTP on this machine. GET and HEAD of the files in
//! the folder, nothing else; 127.0.0.1 unless --bind says otherwise; until Ctrl-C.

use cubeforge::{Error, Result};
use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Component, Path};

fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()) {
        Some("html") => "text/html; charset=utf-8",
        Some("js") => "text/javascript; charset=utf-8",
        Some("png") => "image/png",
        _ => "application/octet-stream",
    }
}

/// Answers one request: a file of `dir`, or 404 (any path that leaves the folder included).
fn answer(dir: &Path, stream: TcpStream) -> std::io::Result<()> {
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    let mut header = String::new();
    while reader.read_line(&mut header)? > 2 {
        header.clear();
    }
    let mut parts = line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
    let path = target.split(['?', '#']).next().unwrap_or("/");
    let rel = Path::new(path.trim_start_matches('/'));
    let safe = rel.components().all(|c| matches!(c, Component::Normal(_)));
    let file = if path == "/" {
        dir.join("index.html")
    } else {
        dir.join(rel)
    };
    let mut out = stream;
    match (method, safe || path == "/", std::fs::read(&file)) {
        ("GET" | "HEAD", true, Ok(bytes)) => {
            write!(
                out,
                "HTTP/1.1 200 OK\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n\r\n",
                content_type(&file),
                bytes.len()
            )?;
            if method == "GET" {
                out.write_all(&bytes)?;
            }
        }
        ("GET" | "HEAD", _, _) => {
            out.write_all(b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n")?
        }
        _ => out.write_all(
            b"HTTP/1.1 405 Method Not Allowed\r\nAllow: GET, HEAD\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
        )?,
    }
    out.flush()
}

/// Serves `dir` on `bind` at a free port, printing the page's address, until the process is
/// stopped.
pub fn serve(dir: &Path, page: &Path, bind: &str) -> Result<()> {
    let listener = TcpListener::bind((bind, 0))
        .map_err(|e| Error::usage(format!("--serve: cannot listen on {bind}: {e}")))?;
    let addr = listener
        .local_addr()
        .map_err(|e| Error::usage(format!("--serve: {e}")))?;
    super::say(format!(
        "serving {} at http://{addr}/{} (Ctrl-C stops)",
        dir.display(),
        page.display()
    ))?;
    for stream in listener.incoming().flatten() {
        let dir = dir.to_path_buf();
        std::thread::spawn(move || {
            let _ = answer(&dir, stream);
        });
    }
    Ok(())
}
