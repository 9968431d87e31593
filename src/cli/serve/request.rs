//! One HTTP/1.x request head, read within bounds: the request line at most [`LINE_MAX`] bytes
//! (414 beyond), at most [`HEADERS_MAX`] header lines of [`HEADER_BYTES_MAX`] bytes in all
//! (431 beyond), everything before a deadline (408). A client cannot make the server hold more
//! than that, nor wait longer.

use std::io::{self, BufRead, Read};
use std::net::{IpAddr, SocketAddr, TcpStream};
use std::time::Instant;

pub const LINE_MAX: usize = 8 * 1024;
pub const HEADERS_MAX: usize = 64;
pub const HEADER_BYTES_MAX: usize = 32 * 1024;

/// A request's method, target (as sent) and `Host` header.
pub struct Request {
    pub method: String,
    pub target: String,
    pub host: Option<String>,
}

/// Why no request was read: the client left (or said nothing) before a request began, or the
/// status to answer.
pub enum Refused {
    Gone,
    Status(u16),
}

/// Reads from a stream until `until`: each read waits only for the time left, so a client that
/// sends a byte now and then is cut off all the same.
pub struct Timed<'a> {
    pub stream: &'a TcpStream,
    pub until: Instant,
}

impl Read for Timed<'_> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let left = self.until.saturating_duration_since(Instant::now());
        if left.is_zero() {
            return Err(io::ErrorKind::TimedOut.into());
        }
        self.stream.set_read_timeout(Some(left))?;
        (&mut &*self.stream).read(buf)
    }
}

enum Line {
    Text,
    TooLong,
    End,
}

/// One line into `line` without its CRLF (or LF), if it fits in `max` bytes with it (on an
/// error, `line` holds what came before it).
fn line(r: &mut impl BufRead, line: &mut Vec<u8>, max: usize) -> io::Result<Line> {
    line.clear();
    loop {
        let buf = r.fill_buf()?;
        if buf.is_empty() {
            return Ok(Line::End);
        }
        let (take, done) = match buf.iter().position(|&b| b == b'\n') {
            Some(i) => (i + 1, true),
            None => (buf.len(), false),
        };
        if line.len() + take > max {
            return Ok(Line::TooLong);
        }
        line.extend_from_slice(&buf[..take]);
        r.consume(take);
        if done {
            line.pop();
            if line.last() == Some(&b'\r') {
                line.pop();
            }
            return Ok(Line::Text);
        }
    }
}

fn timed_out(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
    )
}

/// The request head from `r`. A client that sends nothing before it leaves or its time runs
/// out is [`Refused::Gone`]; one that stops part way is 408.
pub fn read(r: &mut impl BufRead) -> Result<Request, Refused> {
    let fail = |e: io::Error, started: bool| match (timed_out(&e), started) {
        (true, true) => Refused::Status(408),
        _ => Refused::Gone,
    };
    let mut l = Vec::new();
    match line(r, &mut l, LINE_MAX) {
        Ok(Line::Text) => {}
        Ok(Line::TooLong) => return Err(Refused::Status(414)),
        Ok(Line::End) => return Err(Refused::Gone),
        Err(e) => return Err(fail(e, !l.is_empty())),
    };
    let first = String::from_utf8(std::mem::take(&mut l)).map_err(|_| Refused::Status(400))?;
    let parts: Vec<&str> = first.split(' ').collect();
    let [method, target, version] = parts[..] else {
        return Err(Refused::Status(400));
    };
    if !version.starts_with("HTTP/1.") || method.is_empty() || !target.starts_with('/') {
        return Err(Refused::Status(400));
    }
    let mut host = None;
    let (mut count, mut bytes) = (0, 0);
    loop {
        match line(r, &mut l, HEADER_BYTES_MAX - bytes) {
            Ok(Line::Text) => {}
            Ok(Line::TooLong) => return Err(Refused::Status(431)),
            Ok(Line::End) => return Err(Refused::Status(400)),
            Err(e) => return Err(fail(e, true)),
        };
        if l.is_empty() {
            break;
        }
        count += 1;
        bytes += l.len() + 2;
        if count > HEADERS_MAX {
            return Err(Refused::Status(431));
        }
        let text = std::str::from_utf8(&l).map_err(|_| Refused::Status(400))?;
        let (name, value) = text.split_once(':').ok_or(Refused::Status(400))?;
        if name.is_empty() || name.contains(char::is_whitespace) {
            return Err(Refused::Status(400));
        }
        if name.eq_ignore_ascii_case("host") && host.replace(value.trim().to_owned()).is_some() {
            // Two Host headers: which one the client meant is anyone's guess.
            return Err(Refused::Status(400));
        }
    }
    Ok(Request {
        method: method.to_owned(),
        target: target.to_owned(),
        host,
    })
}

/// Whether a `Host` header names the address the server listens on (`bound`, which `--bind`
/// spelled `bind`): its port, and its IP, or for a loopback address any loopback IP or
/// `localhost`, or for an unspecified address (0.0.0.0, ::) any IP literal. A name other than
/// `localhost` or the one `--bind` gave is refused: a page of another site whose name now
/// resolves here (DNS rebinding) sends its own name.
pub fn host_ok(host: &str, bound: SocketAddr, bind: &str) -> bool {
    let (name, port) = match host.strip_prefix('[') {
        Some(v6) => match v6.split_once(']') {
            Some((ip, rest)) => (ip, rest),
            None => return false,
        },
        None => match host.find(':') {
            Some(i) => (&host[..i], &host[i..]),
            None => (host, ""),
        },
    };
    let port = match port {
        "" => 80,
        p => match p.strip_prefix(':').and_then(|p| p.parse::<u16>().ok()) {
            Some(p) => p,
            None => return false,
        },
    };
    if port != bound.port() {
        return false;
    }
    let ip = bound.ip();
    let literal = host.starts_with('[') || name.parse::<std::net::Ipv4Addr>().is_ok();
    match name.parse::<IpAddr>() {
        Ok(named) if literal => {
            named == ip || (ip.is_loopback() && named.is_loopback()) || ip.is_unspecified()
        }
        Ok(_) => false,
        Err(_) => {
            let name = name.to_ascii_lowercase();
            (name == "localhost" && (ip.is_loopback() || ip.is_unspecified()))
                || name == bind.trim_matches(['[', ']']).to_ascii_lowercase()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hosts() {
        let lo: SocketAddr = "127.0.0.1:8123".parse().unwrap();
        for ok in [
            "127.0.0.1:8123",
            "localhost:8123",
            "LocalHost:8123",
            "[::1]:8123",
        ] {
            assert!(host_ok(ok, lo, "127.0.0.1"), "{ok}");
        }
        for bad in [
            "evil.example:8123",
            "127.0.0.1:8124",
            "127.0.0.1",
            "localhost",
            "[::1]",
            "127.0.0.1:8123x",
            "10.0.0.1:8123",
            "[::1:8123",
            "",
        ] {
            assert!(!host_ok(bad, lo, "127.0.0.1"), "{bad}");
        }
        let lan: SocketAddr = "192.168.1.5:9000".parse().unwrap();
        assert!(host_ok("192.168.1.5:9000", lan, "192.168.1.5"));
        assert!(!host_ok("localhost:9000", lan, "192.168.1.5"));
        assert!(!host_ok("127.0.0.1:9000", lan, "192.168.1.5"));
        assert!(host_ok("laptop.lan:9000", lan, "laptop.lan"));
        let any: SocketAddr = "0.0.0.0:9000".parse().unwrap();
        assert!(host_ok("192.168.1.5:9000", any, "0.0.0.0"));
        assert!(host_ok("localhost:9000", any, "0.0.0.0"));
        assert!(!host_ok("evil.example:9000", any, "0.0.0.0"));
    }
}
