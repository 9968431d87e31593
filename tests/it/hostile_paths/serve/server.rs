//! `view --serve` against hostile folders and clients (issue 44, items 6 and 8).

use super::{answer, fifo, Server, SKY_EXR};
use std::io::Write;
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

/// `GET path` is 404, answered at once (a FIFO opened for reading would block it for ever).
fn not_found(server: &Server, path: &str) {
    let start = Instant::now();
    assert_eq!(server.get(path).0, 404, "GET {path}");
    assert!(
        start.elapsed() < Duration::from_secs(5),
        "GET {path} took {:?}",
        start.elapsed()
    );
}

/// A folder that held files before `view`, and files, links and FIFOs planted in it after:
/// only what view wrote is served (bytes as written); a name view wrote that is now a link or
/// a FIFO is 404 too, at once; the server serves on after all of it.
#[test]
fn serve_gives_what_view_wrote_and_nothing_else() {
    let t = tempfile::tempdir().unwrap();
    let (dir, site) = (t.path(), t.path().join("site"));
    std::fs::create_dir(&site).unwrap();
    std::fs::write(site.join("secret.txt"), "held before view").unwrap();
    std::fs::write(dir.join("outside.txt"), "outside the folder").unwrap();
    let server = Server::start(dir, &[SKY_EXR, "-o", "site"], None);
    assert_eq!(server.page, "/index.html");
    assert!(site.join("secret.txt").is_file(), "view removed a file");
    std::fs::write(site.join("planted.txt"), "planted after view").unwrap();
    std::os::unix::fs::symlink("/", site.join("root")).unwrap();
    std::os::unix::fs::symlink("../outside.txt", site.join("outside.txt")).unwrap();
    fifo(&site.join("pipe"));
    for path in [
        "/secret.txt",
        "/planted.txt",
        "/root",
        "/root/etc/hostname",
        "/root%2fetc%2fhostname",
        "/outside.txt",
        "/pipe",
        "/%2e%2e/outside.txt",
        "/../outside.txt",
    ] {
        not_found(&server, path);
    }
    let file = |name: &str| std::fs::read(site.join(name)).unwrap();
    assert_eq!(server.get("/"), (200, file("index.html")));
    assert!(server.get("/data.js") == (200, file("data.js")), "/data.js");
    // Names view wrote, now a FIFO and a link out of the folder.
    std::fs::remove_file(site.join("ui.js")).unwrap();
    fifo(&site.join("ui.js"));
    std::fs::remove_file(site.join("shaders.js")).unwrap();
    std::os::unix::fs::symlink("../outside.txt", site.join("shaders.js")).unwrap();
    not_found(&server, "/ui.js");
    not_found(&server, "/shaders.js");
    assert_eq!(server.get("/viewer.js"), (200, file("viewer.js")));
}

/// `--single-file`: the page alone is served (at its name and at `/`), not the folder it is in.
#[test]
fn serve_gives_a_single_page_alone() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out");
    std::fs::create_dir(&out).unwrap();
    std::fs::write(out.join("other.html"), "another page").unwrap();
    let server = Server::start(
        t.path(),
        &[SKY_EXR, "-o", "out/sky view.html", "--single-file"],
        None,
    );
    assert_eq!(server.page, "/sky%20view.html");
    let page = std::fs::read(out.join("sky view.html")).unwrap();
    assert_eq!(server.get("/sky%20view.html"), (200, page.clone()));
    assert_eq!(server.get("/?material=glass"), (200, page));
    for path in [
        "/other.html",
        "/index.html",
        "/data.js",
        "/sky%20view.html/",
    ] {
        not_found(&server, path);
    }
}

/// A 1 MiB request line without a newline, too many headers, one huge header, a broken
/// request line: each refused with its status at once, and the server serves on.
#[test]
fn serve_bounds_requests() {
    let t = tempfile::tempdir().unwrap();
    let server = Server::start(t.path(), &[SKY_EXR, "-o", "site"], None);
    // The endless line, written on a thread: the server answers before reading it all.
    let mut s = server.connect();
    let mut w = s.try_clone().unwrap();
    let writer = std::thread::spawn(move || {
        let _ = w.write_all(b"GET /");
        let _ = w.write_all(&vec![b'a'; 1 << 20]);
    });
    let (status, _) = answer(&mut s, "a 1 MiB request line");
    assert!(
        matches!(status, 414 | 400),
        "a 1 MiB request line: {status}"
    );
    drop(s);
    writer.join().unwrap();
    let host = format!("Host: {}\r\n", server.addr);
    let many: String = (0..100).map(|i| format!("X-{i}: {i}\r\n")).collect();
    let huge = format!("X-Big: {}\r\n", "b".repeat(40 << 10));
    for (what, head, want) in [
        (
            "100 headers",
            format!("GET / HTTP/1.1\r\n{host}{many}\r\n"),
            431,
        ),
        (
            "a 40 KiB header",
            format!("GET / HTTP/1.1\r\n{host}{huge}\r\n"),
            431,
        ),
        ("no version", format!("GET /\r\n{host}\r\n"), 400),
        (
            "a header without a colon",
            format!("GET / HTTP/1.1\r\n{host}oops\r\n\r\n"),
            400,
        ),
        ("PUT", format!("PUT /data.js HTTP/1.1\r\n{host}\r\n"), 405),
    ] {
        assert_eq!(server.raw(&head).0, want, "{what}");
    }
    assert_eq!(server.get("/index.html").0, 200);
    assert!(t.path().join("site/data.js").is_file());
}

/// A client that connects and says nothing is closed after the timeout; one that stops part
/// way through its request gets 408. The server serves on.
#[test]
fn serve_closes_idle_connections() {
    let t = tempfile::tempdir().unwrap();
    let server = Server::start(t.path(), &[SKY_EXR, "-o", "site"], Some(300));
    let start = Instant::now();
    let mut idle = server.connect();
    let mut buf = Vec::new();
    let read = std::io::Read::read_to_end(&mut idle, &mut buf);
    assert!(
        read.is_ok() && buf.is_empty() && start.elapsed() < Duration::from_secs(5),
        "an idle connection: {read:?}, {buf:?} after {:?}",
        start.elapsed()
    );
    let mut part = server.connect();
    part.write_all(b"GET /index.html HTTP/1.1\r\nHost: ")
        .unwrap();
    let start = Instant::now();
    assert_eq!(answer(&mut part, "half a request").0, 408);
    assert!(start.elapsed() < Duration::from_secs(5));
    assert_eq!(server.get("/").0, 200);
}

/// `Host` must name the bound address: another name (DNS rebinding) or port is 421, none is
/// 400; 127.0.0.1, localhost and [::1] at the port are served.
#[test]
fn serve_checks_the_host() {
    let t = tempfile::tempdir().unwrap();
    let server = Server::start(t.path(), &[SKY_EXR, "-o", "site"], None);
    let port = server.port();
    let head = |host: &str| format!("GET /index.html HTTP/1.1\r\n{host}Connection: close\r\n\r\n");
    for (host, want) in [
        (format!("Host: evil.example:{port}\r\n"), 421),
        ("Host: evil.example\r\n".to_owned(), 421),
        (format!("Host: 127.0.0.1:{}\r\n", port.wrapping_add(1)), 421),
        (format!("Host: localhost.evil.example:{port}\r\n"), 421),
        (String::new(), 400),
        (
            format!("Host: 127.0.0.1:{port}\r\nHost: evil.example:{port}\r\n"),
            400,
        ),
        (format!("Host: 127.0.0.1:{port}\r\n"), 200),
        (format!("Host: localhost:{port}\r\n"), 200),
        (format!("Host: [::1]:{port}\r\n"), 200),
    ] {
        assert_eq!(server.raw(&head(&host)).0, want, "{host:?}");
    }
}

/// Forty connections held open at once: those beyond the server's bound are answered 503 at
/// once (no thread each); closed, the server serves again.
#[test]
fn serve_bounds_connections() {
    let t = tempfile::tempdir().unwrap();
    let server = Server::start(t.path(), &[SKY_EXR, "-o", "site"], None);
    let held: Vec<TcpStream> = (0..40).map(|_| server.connect()).collect();
    let start = Instant::now();
    let (status, _) = server.get("/index.html");
    assert_eq!(status, 503, "a request beside 40 held connections");
    assert!(start.elapsed() < Duration::from_secs(5));
    drop(held);
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        match server.get("/index.html").0 {
            200 => break,
            503 if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(50)),
            s => panic!("after the held connections closed: {s}"),
        }
    }
    assert!(Path::new(&t.path().join("site/index.html")).is_file());
}
