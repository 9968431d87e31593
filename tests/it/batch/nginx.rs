//! Debian's nginx on loopback as a Bazel HTTP cache (WebDAV `PUT`, folders made as needed),
//! in its own temporary prefix on a free port, stopped when dropped. Missing, it skips the
//! test, and fails it under CI (which installs it).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A running nginx serving `root()` at `url()`.
pub(crate) struct Nginx {
    child: Option<Child>,
    prefix: PathBuf,
    port: u16,
}

/// A port nothing listens on now.
pub(crate) fn free_port() -> u16 {
    let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    l.local_addr().unwrap().port()
}

/// Waits until something accepts on `port` (false after `secs`).
pub(crate) fn listening(port: u16, secs: u64) -> bool {
    let end = Instant::now() + Duration::from_secs(secs);
    while Instant::now() < end {
        if std::net::TcpStream::connect(("127.0.0.1", port)).is_ok() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    false
}

impl Nginx {
    /// nginx under `prefix` (a fresh folder) asking every request for `Bearer token`; None
    /// (after a SKIPPED line) where nginx is not installed.
    pub(crate) fn start(prefix: &Path, token: &str) -> Option<Nginx> {
        let bin = ["/usr/sbin/nginx", "nginx"]
            .into_iter()
            .find(|b| Command::new(b).arg("-v").output().is_ok());
        let Some(bin) = bin else {
            assert!(
                std::env::var_os("CI").is_none(),
                "nginx is missing (Debian: nginx-light)"
            );
            eprintln!("SKIPPED: nginx is not installed");
            return None;
        };
        std::fs::create_dir_all(prefix.join("store")).unwrap();
        std::fs::create_dir_all(prefix.join("tmp")).unwrap();
        let port = free_port();
        let p = prefix.display();
        let conf = format!(
            r#"daemon off;
master_process off;
user root;
pid {p}/nginx.pid;
error_log {p}/error.log;
events {{ worker_connections 64; }}
http {{
    access_log {p}/access.log;
    client_body_temp_path {p}/tmp;
    server {{
        listen 127.0.0.1:{port};
        root {p}/store;
        client_max_body_size 0;
        location / {{
            if ($http_authorization != "Bearer {token}") {{ return 401; }}
            dav_methods PUT;
            create_full_put_path on;
            dav_access user:rw group:r all:r;
        }}
    }}
}}
"#
        );
        std::fs::write(prefix.join("nginx.conf"), conf).unwrap();
        let child = Command::new(bin)
            .arg("-p")
            .arg(prefix)
            .arg("-e")
            .arg(prefix.join("error.log"))
            .arg("-c")
            .arg(prefix.join("nginx.conf"))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("nginx starts");
        let n = Nginx {
            child: Some(child),
            prefix: prefix.to_path_buf(),
            port,
        };
        assert!(
            listening(port, 10),
            "nginx did not listen: {}",
            std::fs::read_to_string(prefix.join("error.log")).unwrap_or_default()
        );
        Some(n)
    }

    pub(crate) fn url(&self) -> String {
        format!("http://127.0.0.1:{}", self.port)
    }

    /// Where the cache's `ac/` and `cas/` are.
    pub(crate) fn root(&self) -> PathBuf {
        self.prefix.join("store")
    }

    /// How many `PUT`s the server has answered so far.
    pub(crate) fn puts(&self) -> usize {
        std::fs::read_to_string(self.prefix.join("access.log"))
            .unwrap_or_default()
            .lines()
            .filter(|l| l.contains("\"PUT "))
            .count()
    }

    /// Stops the server (a build then finds no cache).
    pub(crate) fn stop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

impl Drop for Nginx {
    fn drop(&mut self) {
        self.stop();
    }
}
